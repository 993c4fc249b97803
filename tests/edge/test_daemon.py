"""`mast-stereo run` as systemd runs it: a real NOTIFY_SOCKET, a real Modbus client, exit 78.

The daemon runs as a subprocess on the simulator (virtual cameras, paced in
real time); the test plays systemd's part with an AF_UNIX datagram socket and
the VTS's part with mbpoll against the Modbus TCP port.
"""

from __future__ import annotations

import datetime
import os
import re
import shutil
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
import yaml

from edge.errors import EX_CONFIG

ROOT = Path(__file__).resolve().parents[2]


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def start(config: Path, *extra: str, env: dict | None = None) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "edge.cli", "run", "--config", str(config), *extra],
                            cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env={**os.environ, **(env or {})})


def write_config(tmp_path: Path, port: int) -> Path:
    cfg = {"cameras": {"kind": "virtual", "scenario": "akashi-crossing", "seed": 3, "pace": True},
           "outputs": {"modbus": {"tcp": {"enabled": True, "host": "127.0.0.1", "port": port}}}}
    path = tmp_path / "live.yaml"
    path.write_text(yaml.safe_dump(cfg))
    return path


@pytest.mark.skipif(not shutil.which("mbpoll"), reason="needs mbpoll (tools/test installs it)")
def test_daemon_notifies_systemd_and_serves_modbus_while_running(tmp_path: Path) -> None:
    notify = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
    notify_path = str(tmp_path / "notify.sock")
    notify.bind(notify_path)
    notify.settimeout(1.0)
    messages: list[str] = []
    done = threading.Event()

    def drain() -> None:  # like PID 1: always reading, so sd_notify never blocks on a full queue
        while not done.is_set():
            try:
                messages.append(notify.recv(4096).decode())
            except TimeoutError:
                pass

    reader = threading.Thread(target=drain, daemon=True)
    reader.start()
    port = free_port()
    proc = start(write_config(tmp_path, port), "--seconds", "12", "--print-nmea",
                 env={"NOTIFY_SOCKET": notify_path, "WATCHDOG_USEC": "2000000"})
    try:
        end = time.monotonic() + 60
        while not any("WATCHDOG=1" in m for m in messages) and time.monotonic() < end:
            time.sleep(0.1)
        assert messages and messages[0].startswith("READY=1"), messages
        # mbpoll (libmodbus) reads identity and health: probe, map version, update counter advancing
        reads = []
        for _ in range(2):
            out = subprocess.run(["mbpoll", "-m", "tcp", "-p", str(port), "-a", "1", "-0", "-1", "-t", "3",
                                  "-r", "0", "-c", "30", "127.0.0.1"],
                                 capture_output=True, text=True, timeout=10)
            assert out.returncode == 0, out.stdout + out.stderr
            reads.append({int(a): int(v) for a, v in re.findall(r"\[(\d+)\]:\s+(-?\d+)", out.stdout)})
            time.sleep(1.5)
        assert reads[0][0] == 1  # MAP_VERSION
        assert (reads[0][4], reads[0][5]) == (0x1234, 0x5678)  # probe, high word first
        assert reads[1][27] != reads[0][27]  # UPDATE_COUNTER moves while processing runs
        stdout, stderr = proc.communicate(timeout=60)
        assert proc.returncode == 0, stderr
        time.sleep(1.5)  # let the reader take the last datagrams
        assert any(m.startswith("STATUS=") for m in messages)
        assert messages[-1].startswith("STOPPING=1")
        assert re.search(r"^\$RATTM,\d\d,", stdout, re.M), stdout[-2000:]
        assert_utc_is_now(stdout)
    finally:
        proc.kill()
        done.set()
        reader.join()
        notify.close()


def assert_utc_is_now(nmea: str) -> None:
    """The TTM time of measurement is UTC now (within the run), whatever clock the source stamps."""
    stamps = re.findall(r"^\$RATTM,(?:[^,]*,){13}(\d{6}\.\d\d),", nmea, re.M)
    assert stamps, nmea[-1000:]
    now = datetime.datetime.now(datetime.UTC)
    for stamp in stamps:
        t = now.replace(hour=int(stamp[:2]), minute=int(stamp[2:4]), second=int(stamp[4:6]), microsecond=0)
        assert abs((now - t).total_seconds() % 86400) < 120 or abs((t - now).total_seconds() % 86400) < 120


def test_a_replayed_recording_reports_utc_now_not_its_own_clock(tmp_path: Path, recording) -> None:
    root = recording("akashi-crossing", 40)
    path = tmp_path / "replay.yaml"
    path.write_text(yaml.safe_dump({"cameras": {"kind": "replay", "path": str(root), "pace": False},
                                    "outputs": {"modbus": {"tcp": {"enabled": False}}}}))
    proc = start(path, "--print-nmea")
    stdout, stderr = proc.communicate(timeout=120)
    assert proc.returncode == 0, stderr
    assert_utc_is_now(stdout)


@pytest.mark.parametrize("case, text, key", [
    ("v4l2 without a driver", "cameras: {kind: v4l2}\ncalibration: {}\n", "calibration"),
    ("unknown scenario", "cameras: {kind: virtual, scenario: no-such-sea}\n", "no-such-sea"),
    ("bad port", "outputs: {modbus: {tcp: {port: 70000}}}\n", "outputs.modbus.tcp.port"),
])
def test_bad_configuration_exits_78_before_running(tmp_path: Path, case: str, text: str, key: str) -> None:
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    proc = start(path)
    _, stderr = proc.communicate(timeout=60)
    assert proc.returncode == EX_CONFIG, stderr
    assert "Traceback" not in stderr and key in stderr and len(stderr.strip().splitlines()) == 1


def test_capture_queue_keeps_the_newest_pair_and_counts_drops() -> None:
    import numpy as np

    from drivers.camera.base import FramePair
    from edge.daemon import _Latest

    q = _Latest()
    img = np.zeros((4, 4), np.uint8)
    for k in range(3):
        q.put(FramePair(img, img, k, k, k, k, k))
    got = q.get(0.1)
    assert got is not None and got[0].t_ns == 2 and q.dropped == 2 and got[1] > 0
    assert q.get(0.01) is None and not q.ended
    q.end()
    assert q.get(1.0) is None and q.ended
