"""In the VM: `mast-stereo run` on two vivid cameras, as on the mast: READY after the first pair,
NMEA and STATUS lines, and a camera unplugged and replugged (vivid's `disconnect`) turns the
appliance DEGRADED and back to OK while the daemon keeps running, without a traceback."""

from __future__ import annotations

import os
import re
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import yaml

from drivers.camera.v4l2_node import Node

LEFT, RIGHT = "/dev/video0", "/dev/video2"
ROOT = Path(__file__).resolve().parents[2]
FX_PX = 406.0  # 320 px over a 43 deg field of view


def config(tmp_path: Path) -> Path:
    site = {"lat_deg": 34.63, "lon_deg": 135.02, "height_m": 25.0, "heading_deg": 180.0}
    camera = {"model": "pinhole", "fx": FX_PX, "fy": FX_PX, "cx": 159.5, "cy": 89.5,
              "dist": [0, 0, 0, 0, 0], "rotation_deg": [0, 0, 0]}
    cfg = {"cameras": {"kind": "v4l2", "left": {"device": LEFT}, "right": {"device": RIGHT},
                       "width": 320, "height": 180, "pixel_format": "YUYV", "fps": 10.0,
                       "trigger": {"kind": "none", "rate_hz": 10.0}},
           "calibration": {"baseline_m": 8.14, "image": {"width": 320, "height": 180},
                           "cameras": {"left": camera, "right": camera},
                           "site": site},
           "outputs": {"modbus": {"tcp": {"enabled": False}}},
           "health": {"stale_s": 20.0, "min_fps": 0.0, "require_clock_sync": False}}
    path = tmp_path / "vivid.yaml"
    path.write_text(yaml.safe_dump(cfg))
    return path


def test_daemon_on_vivid_survives_a_camera_unplug(tmp_path: Path) -> None:
    sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
    sock.bind(str(tmp_path / "notify"))
    sock.settimeout(0.5)
    messages: list[str] = []
    done = threading.Event()

    def drain() -> None:
        while not done.is_set():
            try:
                messages.append(sock.recv(4096).decode())
            except TimeoutError:
                pass

    threading.Thread(target=drain, daemon=True).start()
    env = {**os.environ, "NOTIFY_SOCKET": str(tmp_path / "notify")}
    proc = subprocess.Popen([sys.executable, "-m", "edge.cli", "run", "--config", str(config(tmp_path)),
                             "--print-nmea"], cwd=ROOT, env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)

    def wait(pattern: str, timeout_s: float, after: int = 0) -> int:
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            for k, m in enumerate(messages[after:], after):
                if re.search(pattern, m):
                    return k
            assert proc.poll() is None, proc.stderr.read() if proc.stderr else ""
            time.sleep(0.2)
        raise AssertionError(f"no {pattern!r} in {messages[-5:]}")

    try:
        ready = wait(r"^READY=1", 180.0)
        node = Node(RIGHT)
        node.set("disconnect", 1)  # vivid: the node is unregistered until its last user closes it,
        try:  # so holding it open keeps the camera unplugged for as long as a person would
            degraded = wait(r"STATUS=DEGRADED.*camera_right", 60.0, after=ready)
        finally:
            node.close()
        wait(r"STATUS=OK", 90.0, after=degraded)
        proc.send_signal(signal.SIGTERM)
        out, err = proc.communicate(timeout=30)
        print(f"READY after {ready} messages; {err.count(chr(10))} log lines")
        assert proc.returncode == 0, err[-3000:]
        assert "Traceback" not in err, err[-3000:]
        processed = re.search(r"stopped: (\d+) pairs processed", err)
        assert processed and int(processed.group(1)) > 0, err[-2000:]
        assert "camera_right" in err and "recovered" in err  # logged once as it started, once as it cleared
    finally:
        proc.kill()
        done.set()
        sock.close()


def test_record_from_vivid_gives_a_recording_replay_accepts(tmp_path: Path) -> None:
    out = tmp_path / "rec"
    record = subprocess.run([sys.executable, "-m", "edge.cli", "record", "--config", str(config(tmp_path)),
                             "--out", str(out), "--frames", "12"], cwd=ROOT, capture_output=True, text=True,
                            timeout=240)
    assert record.returncode == 0, record.stderr[-3000:]
    rows = (out / "frames.csv").read_text().splitlines()
    assert rows[0].startswith("index,t_ns,seq_left,seq_right") and len(rows) == 13
    replay = subprocess.run([sys.executable, "-m", "edge.cli", "replay", str(out), "--tracks",
                             str(tmp_path / "t.csv")], cwd=ROOT, capture_output=True, text=True, timeout=240)
    assert replay.returncode == 0, replay.stderr[-3000:]
    assert re.search(r"read 12, skipped \(unreadable\) 0", replay.stderr), replay.stderr
