"""`mast-stereo selftest`: what a maintenance technician runs on the mast, in 30 s or less.

Each check says PASS, FAIL (with a hint of what to do), WARN (it works, but a person should
look: not a failure) or SKIP (not applicable here, e.g. the serial ports while the running
daemon holds them). The exit status is the number of failures,
so a script or a PLC can act on it. When the daemon is running (its Modbus port answers), the
checks that would fight it for a device read its health block instead of opening the device.

Checks: the configuration and the calibration load; the daemon's state if it runs; both cameras
deliver pairs (at the configured rate and skew for real cameras); a known-answer test of the
core on a rendered pair (range within 1 % of truth); each serial port opens; the Modbus port
binds (or the daemon answers on it); the LEDs cycle; free disk for recordings; the system
clock is synchronised (NMEA carries UTC); with an `ais:` block, the running daemon's AIS
calibration check (disparity and bearing offsets, their sigmas, ships behind them: Modbus 40-45);
with a `masks:` block, the site masks build for the rig, WARN if they hide the whole sea.
"""

from __future__ import annotations

import json
import shutil
import socket
import struct
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from drivers.clock import Clock, SystemClock
from drivers.leds.base import OFF, ON
from edge.appliance.health import Status
from edge.appliance.panel import build_leds
from edge.appliance.sources import SourcePlan, plan_source
from edge.config.app import AppConfig, V4l2Cameras, config_from_dict, load_config
from edge.config.masks import build_search_mask, sea_grid
from edge.config.schema import load_yaml
from edge.core.masks import open_sea_share
from edge.core.match import match_point
from edge.errors import ConfigError
from edge.sim import synth

PASS, FAIL, SKIP, WARN = "PASS", "FAIL", "SKIP", "WARN"  # WARN: works, but look (not a failure)
CAMERA_WAIT_S = 10.0  # longest wait for pairs from cameras the daemon is not using
CAMERA_PAIRS = 5
KNOWN_RANGE_DISPARITY_PX = 5.0  # the known-answer pair: a ship at the range of 5 px disparity
RECORDINGS_DIR = Path("/var/lib/mast-stereo")
LED_STEP_S = 0.5  # each LED on, then off, this long


@dataclass(frozen=True)
class Check:
    name: str
    result: str  # PASS, FAIL or SKIP
    detail: str
    hint: str = ""


@dataclass
class DaemonState:
    """What the running daemon's Modbus health block says (None: not running / not reachable)."""

    status_bits: int
    fault_code: int
    heartbeat: int


def read_health_block(host: str, port: int, timeout_s: float = 1.0) -> DaemonState | None:
    """FC4 read of registers 16..18 (HEARTBEAT, STATUS, FAULT_CODE) with a plain Modbus TCP frame."""
    request = struct.pack(">HHHBBHH", 1, 0, 6, 1, 4, 16, 3)
    try:
        with socket.create_connection((host, port), timeout=timeout_s) as sock:
            sock.sendall(request)
            reply = b""
            while len(reply) < 9 + 6:
                chunk = sock.recv(64)
                if not chunk:
                    break
                reply += chunk
    except OSError:
        return None
    if len(reply) < 15 or reply[7] != 4:
        return None
    heartbeat, status, fault = struct.unpack(">HHH", reply[9:15])
    return DaemonState(status, fault, heartbeat)


def read_input_registers(host: str, port: int, start: int, count: int,
                         timeout_s: float = 1.0) -> tuple[int, ...] | None:
    """FC4 read of `count` registers from `start` with a plain Modbus TCP frame (None: no answer)."""
    request = struct.pack(">HHHBBHH", 2, 0, 6, 1, 4, start, count)
    try:
        with socket.create_connection((host, port), timeout=timeout_s) as sock:
            sock.sendall(request)
            reply = b""
            while len(reply) < 9 + 2 * count:
                chunk = sock.recv(512)
                if not chunk:
                    break
                reply += chunk
    except OSError:
        return None
    if len(reply) < 9 + 2 * count or reply[7] != 4:
        return None
    return struct.unpack(f">{count}H", reply[9:9 + 2 * count])


