"""Guest-only hardware tests: they need the appliance VM's vivid cameras and gpio-sim, so they skip elsewhere.

tests/vm/test_capture_vm.py boots the VM once and runs this directory there
(`V4L2VM_GUEST=1` is set by the harness); on the host they are collected and skipped.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest


def in_guest() -> bool:
    return os.environ.get("V4L2VM_GUEST") == "1" and Path("/dev/video0").exists()


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    if not in_guest():
        skip = pytest.mark.skip(reason="guest-only (vivid cameras, gpio-sim): tests/vm runs these in the VM")
        for item in items:
            if "tests/hw/" in str(item.fspath).replace(os.sep, "/"):
                item.add_marker(skip)
