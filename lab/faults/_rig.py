"""The test bench the camera and lifecycle fault cases share: the real daemon on fake V4L2 cameras.

`Bench` runs `edge.appliance.daemon.Appliance` (the code `mast-stereo run` runs) in this process, its pair
source a real `V4L2PairSource` whose two cameras are `FakeDevice`s behind the kernel-ABI fake
(lab/fakes/v4l2_fake.py), exposed by a `VirtualTrigger` at 10 Hz with one rendered simulator
pair (a ship at ~1.5 km, so the daemon tracks and emits). Every frame carries its ground-truth
pulse id (`FakeDevice.pulses`), and every pair the pipeline processes is logged, so a mispaired
pair is visible however it came about. The knobs a case turns: `trigger_on`, `skew_us`,
`drop_every`, `burst`, `unplug`/`replug` and the wall-clock step `utc_step_s`; at start, ASTERIX to
a loopback port (`asterix_port`) and the daemon's clock (`clock`, a `VirtualClock` a case flips,
checked every `clock_check_s`).

What the unit shows is read the way a technician's tools read it, over real sockets: systemd's
side of sd_notify (an AF_UNIX datagram socket at $NOTIFY_SOCKET), a raw Modbus TCP client polling
the health block every 50 ms (our own socket code, not the server's pymodbus), the NMEA sentences
from a pty the daemon's serial output writes to, and the LED panel's patterns.
"""

from __future__ import annotations

import contextlib
import dataclasses
import os
import socket
import struct
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from drivers.camera.base import FramePair
from drivers.camera.v4l2 import CameraSettings, V4L2Camera
from drivers.camera.v4l2_pair import V4L2PairSource, realtime_offset_ns
from drivers.clock import Clock
from drivers.leds.base import health_patterns
from drivers.notify import SystemdNotifier
from drivers.trigger.virtual import VirtualTrigger
from edge.appliance.daemon import Appliance
from edge.appliance.health import Status
from edge.appliance.sources import BACKOFF_S, read_timeout_s
from edge.config.app import config_from_dict
from lab.fakes.v4l2_fake import FakeDevice, FakeKernel
from lab.faults._modbus_attack import recv_exact

RATE_HZ = 10.0  # the scenario's frame rate
SCENARIO = "akashi-crossing"
STATUS_REG = 17  # health block 16 + 1 (docs/modbus.md)
FAULT_REG = 18


_SCENE: list[tuple[np.ndarray, np.ndarray]] = []


def use_scene(left: np.ndarray, right: np.ndarray) -> None:
    """Show this pair of the scenario instead of rendering one (the tests reuse a recording's)."""
    _SCENE[:] = [(left, right)]


def scene_pair() -> tuple[np.ndarray, np.ndarray]:
    """One rendered pair of the scenario, the ship at ~1.5 km (rendered once per process: ~5 s)."""
    if not _SCENE:
        from edge.sim.scenario import load_scenario
        from edge.sim.simulator import Simulation

        pair = Simulation(load_scenario(SCENARIO), seed=0).pair(29)
        assert pair is not None
        _SCENE.append((pair.left, pair.right))
    return _SCENE[0]


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


class NotifyListener:
    """systemd's end of $NOTIFY_SOCKET: every datagram with its CLOCK_MONOTONIC arrival time."""

    def __init__(self, path: Path) -> None:
        self.path = str(path)
        self.sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
        self.sock.bind(self.path)
        self.sock.settimeout(0.1)
        self.messages: list[tuple[float, str]] = []
        self._done = threading.Event()
        self._thread = threading.Thread(target=self._drain, name="notify-listener", daemon=True)
        self._thread.start()

    def _drain(self) -> None:
        while not self._done.is_set():
            try:
                self.messages.append((time.monotonic(), self.sock.recv(4096).decode()))
            except TimeoutError:
                pass

    def times(self, prefix: str) -> list[float]:
        return [t for t, m in list(self.messages) if m.startswith(prefix)]

    def wait_for(self, prefix: str, after_s: float, timeout_s: float = 60.0) -> float | None:
        """Arrival time of the first message with a line starting with `prefix` after `after_s`, or None."""
        end = time.monotonic() + timeout_s
        while time.monotonic() < end:
            for t, m in list(self.messages):
                if t >= after_s and any(line.startswith(prefix) for line in m.splitlines()):
                    return t
            time.sleep(0.05)
        return None

    def texts(self, prefix: str, after_s: float) -> list[str]:
        return [line for t, m in list(self.messages) if t >= after_s
                for line in m.splitlines() if line.startswith(prefix)]

    def close(self) -> None:
        self._done.set()
        self._thread.join()
        self.sock.close()


