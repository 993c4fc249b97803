"""`mast-stereo run` as systemd runs it: a real NOTIFY_SOCKET, a real Modbus client, exit 78.

The daemon runs as a subprocess on the simulator (virtual cameras, paced in
real time); the test plays systemd's part with an AF_UNIX datagram socket and
the VTS's part with mbpoll against the Modbus TCP port.
"""

from __future__ import annotations

import datetime
import io
import logging
import os
import re
import shutil
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
import yaml
from helpers import free_port

from edge.appliance.daemon import Appliance
from edge.config.app import load_config
from edge.errors import EX_CONFIG
from lab.faults._rig import NotifyListener

ROOT = Path(__file__).resolve().parents[3]


def start(config: Path, *extra: str, env: dict | None = None) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "edge.cli", "run", "--config", str(config), *extra],
                            cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env={**os.environ, **(env or {})})


def write_config(tmp_path: Path, port: int) -> Path:
    cfg = {"cameras": {"kind": "virtual", "scenario": "akashi-crossing", "seed": 3, "pace": True},
           "outputs": {"modbus": {"tcp": {"enabled": True, "host": "127.0.0.1", "port": port}}},
           # the simulator renders live on a shared 2-core machine: give a slow frame 10 s before it
           # counts as a stuck camera (which would rightly stop the watchdog)
           "health": {"stale_s": 10.0, "min_fps": 0.0}}
    path = tmp_path / "live.yaml"
    path.write_text(yaml.safe_dump(cfg))
    return path


class NotifySocket(NotifyListener):
    """systemd's side of sd_notify (lab.faults' listener: a datagram socket read all the time, so the
    daemon never blocks on a full queue, each message with its CLOCK_MONOTONIC arrival time), waited
    on by message index."""

    def wait_for(self, prefix: str, timeout_s: float = 60.0, after: int = 0) -> int:  # type: ignore[override]
        """Index of the first message starting with `prefix` at or after index `after`."""
        end = time.monotonic() + timeout_s
        while time.monotonic() < end:
            for k, (_, m) in enumerate(self.messages[after:], after):
                if m.startswith(prefix):
                    return k
            time.sleep(0.05)
        raise AssertionError(f"no {prefix!r} in {[m for _, m in self.messages]}")


@pytest.fixture
def notify(tmp_path: Path):
    sock = NotifySocket(tmp_path / "notify.sock")
    yield sock
    sock.close()


def mbpoll(port: int, start: int = 0, count: int = 30) -> dict[int, int]:
    """libmodbus's client reads holding registers (FC3) from the daemon."""
    out = subprocess.run(["mbpoll", "-m", "tcp", "-p", str(port), "-a", "1", "-0", "-1", "-t", "3",
                          "-r", str(start), "-c", str(count), "127.0.0.1"],
                         capture_output=True, text=True, timeout=10)
    assert out.returncode == 0, out.stdout + out.stderr
    return {int(a): int(v) for a, v in re.findall(r"\[(\d+)\]:\s+(-?\d+)", out.stdout)}


