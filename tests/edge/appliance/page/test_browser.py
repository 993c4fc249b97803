"""The page in a real browser: headless Chromium (Debian's `chromium`, tools/_setup.sh installs it)
against a real `mast-stereo run` replaying the demo's scene. The live pictures refresh (each loads
several times), the track table lists the daemon's tracks, and the screenshot is saved (the docs'
docs/page.png is made the same way by tools/page-screenshot)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
import urllib.request
from collections.abc import Callable
from pathlib import Path

import pytest
from helpers import ROOT, free_port

from lab.page_browser import chromium, open_page

from .conftest import FRAMES, page_config


@pytest.mark.skipif(chromium() is None, reason="needs chromium (tools/_setup.sh installs it)")
def test_chromium_shows_live_pictures_and_the_tracks(tmp_path: Path, recording: Callable[..., Path]) -> None:
    port = free_port()
    config = page_config(tmp_path, recording("akashi-crossing", FRAMES), port)
    proc = subprocess.Popen([sys.executable, "-m", "edge.cli", "run", "--config", str(config)], cwd=ROOT,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                            env={**os.environ, "PYTHONUNBUFFERED": "1"})
    try:
        ids: set[int] = set()
        end = time.monotonic() + 60
        while not ids:  # the daemon is up and tracking
            assert time.monotonic() < end and proc.poll() is None, "the daemon did not start tracking"
            try:
                with urllib.request.urlopen(f"http://127.0.0.1:{port}/state.json", timeout=5) as r:
                    ids = {t["id"] for t in json.load(r)["tracks"]}
            except OSError:
                pass
            time.sleep(0.5)
        shot = tmp_path / "page.png"
        seen = open_page(f"http://127.0.0.1:{port}/", shot, min_loads=3, timeout_s=30)
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/state.json", timeout=5) as r:
            ids |= {t["id"] for t in json.load(r)["tracks"]}
    finally:
        proc.terminate()
        _, err = proc.communicate(timeout=20)
    assert seen.loads["left"] >= 3 and seen.loads["right"] >= 3, seen  # the pictures refresh
    assert seen.picture_width == 640  # scaled to page.image_width
    assert seen.tracks and {int(row[1]) for row in seen.tracks} <= ids, (seen.tracks, ids)
    assert all(row[2] in ("Q", "T", "L") for row in seen.tracks)
    assert seen.state in ("OK", "DEGRADED") and seen.stages >= 3
    assert shot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and shot.stat().st_size > 10_000
    assert "Traceback" not in err
