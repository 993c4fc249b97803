# Sourced by tools/test and tools/demo: installs what a fresh Debian machine lacks,
# idempotently, and quickly when everything is already there.
#  - as root: Debian packages needed to build systemd-python (libsystemd-dev, pkg-config)
#    and the real peers the tests talk to (socat for pty pairs, mbpoll as an independent
#    Modbus client);
#  - a venv in .venv with the project installed editable, with the test and plots extras.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"

APT_PACKAGES=(libsystemd-dev pkg-config socat mbpoll)
missing=()
for p in "${APT_PACKAGES[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
    if [[ $(id -u) -eq 0 ]]; then
        echo "setup: installing Debian packages: ${missing[*]}" >&2
        export DEBIAN_FRONTEND=noninteractive
        apt-get update -qq >&2
        apt-get install -y -qq --no-install-recommends "${missing[@]}" >&2
    else
        echo "setup: missing Debian packages (${missing[*]}); run as root or install them" >&2
    fi
fi

PY="${PYTHON:-}"
if [[ -z "$PY" ]]; then
    for c in python3.13 python3.12 python3.11 python3; do
        if command -v "$c" >/dev/null && "$c" -c 'import sys; sys.exit(sys.version_info < (3, 11))' 2>/dev/null; then
            PY="$c"; break
        fi
    done
fi
[[ -n "$PY" ]] || { echo "setup: need Python >= 3.11" >&2; exit 1; }

if [[ ! -x .venv/bin/python ]]; then
    echo "setup: creating .venv with $PY" >&2
    "$PY" -m venv .venv
fi
stamp=".venv/.mast-stereo-installed"
want="$(cat pyproject.toml | sha256sum | cut -d' ' -f1)"
if [[ ! -f "$stamp" || "$(cat "$stamp")" != "$want" ]]; then
    echo "setup: installing the project into .venv" >&2
    .venv/bin/python -m pip install -q --upgrade pip >&2
    .venv/bin/python -m pip install -q -e ".[test,plots]" >&2
    echo "$want" > "$stamp"
fi
export PATH="$ROOT/.venv/bin:$PATH"
