"""What the maintenance page shows, gathered from the running appliance as one JSON-ready mapping.

Read on an HTTP thread without the processing thread's lock (the page must never hold up a
step): each value read is one that the processing thread swaps whole (the fixes list, the health
snapshot taken under the monitor's own lock) or a plain integer counter, so the page is at worst
one step behind, never torn. The track table is `run --watch`'s (edge.appliance.console.rows),
with the same NMEA target numbers.
"""

from __future__ import annotations

import math
import shutil
import time
from pathlib import Path
from typing import Any, Protocol

from drivers.leds.base import LedPanel
from edge.appliance.console import rows
from edge.appliance.handover import LatestPair
from edge.appliance.health import HealthMonitor, HealthSnapshot, Status
from edge.appliance.journal import FaultLog
from edge.appliance.sources import SourcePlan
from edge.appliance.state import Persistence
from edge.appliance.timing import StageTimes
from edge.chain import Chain
from edge.config.app import AppConfig
from edge.encode.nmea import fix_name
from edge.fix import ShipFix
from edge.outputs.fanout import Outputs
from edge.outputs.nmea_stream import NmeaStreamOutput
from edge.pipeline import Pipeline

MB = 2**20


class Watched(Protocol):
    """What the page reads of the running appliance (edge.appliance.daemon.Appliance), named here so
    the page does not import the daemon that starts it."""

    @property
    def config(self) -> AppConfig: ...
    @property
    def plan(self) -> SourcePlan: ...
    @property
    def chain(self) -> Chain: ...
    @property
    def pipeline(self) -> Pipeline: ...
    @property
    def outputs(self) -> Outputs: ...
    @property
    def health(self) -> HealthMonitor: ...
    @property
    def queue(self) -> LatestPair: ...
    @property
    def faults(self) -> FaultLog: ...
    @property
    def leds(self) -> LedPanel | None: ...
    @property
    def persistence(self) -> Persistence | None: ...
    @property
    def timing(self) -> StageTimes: ...
    @property
    def last_fixes(self) -> list[ShipFix]: ...
    @property
    def extra_nmea(self) -> tuple[NmeaStreamOutput, ...]: ...
    @property
    def capture_errors(self) -> int: ...
    @property
    def steps(self) -> int: ...
    @property
    def reloads(self) -> int: ...

    def status_line(self, snap: HealthSnapshot) -> str: ...


def _num(value: float | None, decimals: int) -> float | None:
    return None if value is None or not math.isfinite(value) else round(value, decimals)


def counters(app: Watched) -> dict[str, int]:
    """The daemon's own counters (the ones `run` logs at exit), as /metrics exports them."""
    c = app.pipeline.counters
    return {"pairs": c.pairs, "processed": c.processed, "dropped": app.queue.dropped,
            "bad_input": c.bad_input, "failed": c.failed, "gaps": c.gaps, "detections": c.detections,
            "masked": c.masked, "fixes": c.fixes, "capture_errors": app.capture_errors,
            "steps": app.steps, "reloads": app.reloads}


def track_rows(fixes: list[ShipFix], numbers: dict[int, int]) -> list[dict[str, Any]]:
    """The track table as records, nearest first (the order and values of `run --watch`)."""
    out = []
    for f in sorted(fixes, key=lambda f: f.range_m):
        out.append({"number": numbers.get(f.track_id), "id": f.track_id, "status": f.status.value,
                    "range_m": _num(f.range_m, 0), "bearing_deg": _num(f.bearing_deg, 1),
                    "sog_kn": _num(f.sog_kn, 1), "cog_deg": _num(f.cog_deg, 1),
                    "sigma_m": _num(f.sigma_m, 1), "age_s": _num(f.age_s, 1),
                    "name": fix_name(f) if f.ais_mmsi is not None or f.dark else "",
                    "mmsi": f.ais_mmsi})
    return out


