"""Test-suite set-up: `tests/` on sys.path so test modules share `helpers` (importlib mode adds nothing)."""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