class Selftest:
    """Runs the checks for one configuration file."""

    def __init__(self, config_path: str | Path, clock: Clock | None = None) -> None:
        self.config_path = Path(config_path)
        self.clock = clock or SystemClock()
        self.config: AppConfig | None = None
        self.plan: SourcePlan | None = None
        self.daemon: DaemonState | None = None
        self.calibration_error: ConfigError | None = None

    def run(self) -> list[Check]:
        checks = [self.check_config()]
        if self.config is None:
            return checks
        checks.append(self.check_calibration())
        checks.append(self.check_daemon())
        steps: list[Callable[[], Check | list[Check]]] = [
            self.check_cameras, self.check_core, self.check_serial_ports, self.check_modbus,
            self.check_leds, self.check_disk, self.check_clock, self.check_ais, self.check_masks]
        for step in steps:
            got = step()
            checks.extend(got if isinstance(got, list) else [got])
        return checks

    # ------------------------------------------------------------ checks
    def check_config(self) -> Check:
        try:
            self.config = load_config(self.config_path)
        except ConfigError as exc:
            if not exc.key.startswith("calibration") and Path(exc.file) == self.config_path:
                return Check("configuration", FAIL, str(exc), "fix the named key; `mast-stereo check-config`")
            # the configuration is fine but the calibration it names is not: the other checks still run
            self.calibration_error = exc
            data = load_yaml(self.config_path)
            self.config = config_from_dict({k: v for k, v in data.items() if k != "calibration"},
                                           self.config_path)
        return Check("configuration", PASS, str(self.config_path))

    def check_calibration(self) -> Check:
        assert self.config is not None
        try:
            if self.calibration_error is not None:
                raise self.calibration_error
            self.plan = plan_source(self.config, self.config_path)
        except ConfigError as exc:
            return Check("calibration", FAIL, str(exc), "restore the calibration file or recalibrate")
        rig = self.plan.calibration.rig
        if self.plan.calibration.site is None:
            return Check("calibration", FAIL, f"{rig.width}x{rig.height}, no site",
                         "survey the site: site.lat_deg, lon_deg, height_m, heading_deg")
        detail = f"{rig.width}x{rig.height}, baseline {rig.baseline_m:g} m, with site"
        return Check("calibration", PASS, detail)

    def check_daemon(self) -> Check:
        assert self.config is not None
        tcp = self.config.outputs.modbus.tcp
        if not tcp.enabled:
            return Check("daemon", SKIP, "Modbus TCP is off: state not readable here")
        host = "127.0.0.1" if tcp.host in ("0.0.0.0", "") else tcp.host
        self.daemon = read_health_block(host, tcp.port)
        if self.daemon is None:
            return Check("daemon", SKIP, f"not running (nothing answers on {host}:{tcp.port})")
        bits = Status(self.daemon.status_bits)
        detail = f"running, status 0x{self.daemon.status_bits:04x}, heartbeat {self.daemon.heartbeat}"
        if Status.OK in bits:
            return Check("daemon", PASS, detail + ", OK")
        state = "DEGRADED" if Status.DEGRADED in bits else "STALLED"
        return Check("daemon", FAIL, f"{detail}, {state}, fault code {self.daemon.fault_code}",
                     "journalctl -u mast-stereo; the fault code is 10 x stage + kind (docs/operations.md)")

    def check_cameras(self) -> Check:
        if self.plan is None:
            return Check("cameras", SKIP, "no calibration")
        if self.daemon is not None:
            bits = Status(self.daemon.status_bits)
            seen = [name for name, bit in (("left", Status.CAMERA_LEFT), ("right", Status.CAMERA_RIGHT))
                    if bit in bits]
            ok = len(seen) == 2
            hint = "" if ok else "check the camera cables; `journalctl -u mast-stereo STAGE=camera_left`"
            detail = f"in use by the daemon; healthy: {seen or 'none'}"
            return Check("cameras", PASS if ok else FAIL, detail, hint)
        return self._sample_cameras(self.plan)

    def _sample_cameras(self, plan: SourcePlan) -> Check:
        try:
            source = plan.open()
        except Exception as exc:  # a device that cannot be opened is this check's answer
            return Check("cameras", FAIL, f"{plan.description}: {exc}", "check the device names, /dev/mast/*")
        stamps: list[int] = []
        skews: list[int] = []
        deadline = time.monotonic() + CAMERA_WAIT_S
        try:
            while len(stamps) < CAMERA_PAIRS and time.monotonic() < deadline:
                pair = source.read()
                if pair is None:
                    break
                stamps.append(pair.t_ns)
                skews.append(abs(pair.skew_ns))
        except Exception as exc:
            return Check("cameras", FAIL, f"{plan.description}: {exc}", "check the cameras and their cables")
        finally:
            source.close()
        if len(stamps) < 2:
            detail = f"{len(stamps)} pairs in {CAMERA_WAIT_S:g} s from {plan.description}"
            return Check("cameras", FAIL, detail, "check the trigger and that both cameras stream")
        rate = (len(stamps) - 1) * 1e9 / max(1, stamps[-1] - stamps[0])
        skew_ms = max(skews) / 1e6
        detail = f"{len(stamps)} pairs at {rate:.1f} fps (configured {plan.fps:g}), skew <= {skew_ms:.2f} ms"
        if isinstance(self.config.cameras if self.config else None, V4l2Cameras):
            limit_ms = 500.0 / plan.fps  # half a trigger period
            if rate < 0.9 * plan.fps or skew_ms > limit_ms:
                return Check("cameras", FAIL, detail, "check the trigger rate and both cameras' trigger mode")
        return Check("cameras", PASS, detail)

    def check_core(self) -> Check:
        """A rendered exact-shift pair at a known range through the product's matcher and eq. 4.1."""
        if self.plan is None:
            return Check("core known answer", SKIP, "no calibration")
        rig = self.plan.calibration.rig
        fb = rig.focal_px() * rig.baseline_m
        d32 = round(KNOWN_RANGE_DISPARITY_PX * 32)
        truth_m = fb / (d32 / 32)
        rng = np.random.default_rng(7)
        pair = synth.render_pair(synth.make_scene(rng, 64, 160), rng, d32, height_px=41, width_px=96)
        m = match_point(pair.left, pair.right, 48.0, 20.0, window=15, max_disparity=16)
        if not m.valid:
            return Check("core known answer", FAIL, f"no match ({m.reason})", "reinstall: the core is broken")
        range_m = fb / m.disparity_px
        error = (range_m - truth_m) / truth_m
        detail = f"range {range_m:.1f} m for {truth_m:.1f} m ({100 * error:+.2f} %)"
        return Check("core known answer", PASS if abs(error) < 0.01 else FAIL, detail,
                     "" if abs(error) < 0.01 else "reinstall: the core does not compute what it should")

    def check_serial_ports(self) -> list[Check]:
        assert self.config is not None
        urls = [p.url for p in self.config.outputs.nmea]
        if self.config.outputs.modbus.rtu.enabled:
            urls.append(self.config.outputs.modbus.rtu.url)
        if not urls:
            return [Check("serial ports", SKIP, "none configured")]
        if self.daemon is not None:
            active = Status.NMEA_ACTIVE in Status(self.daemon.status_bits)
            return [Check("serial ports", PASS if active or not self.config.outputs.nmea else FAIL,
                          f"held by the daemon: {', '.join(urls)}", "" if active else "check the NMEA cable")]
        import serial  # pyserial; imported here so that the other checks run without it

        out = []
        for url in urls:
            try:
                serial.serial_for_url(url, do_not_open=False, timeout=0).close()
                out.append(Check(f"serial {url}", PASS, "opens"))
            except (serial.SerialException, OSError, ValueError) as exc:
                out.append(Check(f"serial {url}", FAIL, str(exc),
                                 "check the device name (udev rules), the cable and the dialout group"))
        return out

    def check_modbus(self) -> Check:
        assert self.config is not None
        tcp = self.config.outputs.modbus.tcp
        if not tcp.enabled:
            return Check("modbus port", SKIP, "Modbus TCP is off")
        if self.daemon is not None:
            return Check("modbus port", PASS, f"the daemon answers on {tcp.host}:{tcp.port}")
        try:
            with socket.socket() as sock:
                sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
                sock.bind((tcp.host, tcp.port))
        except OSError as exc:
            return Check("modbus port", FAIL, f"{tcp.host}:{tcp.port}: {exc.strerror or exc}",
                         "another program holds the port (ss -ltnp), or a port < 1024 needs the capability")
        return Check("modbus port", PASS, f"{tcp.host}:{tcp.port} bindable")

    def check_leds(self) -> Check:
        """Each LED on, then off (the technician sees them cycle); not while the daemon drives them."""
        assert self.config is not None
        cfg = self.config.health.leds
        if cfg.kind == "none":
            return Check("leds", SKIP, "no LEDs configured")
        if self.daemon is not None:
            return Check("leds", SKIP, "driven by the running daemon")
        panel = build_leds(cfg)
        assert panel is not None
        for pattern in (ON, OFF):
            panel.show(dict.fromkeys(panel.roles, pattern))
            panel.tick()
            time.sleep(LED_STEP_S)
        missing = [role for role, ok in getattr(panel, "present", dict)().items() if not ok]
        panel.close({})
        if missing:
            return Check("leds", FAIL, f"not writable: {', '.join(missing)} under {cfg.root}",
                         "check health.leds names (ls /sys/class/leds) and the udev rule for LEDs")
        return Check("leds", PASS, f"{cfg.kind}: {', '.join(panel.roles)} cycled on and off")

    def check_disk(self) -> Check:
        where = RECORDINGS_DIR if RECORDINGS_DIR.is_dir() else self.config_path.resolve().parent
        free = shutil.disk_usage(where).free
        assert self.config is not None
        need_mb = self.config.health.min_free_disk_mb
        detail = f"{free / 2**30:.1f} GiB free at {where} (needs {need_mb} MB)"
        if free < need_mb * 2**20:
            return Check("disk", FAIL, detail, "free space for recordings: remove old recordings")
        return Check("disk", PASS, detail)

    def check_ais(self) -> Check:
        """The AIS calibration check of the running daemon (issue 17), from its Modbus health block."""
        assert self.config is not None
        if self.config.ais is None:
            return Check("ais calibration check", SKIP, "no ais: block in the configuration")
        tcp = self.config.outputs.modbus.tcp
        if self.daemon is None or not tcp.enabled:
            return Check("ais calibration check", SKIP, "the daemon is not running: nothing measured yet")
        host = "127.0.0.1" if tcp.host in ("0.0.0.0", "") else tcp.host
        regs = read_input_registers(host, tcp.port, 40, 6)
        got = None if regs is None else _ais_monitor_text(regs)
        if got is None:
            return Check("ais calibration check", SKIP, "no estimate yet (needs associated class-A ships)")
        text, fault = got
        if fault:
            return Check("ais calibration check", FAIL, text,
                         "a camera moved or the heading is off: re-check the mount, recalibrate")
        return Check("ais calibration check", PASS, text)

    def check_masks(self) -> Check:
        """The site masks (`masks:`) build for this rig; WARN when they leave no sea to search."""
        assert self.config is not None
        masks = self.config.masks
        if masks.empty:
            return Check("site masks", SKIP, "none configured")
        if self.plan is None or self.plan.calibration.site is None:
            return Check("site masks", SKIP, "no calibration with a site")
        rig, site = self.plan.calibration.rig, self.plan.calibration.site
        sea = sea_grid(rig, site)
        try:
            mask = build_search_mask(masks, rig, site, self.config_path, sea)
        except ConfigError as exc:
            return Check("site masks", FAIL, str(exc), "fix the named vertex; `mast-stereo masks` draws them")
        assert mask is not None
        share = open_sea_share(mask, sea)
        detail = (f"{len(masks.image)} image, {len(masks.geo)} geo polygons; {100 * share:.1f} % of the sea "
                  "below the horizon open to detection")
        if share == 0.0:
            return Check("site masks", WARN, "they hide the whole sea below the horizon: no ship can be "
                         f"detected ({detail})", "check them over a frame: `mast-stereo masks --config ...`")
        return Check("site masks", PASS, detail)

    def check_clock(self) -> Check:
        assert self.config is not None
        if self.clock.synchronised():
            return Check("clock", PASS, "synchronised (NTP/PPS discipline active)")
        if not self.config.health.require_clock_sync:
            return Check("clock", SKIP, "not synchronised; not required (health.require_clock_sync: false)")
        return Check("clock", FAIL, "not synchronised: NMEA and Modbus times may be off",
                     "enable chrony or systemd-timesyncd, or a GPS/PPS source; `timedatectl`")