@pytest.mark.skipif(not shutil.which("mbpoll"), reason="needs mbpoll (tools/test installs it)")
def test_daemon_lifecycle_under_a_real_notify_socket(tmp_path: Path, notify: NotifySocket) -> None:
    """READY only after the first processed pair (the register image has been published by then),
    WATCHDOG=1 at half WATCHDOG_USEC, Modbus answering, and SIGTERM: STOPPING=1, every live track
    sent as lost, exit 0 within 2 s."""
    port = free_port()
    proc = start(write_config(tmp_path, port), "--print-nmea",
                 env={"NOTIFY_SOCKET": notify.path, "WATCHDOG_USEC": "2000000"})
    try:
        ready = notify.wait_for("READY=1")
        before = [m for _, m in notify.messages[:ready]]
        assert all(m.startswith(("EXTEND_TIMEOUT_USEC=", "WATCHDOG=1")) for m in before), before
        first = mbpoll(port)
        assert first[0] == 2 and (first[4], first[5]) == (0x1234, 0x5678)  # map version (2: issue 17), probe
        assert first[27] >= 1  # UPDATE_COUNTER: the first pair was processed and published before READY
        assert first[17] & (1 << 3) and first[17] & (1 << 7)  # STATUS: CALIBRATION_VALID, SITE_SURVEYED
        lines: list[str] = []
        threading.Thread(target=lambda: lines.extend(proc.stdout), daemon=True).start()  # type: ignore[arg-type]
        end = time.monotonic() + 90
        while not any(re.match(r"^\$RATTM,(?:[^,]*,){11}T,", ln) for ln in lines) and time.monotonic() < end:
            time.sleep(0.2)
        second = mbpoll(port)
        assert second[27] != first[27]  # the counter moves while processing runs
        end = time.monotonic() + 30
        while len(notify.times("WATCHDOG=1")) < 6 and time.monotonic() < end:
            time.sleep(0.2)
        pings = notify.times("WATCHDOG=1")
        gaps = [b - a for a, b in zip(pings, pings[1:], strict=False)]
        assert len(gaps) >= 4 and 0.5 < sorted(gaps)[len(gaps) // 2] < 1.5, gaps  # half of 2 s
        assert any(m.startswith("STATUS=OK") or m.startswith("STATUS=DEGRADED")
                   for _, m in notify.messages[ready:])
        proc.send_signal(signal.SIGTERM)
        sent_s = time.monotonic()
        proc.wait(timeout=10)
        gone_s = time.monotonic() - sent_s
        stderr = proc.stderr.read()  # type: ignore[union-attr]
        time.sleep(0.3)
        stdout = "".join(lines)
        assert proc.returncode == 0, stderr
        assert gone_s < 2.0, f"exit took {gone_s:.2f} s"
        notify.wait_for("STOPPING=1", timeout_s=2.0)
        ttm = re.findall(r"^\$RATTM,(\d\d),(?:[^,]*,){10}([QTL]),", stdout, re.M)
        assert ttm, stdout[-2000:]
        last_status = {number: status for number, status in ttm}
        assert set(last_status.values()) == {"L"}, last_status  # every track's last word: lost
        assert_utc_is_now(stdout)
    finally:
        proc.kill()


@pytest.mark.skipif(not shutil.which("mbpoll"), reason="needs mbpoll (tools/test installs it)")
def test_sighup_keeps_a_broken_config_out_and_applies_a_valid_one(tmp_path: Path,
                                                                  notify: NotifySocket) -> None:
    port, new_port = free_port(), free_port()
    config = write_config(tmp_path, port)
    proc = start(config, env={"NOTIFY_SOCKET": notify.path})
    try:
        ready = notify.wait_for("READY=1")
        config.write_text("outputs: {modbus: {tcp: {port: not-a-port}}}\n")
        proc.send_signal(signal.SIGHUP)
        time.sleep(3.0)
        assert proc.poll() is None
        assert not any(m.startswith("RELOADING=1") for _, m in notify.messages)
        assert any("reload refused" in m for _, m in notify.messages[ready:])  # in STATUS
        assert mbpoll(port)[0] == 2  # (map version) still serving on the old configuration
        write_config(tmp_path, new_port)
        proc.send_signal(signal.SIGHUP)
        reloading = notify.wait_for("RELOADING=1", timeout_s=20.0)
        assert re.search(r"MONOTONIC_USEC=\d+", notify.messages[reloading][1])
        notify.wait_for("READY=1", timeout_s=20.0, after=reloading)
        assert mbpoll(new_port)[0] == 2  # the new port serves (map version 2)
        proc.send_signal(signal.SIGTERM)
        _, stderr = proc.communicate(timeout=10)
        assert proc.returncode == 0 and "reload refused" in stderr and "not-a-port" in stderr, stderr
    finally:
        proc.kill()


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
    ("v4l2 without a calibration", "cameras: {kind: v4l2}\n", "calibration"),
    ("v4l2 camera without a device", "cameras: {kind: v4l2, left: {dev: /dev/video0}}\n", "cameras.left"),
    ("v4l2 unknown trigger", "cameras: {kind: v4l2, trigger: {kind: gpoi}}\n", "cameras.trigger"),
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


def _replay_config(root: Path, **health: float) -> dict:
    """A recording looped at its own pace, no Modbus port."""
    return {"cameras": {"kind": "replay", "path": str(root), "pace": True, "loop": True},
            "outputs": {"modbus": {"tcp": {"enabled": False}}}, "health": {"min_fps": 0.0, **health}}


def _replay_appliance(tmp_path: Path, root: Path, notifier, **health: float) -> Appliance:
    path = tmp_path / "appliance.yaml"
    path.write_text(yaml.safe_dump(_replay_config(root, **health)))
    return Appliance.build(load_config(path), path, notifier)


def test_watchdog_stops_within_one_interval_when_processing_hangs(tmp_path: Path, recording, notify,
                                                                  monkeypatch) -> None:
    """A real NOTIFY_SOCKET and WATCHDOG_USEC=1 s (pings every 0.5 s): once a step hangs, the pings
    stop after the stage goes stale (stale_s) plus at most one interval; systemd would restart."""
    from drivers.notify import SystemdNotifier

    monkeypatch.setenv("NOTIFY_SOCKET", notify.path)
    monkeypatch.setenv("WATCHDOG_USEC", "1000000")
    monkeypatch.delenv("WATCHDOG_PID", raising=False)
    app = _replay_appliance(tmp_path, recording("akashi-crossing", 30), SystemdNotifier(), stale_s=1.0)
    hang, hung_at = threading.Event(), []
    real_step = app.pipeline.step

    def step(pair):
        if hang.is_set():
            hung_at.append(time.monotonic())
            threading.Event().wait(30.0)  # stuck code
        return real_step(pair)

    app.pipeline.step = step  # type: ignore[method-assign]
    stop = threading.Event()
    runner = threading.Thread(target=app.run, args=(stop,), daemon=True)
    runner.start()
    try:
        notify.wait_for("READY=1")
        time.sleep(2.0)
        hang.set()
        time.sleep(4.0)
        pings = notify.times("WATCHDOG=1")
        assert hung_at and len([t for t in pings if t < hung_at[0]]) >= 3
        assert pings[-1] <= hung_at[0] + 1.0 + 0.5 + 0.3, (pings[-1] - hung_at[0])
    finally:
        stop.set()
        runner.join(timeout=5.0)


def test_reload_without_camera_or_pipeline_change_keeps_tracks_and_numbers(tmp_path: Path, recording) -> None:
    from drivers.notify import VirtualNotifier
    from edge.outputs.nmea_stream import NmeaStreamOutput

    notifier = VirtualNotifier()
    base = _replay_config(recording("akashi-crossing", 30))
    path = tmp_path / "appliance.yaml"
    path.write_text(yaml.safe_dump(base))
    stream = NmeaStreamOutput(io.StringIO())
    app = Appliance.build(load_config(path), path, notifier, extra_nmea=[stream])
    stop = threading.Event()
    runner = threading.Thread(target=app.run, args=(stop,), daemon=True)
    runner.start()
    try:
        end = time.monotonic() + 60
        while not stream.scheduler.numbers.number_of(1) and time.monotonic() < end:
            time.sleep(0.1)
        pipeline, number = app.pipeline, stream.scheduler.numbers.number_of(1)
        assert number is not None
        path.write_text(yaml.safe_dump({**base, "logging": {"level": "DEBUG"}}))
        assert app.reload()
        assert app.pipeline is pipeline and stream.scheduler.numbers.number_of(1) == number
        assert logging.getLogger().level == logging.DEBUG
        path.write_text(yaml.safe_dump({**base, "pipeline": {"window": 21}}))
        assert app.reload() and app.pipeline is not pipeline  # new matching settings: tracks restart
        assert any(m.startswith("RELOADING=1\nMONOTONIC_USEC=") for m in notifier.messages)
    finally:
        stop.set()
        runner.join(timeout=5.0)
        logging.getLogger().setLevel(logging.WARNING)


def test_an_unplugged_camera_is_degraded_on_leds_and_modbus_while_the_pings_go_on(
        tmp_path: Path, recording, monkeypatch) -> None:
    """Virtual LEDs: green heartbeat while OK; a camera reporting a fault (unplugged) makes it DEGRADED:
    green and red blink together (no amber LED configured), the Modbus STATUS word says DEGRADED, and
    WATCHDOG=1 goes on; replugged, OK again; steady red once stopped."""
    from drivers.leds.virtual import VirtualLedPanel
    from drivers.notify import VirtualNotifier
    from edge.appliance.health import Status

    monkeypatch.setenv("WATCHDOG_USEC", "2000000")
    monkeypatch.delenv("WATCHDOG_PID", raising=False)
    notifier = VirtualNotifier()
    app = _replay_appliance(tmp_path, recording("akashi-crossing", 30), notifier)
    leds = app.leds
    assert isinstance(leds, VirtualLedPanel)
    stop = threading.Event()
    runner = threading.Thread(target=app.run, args=(stop,), daemon=True)
    runner.start()

    def toggles(role: str, since_ns: int) -> int:
        return sum(1 for t, _ in leds.history[role] if t >= since_ns)

    try:
        end = time.monotonic() + 60
        while app.steps == 0 and time.monotonic() < end:
            time.sleep(0.1)
        time.sleep(2.5)
        t_ok = time.monotonic_ns()
        time.sleep(2.0)
        assert toggles("ok", t_ok) >= 4 and toggles("fault", t_ok) == 0  # heartbeat: two pulses a second
        assert app.source is not None
        app.source.camera_faults = lambda: {"left": None, "right": "unplugged"}  # type: ignore[method-assign]
        time.sleep(2.0)
        t_bad = time.monotonic_ns()
        time.sleep(2.0)
        snap = app.health.snapshot()
        assert snap.state.value == "DEGRADED" and "camera_right" in snap.reason
        assert snap.status_bits & Status.DEGRADED and not snap.status_bits & Status.CAMERA_RIGHT
        assert toggles("ok", t_bad) >= 4 and toggles("fault", t_bad) >= 4  # blinking together: amber
        pings = notifier.messages.count("WATCHDOG=1")
        app.source.camera_faults = lambda: {"left": None, "right": None}  # type: ignore[method-assign]
        time.sleep(2.0)
        assert app.health.snapshot().state.value == "OK"
        assert notifier.messages.count("WATCHDOG=1") > pings  # never stopped
    finally:
        stop.set()
        runner.join(timeout=5.0)
    assert leds.levels() == {"ok": 0, "fault": 1}  # stopped: steady red
