"""tests/vm on sys.path, so the VM tests share `systemd_harness` (importlib mode adds nothing)."""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
