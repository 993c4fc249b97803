#!/usr/bin/env bash
# The C core built for x86-64 and for aarch64 (cross compiler, run under qemu-user), the same inputs,
# the hashes of their outputs compared (native/README.md, "aarch64"). Needs gcc, gcc-aarch64-linux-gnu,
# libc6-dev-arm64-cross and qemu-user (apt), and the project's venv (the log2 table comes from
# edge.core.fixedpoint).
set -euo pipefail
HERE=$(cd "$(dirname "$0")" && pwd)
ROOT=$(cd "$HERE/../.." && pwd)
PY=${PYTHON:-$ROOT/.venv/bin/python}
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
PYTHONPATH=$ROOT "$PY" -c "
from edge.core.fixedpoint import LOG2_TABLE
print('static const int64_t LOG2_TABLE[] = {' + ', '.join(str(v) + 'LL' for v in LOG2_TABLE.tolist()) + '};')
" > "$out/log2_table.h"
src=(fixedpoint.c remap.c match.c follow.c imm.c)
flags=(-std=c99 -O3 -ffp-contract=off -fno-fast-math -I"$out")
gcc "${flags[@]}" -o "$out/x86" "$HERE/harness.c" "${src[@]/#/$HERE/../src/}" -lm
aarch64-linux-gnu-gcc "${flags[@]}" -static -o "$out/arm" "$HERE/harness.c" "${src[@]/#/$HERE/../src/}" -lm
a=$("$out/x86"); b=$(qemu-aarch64 "$out/arm")
printf 'x86-64:\n%s\naarch64 (qemu-user):\n%s\n' "$a" "$b"
[[ "$(head -2 <<<"$a")" == "$(head -2 <<<"$b")" ]] || { echo "cross: the integer kernels differ" >&2; exit 1; }
if [[ "$a" == "$b" ]]; then echo "cross: bit-identical on both"
else echo "cross: integer kernels identical; the ground filter's floats differ (libm's exp)"; fi