def _outputs(app: Watched, snap: HealthSnapshot) -> list[dict[str, Any]]:
    cfg = app.config.outputs
    stages = {s.name: s for s in snap.stages}
    listed: list[tuple[str, str, str]] = [("nmea", "NMEA serial", p.url) for p in cfg.nmea]
    if cfg.udp.enabled:
        listed.append(("nmea", "NMEA UDP", f"{cfg.udp.group}:{cfg.udp.port}"))
    if app.extra_nmea:
        listed.append(("nmea", "NMEA stream", "stdout"))
    if cfg.modbus.tcp.enabled:
        listed.append(("modbus", "Modbus TCP", f"{cfg.modbus.tcp.host}:{cfg.modbus.tcp.port}"))
    if cfg.modbus.rtu.enabled:
        listed.append(("modbus", "Modbus RTU", cfg.modbus.rtu.url))
    if cfg.tracks_csv is not None:
        listed.append(("tracks_csv", "tracks CSV", cfg.tracks_csv))
    if cfg.asterix.enabled:
        dest = cfg.asterix.tracks
        listed.append(("asterix", "ASTERIX CAT 010", f"{dest.address}:{dest.port}"))
    out = []
    for stage, kind, where in listed:
        s = stages.get(stage)
        out.append({"stage": stage, "kind": kind, "where": where,
                    "fresh": None if s is None else s.fresh, "fault": None if s is None else s.fault,
                    "counters": {} if s is None else dict(s.counters)})
    return out


def _alerts(app: Watched) -> list[dict[str, Any]]:
    manager = app.chain.alerts
    if manager is None:
        return []
    for _ in range(3):  # the processing thread may change the table meanwhile: read again
        try:
            active = list(manager.active())
            break
        except RuntimeError:
            continue
    else:
        return []
    now_ns = manager.last_utc_ns
    return [{"alert": a.alert_id.name, "id": int(a.alert_id), "state": str(a.state), "priority": a.priority,
             "tracks": list(a.tracks), "instance": a.instance, "cpa_m": _num(a.cpa_m, 0),
             "tcpa_s": _num(a.tcpa_s, 0), "age_s": _num(max(0.0, (now_ns - a.raised_ns) / 1e9), 0)}
            for a in active]


def _disk(app: Watched) -> dict[str, Any]:
    where = app.persistence.keeper.path.parent if app.persistence is not None else Path.cwd()
    try:
        usage = shutil.disk_usage(where)
    except OSError as exc:
        return {"path": str(where), "error": str(exc)}
    need = app.config.health.min_free_disk_mb
    return {"path": str(where), "free_mb": usage.free // MB, "total_mb": usage.total // MB,
            "min_free_mb": need, "ok": usage.free >= need * MB}


def page_state(app: Watched, pictures: dict[str, int]) -> dict[str, Any]:
    """Everything the page shows; `pictures`: the latest picture's number per side."""
    snap = app.health.snapshot()
    fixes = list(app.last_fixes)
    numbers = app.outputs.target_numbers(fixes)
    leds = app.leds
    ais = next((s for s in snap.stages if s.name == "ais"), None)
    return {
        "time_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
        "source": app.plan.description,
        "health": {"state": snap.state.value, "reason": snap.reason, "fault_code": snap.fault_code,
                   "status_bits": snap.status_bits,
                   "flags": [f.name for f in Status if f.name and snap.status_bits & f],
                   "fps": _num(snap.frame_rate_hz, 2), "latency_s": _num(snap.latency_s, 3),
                   "uptime_s": round(snap.uptime_s),
                   "stages": [{"name": s.name, "fresh": s.fresh, "age_s": _num(s.age_s, 1), "fault": s.fault,
                               "counters": dict(s.counters)} for s in snap.stages],
                   "faults": app.faults.active,
                   "leds": {} if leds is None else {role: str(p) for role, p in leds.patterns.items()},
                   "clock": {"synchronised": bool(snap.status_bits & Status.TIME_SYNC),
                             "required": app.config.health.require_clock_sync},
                   "disk": _disk(app),
                   "status_line": app.status_line(snap)},
        "counters": {**counters(app), "fps": _num(snap.frame_rate_hz, 2)},
        "tracks": track_rows(fixes, numbers),
        "table": rows(fixes, numbers),
        "outputs": _outputs(app, snap),
        "ais": None if ais is None else {
            "fresh": ais.fresh, "fault": ais.fault, "counters": dict(ais.counters),
            "associated": sum(f.ais_mmsi is not None for f in fixes), "dark": sum(f.dark for f in fixes)},
        "alerts": _alerts(app),
        "pictures": pictures,
    }
