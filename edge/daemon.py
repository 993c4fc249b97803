"""The live appliance: frame-pair source -> Pipeline -> Outputs, with health and the watchdog.

Threads (DESIGN.md): a capture thread reads the source into a one-slot
queue where the newest pair wins (drops counted), so a slow step never backs
up the cameras; a processing thread runs `Pipeline.step` and hands the fixes
to `Outputs` (whose writers have their own threads); the caller's thread
owns signals and the watchdog: it sends STATUS= every second and WATCHDOG=1
only while no critical stage is STALLED.

`Appliance.build` does everything that can fail on a bad configuration
(calibration, scenario, outputs) before any device is opened, raising
`ConfigError`; faults after that are counted, logged and shown in health,
never raised out of the loop.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

from drivers.camera.base import FramePair, FramePairSource
from drivers.camera.replay import ReplaySource
from drivers.notify import Notifier
from edge.config.app import AppConfig, ReplayCameras, VirtualCameras
from edge.config.calibration import Calibration, recording_calibration
from edge.errors import ConfigError
from edge.fix import ShipFix
from edge.health import HealthMonitor, HealthState, standard_stages
from edge.outputs.fanout import Outputs, output_stages
from edge.outputs.nmea_stream import NmeaStreamOutput
from edge.pipeline import Pipeline
from edge.sim.scenario import load_scenario
from edge.sim.simulator import live_source

log = logging.getLogger(__name__)

FixCallback = Callable[[int, Sequence[ShipFix]], None]  # (utc_ns, fixes) after each step
STATUS_PERIOD_S = 1.0
QUEUE_WAIT_S = 0.2


@dataclass(frozen=True, slots=True)
class SourcePlan:
    """What the configured cameras are, checked before anything is opened."""

    open: Callable[[], FramePairSource]
    calibration: Calibration
    fps: float
    description: str
    monotonic_stamps: bool  # pairs stamped on CLOCK_MONOTONIC (live); else a recording's own clock


def plan_source(config: AppConfig, config_file: str | Path | None) -> SourcePlan:
    """Resolve `cameras` and the calibration; ConfigError names the key on any problem."""
    cams = config.cameras  # relative paths in it are already resolved against the config file
    if isinstance(cams, VirtualCameras):
        scenario = load_scenario(cams.scenario)
        cal = config.calibration or scenario.spec.calibration
        site = config.effective_site or scenario.spec.site or cal.site
        return SourcePlan(lambda: live_source(scenario, cams.seed, cams.pace, cams.loop),
                          Calibration(cal.rig, site), scenario.spec.fps,
                          f"virtual scenario {cams.scenario!r} seed {cams.seed}", monotonic_stamps=cams.pace)
    if isinstance(cams, ReplayCameras):
        root = Path(cams.path)
        try:
            probe = ReplaySource(root)
        except (OSError, ValueError) as exc:
            raise ConfigError(config_file, "cameras.path", "a readable recording directory",
                              f"{root}: {exc}") from exc
        cal = config.calibration or recording_calibration(root, probe.meta)
        site = config.effective_site or cal.site
        fps = float(probe.meta.get("fps") or 0.0)
        probe.close()
        if not fps > 0:
            raise ConfigError(root / "meta.yaml", "fps", "a positive frame rate", fps)
        return SourcePlan(lambda: ReplaySource(root, pace=cams.pace, loop=cams.loop),
                          Calibration(cal.rig, site), fps, f"recording {root}", monotonic_stamps=False)
    raise ConfigError(config_file, "cameras.kind",
                      "'virtual' or 'replay' (this build has no V4L2 capture driver yet)", cams.kind)


class _Latest:
    """One-slot queue: put() replaces an unread pair (counted as dropped); remembers when it came."""

    def __init__(self) -> None:
        self._cond = threading.Condition()
        self._pair: FramePair | None = None
        self.put_ns = 0  # CLOCK_MONOTONIC when the pair now held was put
        self.dropped = 0
        self.ended = False

    def put(self, pair: FramePair) -> None:
        with self._cond:
            self.dropped += self._pair is not None
            self._pair, self.put_ns = pair, time.monotonic_ns()
            self._cond.notify()

    def end(self) -> None:
        with self._cond:
            self.ended = True
            self._cond.notify()

    def get(self, timeout_s: float) -> tuple[FramePair, int] | None:
        """(pair, CLOCK_MONOTONIC ns when it was captured), or None on time-out or end."""
        with self._cond:
            self._cond.wait_for(lambda: self._pair is not None or self.ended, timeout_s)
            pair, self._pair = self._pair, None
            return None if pair is None else (pair, self.put_ns)


class Appliance:
    """Everything the daemon runs; `build` first, then `run`."""

    def __init__(self, plan: SourcePlan, pipeline: Pipeline, outputs: Outputs, health: HealthMonitor,
                 notifier: Notifier, on_fixes: FixCallback | None = None) -> None:
        self.plan, self.pipeline, self.outputs = plan, pipeline, outputs
        self.health, self.notifier, self.on_fixes = health, notifier, on_fixes
        self.queue = _Latest()
        self.source: FramePairSource | None = None
        self.capture_errors = 0
        self.steps = 0
        self.live_fixes = 0

    @classmethod
    def build(cls, config: AppConfig, config_file: str | Path | None, notifier: Notifier,
              on_fixes: FixCallback | None = None,
              extra_nmea: Sequence[NmeaStreamOutput] = ()) -> Appliance:
        plan = plan_source(config, config_file)
        if plan.calibration.site is None:
            raise ConfigError(config_file, "site", "a site (lat_deg, lon_deg, height_m, heading_deg)")
        # live pairs are stamped on CLOCK_MONOTONIC; a recording's clock is anchored at its first pair
        utc_offset_ns = time.time_ns() - time.monotonic_ns() if plan.monotonic_stamps else 0
        pipeline = Pipeline(plan.calibration, config.pipeline, fps=plan.fps, utc_offset_ns=utc_offset_ns)
        health = HealthMonitor(standard_stages(output_stages(config.outputs, extra_nmea=bool(extra_nmea))))
        site = plan.calibration.site
        outputs = Outputs.from_config(config.outputs, health, max_tracks=config.pipeline.max_tracks,
                                      site_lat_deg=site.lat_deg, site_lon_deg=site.lon_deg)
        for stream in extra_nmea:
            outputs.add(stream)
        return cls(plan, pipeline, outputs, health, notifier, on_fixes)

    # ------------------------------------------------------------------ threads
    def _capture(self, stop: threading.Event) -> None:
        assert self.source is not None
        while not stop.is_set():
            try:
                pair = self.source.read()
            except Exception as exc:  # a camera fault: count, log once, keep trying
                self.capture_errors += 1
                if self.capture_errors == 1:
                    log.error("camera source failed: %s (retrying)", exc)
                for stage in ("camera_left", "camera_right"):
                    self.health.beat(stage, fault=f"capture error: {exc}")
                stop.wait(1.0)
                continue
            if pair is None:
                break
            self.health.beat("camera_left", frames=1)
            self.health.beat("camera_right", frames=1)
            self.queue.put(pair)
        self.queue.end()

    def _process(self, stop: threading.Event) -> None:
        while not stop.is_set():
            got = self.queue.get(QUEUE_WAIT_S)
            if got is None:
                if self.queue.ended:
                    break
                continue
            pair, captured_ns = got
            if self.steps == 0 and not self.plan.monotonic_stamps:  # UTC of a recording: now, onwards
                self.pipeline.utc_offset_ns = time.time_ns() - pair.t_ns
            fixes = self.pipeline.step(pair)
            self.steps, self.live_fixes = self.steps + 1, len(fixes)
            latency_s = (time.monotonic_ns() - captured_ns) / 1e9  # capture to outputs
            self.health.beat("processing", frames=1, latency_s=latency_s,
                             counters={"dropped_pairs": self.queue.dropped,
                                       "failed_pairs": self.pipeline.counters.failed})
            utc_ns = pair.t_ns + self.pipeline.utc_offset_ns
            self.outputs.publish(fixes, utc_ns)
            if self.on_fixes is not None:
                self.on_fixes(utc_ns, fixes)

    # ------------------------------------------------------------------ main
    def run(self, stop: threading.Event, seconds: float | None = None) -> int:
        """Run until `stop` is set, the source ends, or `seconds` pass; returns an exit status."""
        self.source = self.plan.open()
        self.outputs.start()
        threads = [threading.Thread(target=self._capture, args=(stop,), name="capture", daemon=True),
                   threading.Thread(target=self._process, args=(stop,), name="processing", daemon=True)]
        for t in threads:
            t.start()
        self.notifier.ready(f"running: {self.plan.description}")
        log.info("running: %s", self.plan.description)
        period_s = min(STATUS_PERIOD_S, self.notifier.watchdog_interval_s() or STATUS_PERIOD_S)
        deadline = None if seconds is None else time.monotonic() + seconds
        try:
            while not stop.is_set() and threads[1].is_alive():
                if deadline is not None and time.monotonic() >= deadline:
                    break
                self._report()
                stop.wait(period_s)
        finally:
            stop.set()
            self.notifier.stopping("stopping")
            self.source.close()
            for t in threads:
                t.join(timeout=5.0)
            self.outputs.close()
        return 0

    def _report(self) -> None:
        snap = self.health.snapshot()
        rate = f"{snap.frame_rate_hz:.1f} fps" if snap.frame_rate_hz is not None else "no frames yet"
        text = f"{snap.state.value}: {rate}, {self.live_fixes} ships"
        if snap.reason:
            text += f"; {snap.reason}"
        self.notifier.status(text)
        if snap.state is not HealthState.STALLED:
            self.notifier.watchdog()
