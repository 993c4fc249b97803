"""Runs the calling tool under the project's venv (.venv), so every tools/ entry point works from a
fresh clone after `tools/test` with nothing activated.

`tools/_setup.sh` creates .venv with the project installed editable and a .pth that puts the
repository root (and so the `lab` package, which the wheel leaves out) on the venv's path. A tool
started by another interpreter is re-executed by the venv's, with its arguments unchanged.
"""

import os
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
VENV = ROOT / ".venv"


def _in_venv() -> bool:
    return Path(sys.prefix).resolve() == VENV.resolve()


if not _in_venv():
    python = VENV / "bin" / "python"
    if not python.exists():
        sys.exit(f"{sys.argv[0]}: the project's venv is missing; run tools/test (or tools/demo) once first")
    os.environ["PATH"] = f"{VENV / 'bin'}{os.pathsep}{os.environ.get('PATH', '')}"
    os.execv(python, [str(python), sys.argv[0], *sys.argv[1:]])
