"""The live appliance: frame-pair source -> Pipeline -> Outputs, with health, the watchdog and reload.

Threads (docs/design.md): a capture thread reads the source into a one-slot queue where the newest
pair wins (drops counted), so a slow step never backs up the cameras (a source without
pacing, a recording or the simulator at full speed, waits for the slot instead: it loses
nothing); a processing thread runs `Pipeline.step` and hands the fixes to `Outputs` (whose
writers have their own threads); the caller's thread owns signals, sd_notify and the LEDs.

Lifecycle under systemd (Type=notify):
- `Appliance.build` does everything that can fail on a bad configuration (calibration, scenario,
  outputs) before any device is opened, raising `ConfigError` (exit 78).
- READY=1 comes once the first pair has been processed; until then EXTEND_TIMEOUT_USEC keeps
  systemd waiting while the cameras warm up, for at most READY_WAIT_S, after which the daemon
  reports READY anyway and shows why it is DEGRADED (a unit that never starts is no use to a
  technician reading its status).
- WATCHDOG=1 at half WatchdogSec, only while every critical stage is fresh. A known fault (a
  camera gone, a port gone) keeps the stages beating with a fault: DEGRADED, pings continue.
  Only stuck code (a thread that stopped beating) stops them.
- STATUS= carries one line: state, frame rate, ships and the worst fault.
- While no pair comes (a camera gone, no trigger), the processing thread republishes the health
  to the Modbus registers every QUEUE_WAIT_S, so the PLC's STATUS word shows DEGRADED within a
  second instead of freezing at its last value; the LEDs follow the health at every blink edge.
- `record` (run --record DIR): the processed pairs also go to a recording (edge/recording/live.py);
  a write failure (disk full) stops the recording with a fault, never the tracking.
- SIGTERM: STOPPING=1, every live track sent once more as lost (and every active alert cleared,
  none raised: issue 18), outputs flushed and closed.
- SIGHUP: the configuration file is loaded and checked first; a broken one is logged and the
  daemon runs on. Otherwise RELOADING=1, the changed parts are swapped in between two pairs,
  then READY=1. Cameras, pipeline and outputs are each rebuilt only if their configuration
  changed, so a reload that leaves cameras and pipeline alone keeps every track and its number.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import threading
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from drivers.camera.base import FramePair, FramePairSource
from drivers.clock import Clock, SystemClock
from drivers.leds.base import LedPanel
from drivers.notify import Notifier
from edge.ais.live import LiveAis, ais_stage
from edge.alerts.manager import AlertManager
from edge.appliance.handover import LatestPair
from edge.appliance.health import HealthMonitor, HealthSnapshot, HealthState, Status, standard_stages
from edge.appliance.journal import MESSAGE_IDS, FaultLog
from edge.appliance.panel import build_leds
from edge.appliance.sources import SourcePlan, plan_source
from edge.appliance.state import Persistence
from edge.appliance.timing import StageTimes
from edge.chain import Chain
from edge.config.app import AppConfig, load_config
from edge.config.asterix import check_asterix
from edge.config.masks import build_search_mask
from edge.config.page import check_page
from edge.config.trust import check_config_files
from edge.errors import ConfigError
from edge.fix import ShipFix, TrackStatus
from edge.outputs.asterix import sensor_position
from edge.outputs.fanout import Outputs, output_stages
from edge.outputs.nmea_stream import NmeaStreamOutput
from edge.pipeline import Pipeline
from edge.recording.live import LiveRecorder, recording_stage

if TYPE_CHECKING:
    from edge.appliance.page.page import Page

log = logging.getLogger(__name__)

FixCallback = Callable[[int, Sequence[ShipFix]], None]  # (utc_ns, fixes) after each step
HealthCallback = Callable[[HealthSnapshot], None]  # every main-loop tick (LEDs, the demo's table)
STATUS_PERIOD_S = 1.0
QUEUE_WAIT_S = 0.2
READY_WAIT_S = 60.0  # longest wait for the first pair before READY=1 is sent anyway
EXTEND_S = 5.0  # each EXTEND_TIMEOUT_USEC while waiting for the first pair
CLOCK_CHECK_S = 10.0  # how often the TIME_SYNC status bit is refreshed from the kernel
LED_POLL_NS = 100_000_000  # the LEDs take up a health change within 0.1 s
JOIN_S = 0.5  # per thread at shutdown (a camera blocked mid-frame is left behind): exit within 2 s


def _plan(config: AppConfig, config_file: str | Path | None) -> SourcePlan:
    check_asterix(config.outputs.asterix, config_file)  # its interfaces exist here (exit 78 if not)
    plan = plan_source(config, config_file)
    if plan.calibration.site is None:
        raise ConfigError(config_file, "site", "a site (lat_deg, lon_deg, height_m, heading_deg)")
    mask = build_search_mask(config.masks, plan.calibration.rig, plan.calibration.site, config_file)
    return plan if mask is None else dataclasses.replace(plan, search_mask=mask)


def _health(config: AppConfig, plan: SourcePlan, extra_nmea: bool, recording: bool = False) -> HealthMonitor:
    stages = standard_stages(output_stages(config.outputs, extra_nmea=extra_nmea),
                             stall_after_s=config.health.stale_s)
    if recording:
        stages += (recording_stage(config.health.stale_s),)
    if config.ais is not None:
        stages += (ais_stage(config.health.stale_s),)
    health = HealthMonitor(stages, min_rate_hz=config.health.min_fps or None)
    health.set_flags(Status.CALIBRATION_VALID)  # the plan loaded and checked it
    health.set_flags(Status.SITE_SURVEYED, plan.calibration.site is not None)
    return health


class Appliance:
    """Everything the daemon runs; `build` first, then `run`."""

    def __init__(self, config: AppConfig, config_file: str | Path | None, plan: SourcePlan,
                 chain: Chain, outputs: Outputs, health: HealthMonitor, notifier: Notifier,
                 on_fixes: FixCallback | None = None, extra_nmea: Sequence[NmeaStreamOutput] = (),
                 recorder: LiveRecorder | None = None) -> None:
        self.config, self.config_file, self.plan = config, config_file, plan
        self.chain, self.outputs, self.health = chain, outputs, health
        self.notifier, self.on_fixes, self.extra_nmea = notifier, on_fixes, tuple(extra_nmea)
        self.recorder = recorder
        self.on_health: HealthCallback | None = None
        self.leds: LedPanel | None = build_leds(config.health.leds)
        self.clock: Clock = SystemClock()
        self.clock_check_s = CLOCK_CHECK_S  # the fault bench shortens it
        self.wall_clock_ns: Callable[[], int] = time.time_ns  # anchors a recording's UTC at its first pair
        self._clock_checked_s = -math.inf
        self.queue = LatestPair()
        self.source: FramePairSource | None = None
        self.capture_errors = 0
        self.steps = 0
        self.live_fixes = 0
        self.last_fixes: list[ShipFix] = []
        self.reloads = 0
        self.reload_error: str | None = None
        self.faults = FaultLog(log)
        self.persistence = Persistence.open(config.health.state_dir)  # NMEA numbers, track ids: .state
        self._step_lock = threading.Lock()  # held by one step + publish; a reload swaps between steps
        self._capture_thread: threading.Thread | None = None
        self._capture_stop = threading.Event()
        self.timing = StageTimes()  # per-stage latency histograms (/metrics)
        self.page_token: str | None = None  # checked by build (exit 78 off loopback without one)
        self.page: Page | None = None  # the maintenance page (page.enabled), started by run

    @property
    def pipeline(self) -> Pipeline:
        return self.chain.pipeline

    @property
    def ais(self) -> LiveAis | None:
        return self.chain.ais

    @classmethod
    def build(cls, config: AppConfig, config_file: str | Path | None, notifier: Notifier,
              on_fixes: FixCallback | None = None, extra_nmea: Sequence[NmeaStreamOutput] = (),
              record: str | Path | None = None) -> Appliance:
        """Everything checked and built, nothing opened; `record`: also record the processed pairs
        there (OSError if that directory cannot be created: exists and not empty, not writable)."""
        plan = _plan(config, config_file)
        health = _health(config, plan, bool(extra_nmea), recording=record is not None)
        chain = Chain.from_config(config, cls._pipeline(config, plan))  # nothing opened yet
        outputs = cls._outputs(config, plan, health, chain.alerts, extra_nmea)
        token = check_page(config.page, config_file)  # before anything opens: exit 78 naming the key
        recorder = None if record is None else \
            LiveRecorder(record, plan.calibration, plan.fps, plan.description)
        app = cls(config, config_file, plan, chain, outputs, health, notifier, on_fixes, extra_nmea, recorder)
        app.page_token = token
        return app

    @staticmethod
    def _pipeline(config: AppConfig, plan: SourcePlan) -> Pipeline:
        # live pairs are stamped on CLOCK_MONOTONIC; a recording's clock is anchored at its first pair
        utc_offset_ns = time.time_ns() - time.monotonic_ns() if plan.monotonic_stamps else 0
        return Pipeline(plan.calibration, config.pipeline, fps=plan.fps, utc_offset_ns=utc_offset_ns,
                        search_mask=plan.search_mask)

    @staticmethod
    def _outputs(config: AppConfig, plan: SourcePlan, health: HealthMonitor, alerts: AlertManager | None,
                 extra_nmea: Sequence[NmeaStreamOutput]) -> Outputs:
        site = plan.calibration.site
        assert site is not None  # build() refuses a plan without a site
        asterix_site = sensor_position(site) if config.outputs.asterix.enabled else None
        outputs = Outputs.from_config(config.outputs, health, max_tracks=config.pipeline.max_tracks,
                                      site_lat_deg=site.lat_deg, site_lon_deg=site.lon_deg,
                                      alerts=alerts, asterix_site=asterix_site,
                                      dark_prefix="DARK" if config.ais is None else config.ais.dark_prefix)
        for stream in extra_nmea:
            outputs.add(stream)
        return outputs

    # ------------------------------------------------------------------ threads
    def _capture(self, source: FramePairSource, stop: threading.Event) -> None:
        while not stop.is_set():
            try:
                pair = source.read()
            except TimeoutError:  # no pair in time (a live source): its cameras say why, below
                if not source.closed:
                    self._beat_cameras(source, frames=0)
                continue
            except Exception as exc:  # a camera fault: count, show in health, keep trying
                self.capture_errors += 1
                for stage in ("camera_left", "camera_right"):
                    self.health.beat(stage, fault=f"capture error: {exc}")
                stop.wait(1.0)
                continue
            if pair is None:
                break
            self._beat_cameras(source, frames=1)
            self.queue.put(pair, stop if self.plan.lossless else None)
        if not stop.is_set():  # the source ended (a finite recording), not stopped or reloaded
            self.queue.end()

    def _beat_cameras(self, source: FramePairSource, frames: int) -> None:
        """Both camera stages, each with its own fault (a pair needs both, so frames go to both)."""
        faults = source.camera_faults()
        if frames == 0 and not any(faults.values()):
            faults = {side: "no frame pairs (trigger?)" for side in faults}
        counters = {k: v for k, v in source.counters.items() if isinstance(v, int)}
        for side, fault in faults.items():  # drops, unpaired frames, reconnects of this camera
            mine = {k.removesuffix(f"_{side}"): v for k, v in counters.items() if k.endswith(f"_{side}")}
            self.health.beat(f"camera_{side}", fault=fault, frames=frames,
                             counters={**mine, "source_dropped_pairs": source.dropped,
                                       "source_skipped_pairs": source.skipped})

    def _process(self, stop: threading.Event) -> None:
        while not stop.is_set():
            got = self.queue.get(QUEUE_WAIT_S)
            if got is None:
                if self.queue.ended:
                    break
                self.health.beat("processing")  # idle but alive: waiting for pairs is not stuck
                with self._step_lock:  # no pair: the PLC still sees the health change (a camera gone)
                    now_ns = time.time_ns()
                    self.chain.idle(now_ns, self.health.snapshot())
                    self.outputs.publish_health(self.last_fixes, now_ns)
                    if self.recorder is not None:
                        self.recorder.beat(self.health)
                continue
            with self._step_lock:
                self._step(*got)

    def _step(self, pair: FramePair, captured_ns: int) -> None:
        if self.steps == 0 and not self.plan.monotonic_stamps:  # UTC of a recording: now, onwards
            self.pipeline.utc_offset_ns = self.wall_clock_ns() - pair.t_ns
        elif pair.realtime_offset_ns is not None:  # UTC of a live pair: the wall clock at its exposure
            self.pipeline.utc_offset_ns = pair.realtime_offset_ns
        utc_ns = pair.t_ns + self.pipeline.utc_offset_ns
        start_ns = time.monotonic_ns()
        fixes = self.chain.step(pair, utc_ns, self.health)  # the one chain: pipeline, AIS, alerts
        chain_ns = time.monotonic_ns()
        self.live_fixes, self.last_fixes = len(fixes), fixes
        latency_s = (time.monotonic_ns() - captured_ns) / 1e9  # capture to outputs
        self.health.beat("processing", frames=1, latency_s=latency_s,
                         counters={"dropped_pairs": self.queue.dropped,
                                   "failed_pairs": self.pipeline.counters.failed})
        self.outputs.publish(fixes, utc_ns)
        done_ns = time.monotonic_ns()
        self.timing.observe({"queue": (start_ns - captured_ns) / 1e9, "chain": (chain_ns - start_ns) / 1e9,
                             "outputs": (done_ns - chain_ns) / 1e9, "total": (done_ns - captured_ns) / 1e9})
        if self.page is not None:  # a reference handed over when the page's encoder wants a picture
            self.page.offer(pair, fixes, utc_ns)
        if self.recorder is not None:
            self.recorder.offer(pair)
            self.recorder.beat(self.health)
        if self.persistence is not None:
            self.persistence.after_step(self.pipeline, self.outputs)
        if self.on_fixes is not None:
            self.on_fixes(utc_ns, fixes)
        self.steps += 1  # after publishing: READY=1 waits for the first pair to reach the outputs

    def _start_capture(self) -> None:
        self._capture_stop = threading.Event()
        self.source = self.plan.open()
        self._capture_thread = threading.Thread(target=self._capture, args=(self.source, self._capture_stop),
                                                name="capture", daemon=True)
        self._capture_thread.start()

    def _stop_capture(self) -> None:
        self._capture_stop.set()
        if self.source is not None:
            self.source.close()
        if self._capture_thread is not None:
            self._capture_thread.join(timeout=JOIN_S / 2)

    # ------------------------------------------------------------------ main
    def run(self, stop: threading.Event, seconds: float | None = None,
            reload: threading.Event | None = None) -> int:
        """Run until `stop` is set, the source ends, or `seconds` pass; `reload` set asks for a
        reload of the configuration file. Returns an exit status."""
        if self.persistence is not None:
            self.persistence.restore(self.pipeline, self.outputs)
        self.outputs.start()
        self.chain.start(time.time_ns())
        self._start_page()
        self._start_capture()
        processing = threading.Thread(target=self._process, args=(stop,), name="processing", daemon=True)
        processing.start()
        log.info("running: %s", self.plan.description)
        period_s = min(STATUS_PERIOD_S, self.notifier.watchdog_interval_s() or STATUS_PERIOD_S)
        start_s = time.monotonic()
        deadline = None if seconds is None else start_s + seconds
        ready = False
        try:
            while not stop.is_set() and processing.is_alive():
                now_s = time.monotonic()
                if deadline is not None and now_s >= deadline:
                    break
                if reload is not None and reload.is_set():
                    reload.clear()
                    self.reload()
                snap = self.health.snapshot()
                if not ready and (self.steps > 0 or now_s - start_s >= READY_WAIT_S or self.queue.ended):
                    ready = True
                    self.notifier.ready(self.status_line(snap))
                elif not ready:
                    self.notifier.extend_timeout(EXTEND_S, "starting: waiting for the first frame pair")
                self._report(snap, ready)
                self._wait(stop, period_s)
        finally:
            stop.set()
            self.notifier.stopping("stopping")
            self._stop_capture()
            processing.join(timeout=JOIN_S)
            self._stop_page()
            self._send_lost()
            self.outputs.close()
            self.chain.close()
            if self.recorder is not None:
                self.recorder.close()
            if self.persistence is not None:
                self.persistence.close(self.pipeline, self.outputs)
            if self.leds is not None:
                self.leds.close()  # steady red: not running
        return 0

    def _start_page(self) -> None:
        """The maintenance page's threads (page.enabled); imported only then (docs/page.md)."""
        if not self.config.page.enabled:
            return
        from edge.appliance.page.page import Page

        self.page = Page(self, self.config.page, self.page_token)
        self.page.start()

    def _stop_page(self) -> None:
        if self.page is not None:
            self.page.close()
            self.page = None

    def _wait(self, stop: threading.Event, period_s: float) -> None:
        """Sleep until the next status tick, driving the LEDs' blink edges meanwhile: the daemon's
        own loop toggles them, so a hung daemon leaves them steady instead of blinking on."""
        end_ns = time.monotonic_ns() + round(period_s * 1e9)
        while not stop.is_set():
            now_ns = time.monotonic_ns()
            if now_ns >= end_ns:
                return
            next_ns = end_ns
            if self.leds is not None:  # the LEDs follow the health within LED_POLL_NS, not once a period
                self.leds.show_health(self.health.snapshot().state)
                next_ns = min(end_ns, self.leds.tick(now_ns), now_ns + LED_POLL_NS)
            stop.wait(max(0, next_ns - now_ns) / 1e9)

    def status_line(self, snap: HealthSnapshot) -> str:
        rate = f"{snap.frame_rate_hz:.1f} fps" if snap.frame_rate_hz is not None else "no frames yet"
        text = f"{snap.state.value}: {rate}, {self.live_fixes} ships"
        if snap.reason:
            text += f"; {snap.reason}"
        if self.reload_error:
            text += f"; reload refused: {self.reload_error}"
        held = self.persistence.status() if self.persistence is not None else None
        if held:
            text += f"; {held}"
        return text

    def _report(self, snap: HealthSnapshot, ready: bool) -> None:
        now_s = time.monotonic()
        if now_s - self._clock_checked_s >= self.clock_check_s:  # NMEA carries UTC: is it true UTC?
            self._clock_checked_s = now_s
            self.health.set_flags(Status.TIME_SYNC, self.clock.synchronised())
        self.faults.observe(snap)
        if ready:
            self.notifier.status(self.status_line(snap))
        watched = self.notifier.watchdog_interval_s() is not None  # WatchdogSec set, and for our pid
        if watched and self.config.health.watchdog and snap.state is not HealthState.STALLED:
            self.notifier.watchdog()
        if self.leds is not None:
            self.leds.show_health(snap.state)
            self.leds.tick()
        if self.on_health is not None:
            self.on_health(snap)

    def _send_lost(self) -> None:
        """Every live track once more with status L, so receivers drop them now, not at a time-out."""
        lost = [dataclasses.replace(f, status=TrackStatus.LOST) for f in self.last_fixes
                if f.status is not TrackStatus.LOST]
        self.chain.stop(time.time_ns())  # alerts end with the appliance, none raised now
        if lost or self.chain.alerts is not None:
            try:
                self.outputs.publish(lost, time.time_ns())
            except Exception as exc:  # shutting down: report, never hang or raise
                log.warning("could not send the lost tracks at shutdown: %s", exc)

    # ------------------------------------------------------------------ reload
    def reload(self) -> bool:
        """Re-read the configuration file; swap in what changed. False (and logged) if it is invalid."""
        if self.config_file is None:
            return False
        try:
            check_config_files(self.config_file)
            config = load_config(self.config_file)
            plan = _plan(config, self.config_file)
            health = _health(config, plan, bool(self.extra_nmea), recording=self.recorder is not None)
            # ais: its health stage and the DARK prefix; alerts: the ports' alert sentences
            changed = (config.outputs, config.health, config.ais, config.alerts) != \
                (self.config.outputs, self.config.health, self.config.ais, self.config.alerts)
            alerts = self.chain.alerts
            if config.alerts != self.config.alerts:  # a new manager, and the outputs that render it
                alerts = None
                if config.alerts.enabled:
                    alerts = AlertManager(config.alerts, config.pipeline.max_tracks)
            outputs = self._outputs(config, plan, health, alerts, self.extra_nmea) if changed else None
            token = check_page(config.page, self.config_file)
        except ConfigError as exc:
            self.reload_error = str(exc)
            log.error("reload refused, running on the previous configuration: %s", exc,
                      extra={"MESSAGE_ID": MESSAGE_IDS["reload_refused"]})
            return False
        self.notifier.reloading("reloading the configuration")
        old, cameras_changed = self.config, config.cameras != self.config.cameras
        with self._step_lock:
            logging.getLogger().setLevel(config.logging.level)
            if cameras_changed:
                self._stop_capture()
            if cameras_changed or (old.calibration, old.site, old.pipeline, old.masks) != \
                    (config.calibration, config.site, config.pipeline, config.masks):
                self.chain.pipeline, self.steps, self.last_fixes = self._pipeline(config, plan), 0, []
                if self.page is not None:
                    self.page.pipeline_changed()
            if config.ais != old.ais:
                self.chain.close()
                self.chain.ais = Chain.build_ais(config.ais, self.pipeline)
                self.chain.start(time.time_ns())
            self.chain.alerts = alerts
            if outputs is not None:
                self.outputs.close()
                self.outputs, self.health = outputs, health
                self.outputs.start()
                self.outputs.publish(self.last_fixes, time.time_ns())  # new ports serve at once
            if config.health.leds != old.health.leds:
                if self.leds is not None:
                    self.leds.close()
                self.leds = build_leds(config.health.leds)
            self.config, self.plan, self.reload_error = config, plan, None
            self.page_token = token
            if config.page != old.page:  # the page reads health and outputs afresh: only its block counts
                self._stop_page()
                self._start_page()
            if self.persistence is not None and (outputs is not None or self.steps == 0):
                self.persistence.restore(self.pipeline, self.outputs, from_memory=True)
            if cameras_changed:
                self._start_capture()
        self.reloads += 1
        log.info("configuration reloaded from %s", self.config_file,
                 extra={"MESSAGE_ID": MESSAGE_IDS["reload"]})
        self.notifier.ready(self.status_line(self.health.snapshot()))
        return True
