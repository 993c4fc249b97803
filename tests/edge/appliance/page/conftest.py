"""A running appliance with its page: the real daemon in this process, replaying the session's short
akashi-crossing recording at its frame rate, the page on a free loopback port."""

from __future__ import annotations

import threading
import time
import urllib.request
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
import yaml
from helpers import free_port

from drivers.notify import VirtualNotifier
from edge.appliance.daemon import Appliance
from edge.config.app import load_config

FRAMES = 30  # the recording the replay and fault tests render too (rendered once per session)


def page_config(tmp_path: Path, recording: Path, port: int, **page: Any) -> Path:
    cfg = {"cameras": {"kind": "replay", "path": str(recording), "pace": True, "loop": True},
           "outputs": {"modbus": {"tcp": {"enabled": False}}},
           "health": {"require_clock_sync": False, "min_fps": 0.0, "leds": {"kind": "virtual"},
                      "state_dir": str(tmp_path / "state")},
           "page": {"enabled": True, "port": port, "docs_dir": None, **page}}
    path = tmp_path / "page.yaml"
    path.write_text(yaml.safe_dump(cfg))
    return path


class Running:
    def __init__(self, app: Appliance, port: int) -> None:
        self.app, self.port = app, port

    def get(self, path: str, headers: dict[str, str] | None = None) -> bytes:
        req = urllib.request.Request(f"http://127.0.0.1:{self.port}{path}", headers=headers or {})
        with urllib.request.urlopen(req, timeout=10) as r:
            return bytes(r.read())

    def wait(self, until: Callable[[], bool], timeout_s: float = 60.0) -> None:
        end = time.monotonic() + timeout_s
        while not until():
            assert time.monotonic() < end, "timed out"
            time.sleep(0.1)


@pytest.fixture
def running(tmp_path: Path, recording: Callable[..., Path]) -> Iterator[Running]:
    port = free_port()
    path = page_config(tmp_path, recording("akashi-crossing", FRAMES), port)
    app = Appliance.build(load_config(path), path, VirtualNotifier())
    stop = threading.Event()
    thread = threading.Thread(target=app.run, args=(stop,), daemon=True)
    thread.start()
    run = Running(app, port)
    run.wait(lambda: app.page is not None and app.page.server is not None and app.steps > 0)
    yield run
    stop.set()
    thread.join(timeout=10)