def modbus_read(sock: socket.socket, tid: int, start: int, count: int) -> list[int]:
    """One FC3 read over Modbus TCP (MBAP header + PDU), answered registers as u16."""
    sock.sendall(struct.pack(">HHHBBHH", tid & 0xFFFF, 0, 6, 1, 3, start, count))
    head = recv_exact(sock, 7)
    _, _, length, _ = struct.unpack(">HHHB", head)
    body = recv_exact(sock, length - 1)
    if body[0] != 3:
        raise OSError(f"Modbus exception {body[1] if len(body) > 1 else '?'}")
    return list(struct.unpack(f">{body[1] // 2}H", body[2:]))


class ModbusPoller:
    """Reads STATUS and FAULT_CODE every 50 ms: [(monotonic s, status, fault code)]."""

    def __init__(self, port: int) -> None:
        self.port, self.samples = port, []  # type: ignore[var-annotated]
        self.errors = 0
        self._done = threading.Event()
        self._thread = threading.Thread(target=self._run, name="modbus-poller", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        tid, sock = 0, None
        while not self._done.wait(0.05):
            try:
                if sock is None:
                    sock = socket.create_connection(("127.0.0.1", self.port), timeout=1.0)
                tid += 1
                status, fault = modbus_read(sock, tid, STATUS_REG, 2)
                self.samples.append((time.monotonic(), status, fault))
            except OSError:
                self.errors += 1
                if sock is not None:
                    sock.close()
                sock = None
        if sock is not None:
            sock.close()

    def first(self, after_s: float, predicate) -> float | None:
        """Time of the first sample at/after `after_s` whose (status, fault) satisfy `predicate`."""
        return next((t for t, s, f in list(self.samples) if t >= after_s and predicate(s, f)), None)

    def close(self) -> None:
        self._done.set()
        self._thread.join()


class PtyReader:
    """The far end of the daemon's NMEA serial port: sentences with their arrival times."""

    def __init__(self) -> None:
        self.master, slave = os.openpty()
        self.path = os.ttyname(slave)
        os.close(slave)  # pyserial opens it by name; the master keeps the pty alive
        self.lines: list[tuple[float, str]] = []
        self._done = threading.Event()
        self._thread = threading.Thread(target=self._run, name="pty-reader", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        import select

        buf = b""
        while not self._done.is_set():
            if not select.select([self.master], [], [], 0.1)[0]:
                continue
            try:
                buf += os.read(self.master, 4096)
            except OSError:  # no slave open right now
                time.sleep(0.05)
                continue
            *done, buf = buf.split(b"\n")
            now = time.monotonic()
            self.lines += [(now, ln.decode("ascii", "replace").strip()) for ln in done]

    def sentences(self, kind: str = "TTM") -> list[tuple[float, list[str]]]:
        """Checksum-valid sentences of `kind`: (arrival, fields without the checksum)."""
        out = []
        for t, line in list(self.lines):
            if not line.startswith("$") or "*" not in line:
                continue
            body, _, check = line[1:].partition("*")
            calc = 0
            for ch in body.encode():
                calc ^= ch
            if f"{calc:02X}" == check[:2].upper() and body[2:5] == kind:
                out.append((t, body.split(",")))
        return out

    def close(self) -> None:
        self._done.set()
        self._thread.join()
        os.close(self.master)


@dataclasses.dataclass
class Processed:
    """One pair the pipeline processed: its ground-truth pulse per camera, when, and its fixes."""

    t_s: float
    pulse_left: int | None
    pulse_right: int | None
    fixes: list[Any]


class Bench:
    """The daemon on two fake cameras; use as a context manager (`with Bench(tmp) as b:`)."""

    def __init__(self, workdir: Path, *, max_skew_ms: float | None = None, stale_s: float = 2.0,
                 watchdog_usec: int | None = None, record: Path | None = None,
                 asterix_port: int | None = None, clock: Clock | None = None,
                 clock_check_s: float | None = None) -> None:
        self.workdir = workdir
        self.asterix_port = asterix_port  # ASTERIX (tracks and status) to 127.0.0.1 at this port
        self.clock, self.clock_check_s = clock, clock_check_s  # the daemon's clock and its check period
        self.trigger_on, self.skew_us, self.burst = True, 0, 0
        self.drop_every: tuple[str, int] | None = None  # (side, n): that camera loses every n-th pulse
        self.dropped_by_us = {"left": 0, "right": 0}
        self.utc_step_s = 0.0
        self.pulse = 0
        self.processed: list[Processed] = []
        self.max_skew_ms, self.stale_s = max_skew_ms, stale_s
        self.watchdog_usec, self.record = watchdog_usec, record
        size = {"GREY": [(720, 480)]}
        self.devices = {"left": FakeDevice(size), "right": FakeDevice(size)}
        self.kernel = FakeKernel({f"/dev/fake-{s}": d for s, d in self.devices.items()})
        self.images = scene_pair()

    # --- the cameras and their trigger ---------------------------------------------------------
    def _fire(self, t_ns: int) -> None:
        t_ns = t_ns // 1000 * 1000  # V4L2 timestamps are timevals: whole microseconds
        extra, self.burst = self.burst, 0
        for i in range(1 + extra):  # a burst: `extra` more pulses, 10 ms apart, after this one
            self._expose(t_ns + i * 10_000_000)

    def _expose(self, t_ns: int) -> None:
        k = self.pulse
        self.pulse += 1
        if not self.trigger_on:
            return
        right_ns = t_ns + self.skew_us * 1000
        for side, image, t in (("left", self.images[0], t_ns), ("right", self.images[1], right_ns)):
            if self.drop_every and self.drop_every[0] == side and k % self.drop_every[1] == 0:
                self.devices[side].drop_next(1)
                self.dropped_by_us[side] += 1
            self.devices[side].produce(t, image, pulse=k)

    def _source(self) -> V4L2PairSource:
        trigger = VirtualTrigger(RATE_HZ, [self._fire])
        left, right = (CameraSettings(f"/dev/fake-{s}", 720, 480, "GREY", buffers=4)
                       for s in ("left", "right"))
        skew_ns = None if self.max_skew_ms is None else round(self.max_skew_ms * 1e6)
        return V4L2PairSource(left, right, trigger, max_skew_ns=skew_ns,
                              read_timeout_s=read_timeout_s(RATE_HZ),
                              backoff_s=BACKOFF_S, open_camera=lambda s: V4L2Camera(s, kernel=self.kernel),
                              realtime_offset=lambda: realtime_offset_ns() + round(self.utc_step_s * 1e9))

    def unplug(self, side: str) -> None:
        self.devices[side].unplug()

    def replug(self, side: str) -> None:
        self.devices[side].replug()

    # --- the daemon ----------------------------------------------------------------------------
    def __enter__(self) -> Bench:
        self.notify = NotifyListener(self.workdir / "notify.sock")
        self.pty = PtyReader()
        self.port = free_port()
        to_rx = {"address": "127.0.0.1", "port": self.asterix_port or 8600}
        cfg = {"cameras": {"kind": "virtual", "scenario": SCENARIO, "pace": True},  # calibration and site
               "outputs": {"modbus": {"tcp": {"enabled": True, "host": "127.0.0.1", "port": self.port}},
                           "nmea": [{"url": self.pty.path, "baud": 115200}],
                           "asterix": {"enabled": self.asterix_port is not None, "tracks": to_rx}},
               "health": {"stale_s": self.stale_s, "min_fps": 0.0, "require_clock_sync": False,
                          "leds": {"kind": "virtual"}},
               "logging": {"level": "WARNING"}}
        self._env = {k: os.environ.get(k) for k in ("NOTIFY_SOCKET", "WATCHDOG_USEC", "WATCHDOG_PID")}
        os.environ["NOTIFY_SOCKET"] = self.notify.path
        os.environ.pop("WATCHDOG_PID", None)
        if self.watchdog_usec:
            os.environ["WATCHDOG_USEC"] = str(self.watchdog_usec)
        else:
            os.environ.pop("WATCHDOG_USEC", None)
        config = config_from_dict(cfg, self.workdir / "bench.yaml")
        self.app = Appliance.build(config, None, SystemdNotifier(), record=self.record)
        if self.clock is not None:
            self.app.clock = self.clock
        if self.clock_check_s is not None:
            self.app.clock_check_s = self.clock_check_s
        self.app.plan = dataclasses.replace(self.app.plan, open=self._source, fps=RATE_HZ,
                                            monotonic_stamps=True,
                                            description="two fake V4L2 cameras, virtual trigger")
        real_step = self.app.pipeline.step

        def step(pair: FramePair):  # the pairs the pipeline really processed, with their truth
            fixes = real_step(pair)
            self.processed.append(Processed(time.monotonic(), self.devices["left"].pulses.get(pair.t_left_ns),
                                            self.devices["right"].pulses.get(pair.t_right_ns), list(fixes)))
            return fixes

        self.app.pipeline.step = step  # type: ignore[method-assign]
        self.stop = threading.Event()
        self.runner = threading.Thread(target=self.app.run, args=(self.stop,), name="daemon", daemon=True)
        self.runner.start()
        self.modbus = ModbusPoller(self.port)
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop.set()
        self.runner.join(timeout=5.0)
        self.modbus.close()
        self.pty.close()
        self.notify.close()
        for key, value in self._env.items():
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value

    # --- observations --------------------------------------------------------------------------
    def wait(self, predicate, timeout_s: float) -> float | None:
        """Monotonic time when `predicate()` first held, polling every 20 ms; None on time-out."""
        end = time.monotonic() + timeout_s
        while time.monotonic() < end:
            if predicate():
                return time.monotonic()
            time.sleep(0.02)
        return None

    def ready(self, timeout_s: float = 30.0) -> bool:
        """READY=1 came and the unit is OK on Modbus."""
        return self.wait(lambda: self.notify.times("READY=1") and self.modbus.first(0, ok) is not None,
                         timeout_s) is not None

    def led_state(self) -> str | None:
        """Which health state the LED panel shows now (OK/DEGRADED/STALLED), from its patterns."""
        leds = self.app.leds
        if leds is None:
            return None
        shown = leds.patterns
        for state in ("OK", "DEGRADED", "STALLED"):
            if shown == health_patterns(state, amber=leds.has_amber):
                return state
        return None

    def mispaired(self, since_s: float = 0.0) -> list[Processed]:
        return [p for p in self.processed if p.t_s >= since_s and p.pulse_left != p.pulse_right]

    def stage_counters(self, stage: str) -> dict[str, int]:
        snap = self.app.health.snapshot()
        return dict(next(s.counters for s in snap.stages if s.name == stage))


def ok(status: int, fault: int) -> bool:
    return bool(status & Status.OK) and fault == 0


def degraded(status: int, fault: int) -> bool:
    return bool(status & Status.DEGRADED)


@contextlib.contextmanager
def tmpfs(path: Path, size_kb: int) -> Iterator[bool]:
    """A tiny tmpfs at `path` (root only); yields False where it cannot be mounted."""
    import subprocess

    path.mkdir(parents=True, exist_ok=True)
    if os.geteuid() != 0:
        yield False
        return
    done = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size_kb}k", "faults-tmpfs", str(path)],
                          capture_output=True, text=True)
    if done.returncode != 0:
        yield False
        return
    try:
        yield True
    finally:
        subprocess.run(["umount", "-l", str(path)], capture_output=True)
