"""Every tools/ entry point answers --help from a clean environment: no venv activated, no
PYTHONPATH, a bare PATH, as a user runs it after `tools/test` in a fresh clone."""

from __future__ import annotations

import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
TOOLS = sorted(p for p in (ROOT / "tools").iterdir()
               if p.is_file() and p.suffix != ".py" and not p.name.startswith("_"))


@pytest.mark.parametrize("tool", TOOLS, ids=lambda p: p.name)
def test_tool_answers_help_unactivated(tool: Path, tmp_path: Path) -> None:
    env = {"PATH": "/usr/local/bin:/usr/bin:/bin", "HOME": str(tmp_path), "LANG": "C.UTF-8"}
    proc = subprocess.run([str(tool), "--help"], capture_output=True, text=True, timeout=120, env=env,
                          cwd=tmp_path)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    text = proc.stdout + proc.stderr
    assert "Traceback" not in text and "ModuleNotFoundError" not in text, text
    assert len(text.strip().splitlines()) >= 2, f"{tool.name} --help says too little: {text!r}"
