# Sourced by tools/test and tools/demo: installs what a fresh Debian machine lacks,
# idempotently, and quickly when everything is already there.
#  - as root: Debian packages needed to build systemd-python (libsystemd-dev, pkg-config)
#    and the real peers the tests talk to (socat for pty pairs, mbpoll as an independent
#    Modbus client, tshark as an independent ASTERIX decoder; g++ builds asterix-decoder;
#    chromium, headless, opens the maintenance page; gcc and python3-dev build the compiled kernels);
#  - a venv in .venv with the project installed editable, with the test, plots and docs extras, and
#    the compiled kernels (native/, built by meson-python with the C compiler; rebuilt when they change).
set -euo pipefail
# `TOOL -h|--help`: the calling tool's header comment (its usage), before anything is installed.
if [[ "${1:-}" == "-h" || "${1:-}" == "--help" ]]; then
    sed -n '2,/^[^#]/p' "$0" | sed -e '/^[^#]/d' -e 's/^# \{0,1\}//'
    exit 0
fi
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"

APT_PACKAGES=(libsystemd-dev pkg-config gcc python3-dev socat mbpoll tshark g++ chromium)
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

# The appliance VM for tests/vm (qemu + Debian's kernel with vivid, gpio-sim and uleds), built outside
# the repository by the shared harness when its artifacts are missing; tests/vm/vmharness.py runs it.
VM_HARNESS="$ROOT/../shared/tools/appliance-vm"
[[ -d "$VM_HARNESS" ]] || VM_HARNESS=/work/shared/tools/appliance-vm  # a clone outside the workplace
VM_DIR="${V4L2VM_DIR:-/var/tmp/appliance-vm}"
if [[ -x "$VM_HARNESS/build.sh" ]]; then
    if [[ ! -e "$VM_DIR/vmlinuz" || ! -e "$VM_DIR/initramfs.cpio.gz" || ! -s "$VM_DIR/kmods/gpio-sim.ko" ]] \
        || ! grep -qx gpio-sim.ko "$VM_DIR/initramfs/etc/modules.list" 2>/dev/null \
        || ! command -v qemu-system-x86_64 >/dev/null; then
        if [[ $(id -u) -eq 0 ]]; then
            echo "setup: building the appliance VM in $VM_DIR (once; ~30 s)" >&2
            V4L2VM_DIR="$VM_DIR" V4L2VM_KMODS=1 "$VM_HARNESS/build.sh" >&2
        else
            echo "setup: the appliance VM is not built in $VM_DIR; run as root once (tests/vm will skip)" >&2
        fi
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
    .venv/bin/python -m pip install -q -e ".[test,plots,docs]" >&2
    echo "$want" > "$stamp"
fi
# the compiled kernels (native/: C, meson-python): a wheel of its own, installed (not editable), so
# rebuilt here whenever its sources change
native_stamp=".venv/.mast-stereo-native-installed"
native_want="$(find native -type f ! -path '*/build/*' | LC_ALL=C sort | xargs sha256sum | sha256sum | cut -d' ' -f1)"
if [[ ! -f "$native_stamp" || "$(cat "$native_stamp")" != "$native_want" ]]; then
    echo "setup: building the compiled kernels (native/)" >&2
    .venv/bin/python -m pip install -q --force-reinstall ./native >&2
    echo "$native_want" > "$native_stamp"
fi
# The lab package (evaluation, benchmarks, fault injection, fake devices) is not in the wheel: a .pth
# puts the checkout's root on the venv's path so tests, tools and their child processes import it.
site="$(.venv/bin/python -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])')"
[[ "$(cat "$site/mast_stereo_lab.pth" 2>/dev/null)" == "$ROOT" ]] || echo "$ROOT" > "$site/mast_stereo_lab.pth"
export PATH="$ROOT/.venv/bin:$PATH"