def _ais_monitor_text(regs: tuple[int, ...]) -> tuple[str, bool] | None:
    """Registers 40-45 -> (text, fault) or None when the daemon has no estimate yet."""
    from edge.encode.registers import BY_NAME, WordOrder, decode

    def value(name: str) -> float | None:
        return decode(BY_NAME[name], regs[BY_NAME[name].offset - 24:][:1], WordOrder.HIGH_FIRST)

    names = ("AIS_DISP_OFFSET", "AIS_DISP_SIGMA", "AIS_BRG_OFFSET", "AIS_BRG_SIGMA")
    d, ds, b, bs = (value(n) for n in names)
    ships, faults = value("AIS_MONITOR_SHIPS"), value("AIS_MONITOR_FAULTS")
    if d is None or ds is None or b is None or bs is None:
        return None
    text = (f"disparity offset {d:+.3f} px (sigma {ds:.3f}), bearing offset {b:+.3f} deg (sigma {bs:.3f}), "
            f"{int(ships or 0)} ships")
    return text, bool(faults)


def report(checks: list[Check]) -> str:
    """The PASS/FAIL table with a hint under each failure."""
    width = max(len(c.name) for c in checks)
    lines = [f"{'check':<{width}}  result  detail"]
    for c in checks:
        lines.append(f"{c.name:<{width}}  {c.result:<6}  {c.detail}")
        if c.result in (FAIL, WARN) and c.hint:
            lines.append(f"{'':<{width}}          hint: {c.hint}")
    failed = sum(c.result == FAIL for c in checks)
    warned = sum(c.result == WARN for c in checks)
    lines.append((f"{failed} of {len(checks)} checks failed" if failed
                  else f"all {len(checks)} checks passed or skipped")
                 + (f", {warned} with a warning" if warned else ""))
    return "\n".join(lines)


def as_json(checks: list[Check]) -> str:
    return json.dumps({"checks": [asdict(c) for c in checks],
                       "failed": sum(c.result == FAIL for c in checks)}, indent=2)
