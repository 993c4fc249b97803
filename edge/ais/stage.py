"""The AIS stage: lines in, fixes annotated with MMSI, name and the dark flag, and the
calibration monitor's estimates out. The daemon feeds it from the AIS input driver, `replay`
from the recording's `ais.csv`; both through `feed` and `annotate`, so a replay exercises the
live code. Synchronous and deterministic: the caller owns threads and clocks.

Times: a line's `t_ns` and the fixes' `t_ns` must be on one clock (UTC in the daemon, the
recording's clock in a replay). A report's time is its receive time (AIS latency is a slot,
tens of ms).
"""

from __future__ import annotations

import dataclasses
import logging
import math
from collections.abc import Callable, Sequence

import numpy as np

from edge.ais.associate import Associator, TrackGeometry
from edge.ais.decode import AisCounters, AisDecoder, PositionReport
from edge.ais.monitor import MAX_REPORT_AGE_S, NEAR_SHARE, Estimate, OffsetEstimator, residual
from edge.ais.targets import SIGMA_ACCURATE_M, Predicted, TargetTable
from edge.config.ais import AisConfig
from edge.core.geo import enu_to_world
from edge.core.site import Site
from edge.fix import ShipFix, TrackStatus
from edge.measure.groundtrack import measurement_cov

log = logging.getLogger(__name__)

Geometry = Callable[[int], tuple[np.ndarray, np.ndarray] | None]  # track id -> (east/north, cov)


class AisStage:
    """Decoder, target table, association and monitor of one appliance."""

    def __init__(self, config: AisConfig, site: Site, focal_px: float, baseline_m: float) -> None:
        self.cfg, self.site = config, site
        self.focal_px, self.baseline_m = float(focal_px), float(baseline_m)
        self.decoder = AisDecoder()
        self.counters: AisCounters = self.decoder.counters
        self.table = TargetTable(site, config.max_age_s, self.counters)
        self.associator = Associator(config.gate_nis, config.hold_bonus, config.confirm_s,
                                     config.dark_after_s, config.warmup_s)
        m = config.monitor
        self.disparity = OffsetEstimator(m.disparity_bound_px, m.confidence_sigmas, m.min_reports)
        self.bearing = OffsetEstimator(m.bearing_bound_deg, m.confidence_sigmas, m.min_reports)
        self.input_start_ns: int | None = None
        self._used_reports: set[tuple[int, int]] = set()  # (mmsi, report t_ns) compared already
        self._fault_logged: str | None = None
        self._dark_logged: set[int] = set()  # tracks whose turning dark was logged

    # ------------------------------------------------------------ input
    def start(self, t_ns: int) -> None:
        """The AIS input is running from `t_ns` (the dark flag's warm-up counts from here)."""
        if self.input_start_ns is None:
            self.input_start_ns = int(t_ns)

    def input_lost(self) -> None:
        """The receiver is gone: "no AIS" can no longer be told from "no receiver", so no track is
        dark until lines come again and the warm-up has run anew (`start` from the next line)."""
        self.input_start_ns = None

    def feed(self, t_ns: int, line: str | bytes) -> None:
        self.start(t_ns)
        for report in self.decoder.feed(line, t_ns):
            self.table.add(report)

    # ------------------------------------------------------------ per pair
    def annotate(self, fixes: Sequence[ShipFix], geometry: Geometry | None = None) -> list[ShipFix]:
        """The fixes with `ais_mmsi`, `ais_name` and `dark` set (T tracks; others unchanged)."""
        if not fixes:
            return list(fixes)
        t_ns = fixes[0].t_ns
        targets = self.table.predict(t_ns)
        t_fixes = [f for f in fixes if f.status is TrackStatus.TRACKING]
        tracks = [self._geometry(f, geometry) for f in t_fixes]
        live = {f.track_id for f in fixes}
        self._dark_logged &= live
        result = self.associator.step(t_ns, tracks, targets, self.input_start_ns, live)
        by_mmsi = {p.mmsi: p for p in targets}
        out = []
        for f in fixes:
            a = result.get(f.track_id)
            if a is None:  # Q or L: a lost track keeps the identity it had in its last sentences
                held = self.associator.state.get(f.track_id)
                if f.status is TrackStatus.LOST and held is not None and held.reported is not None:
                    target = self.table.targets.get(held.reported)
                    f = dataclasses.replace(f, ais_mmsi=held.reported,
                                            ais_name=None if target is None else target.name)
                out.append(f)
                continue
            mmsi = a.mmsi if a.this_pair else None
            target = self.table.targets.get(mmsi) if mmsi is not None else None
            name = None if target is None else target.name
            out.append(dataclasses.replace(f, ais_mmsi=mmsi, ais_name=name, dark=a.dark))
            if a.dark and f.track_id not in self._dark_logged:  # the journal line (alert 10001: the flag)
                self._dark_logged.add(f.track_id)
                log.info("track %d is dark: no AIS association for %.0f s (range %.0f m, bearing %.1f deg)",
                         f.track_id, self.cfg.dark_after_s, f.range_m, f.bearing_deg)
            if mmsi is not None and self.cfg.monitor.enabled and mmsi in by_mmsi:
                self._monitor(f, by_mmsi[mmsi])
        self._log_fault()
        return out

    def _geometry(self, f: ShipFix, geometry: Geometry | None) -> TrackGeometry:
        got = geometry(f.track_id) if geometry is not None else None
        if got is not None:
            return TrackGeometry(f.track_id, got[0], got[1])
        b = math.radians(f.bearing_deg)
        en = np.array([f.range_m * math.sin(b), f.range_m * math.cos(b)])
        across = max(1.0, f.range_m * 1e-3)  # ~1 mrad of bearing when the filter has no state yet
        return TrackGeometry(f.track_id, en, measurement_cov(b, f.sigma_m, across))

    def _monitor(self, f: ShipFix, p: Predicted) -> None:
        rep: PositionReport = p.report
        key = (rep.mmsi, rep.t_ns)
        if rep.ais_class != "A" or not rep.accurate or key in self._used_reports:
            return
        if not 0 <= f.t_ns - rep.t_ns <= MAX_REPORT_AGE_S * 1e9 or f.range_m > self.cfg.monitor.max_range_m:
            return
        self._used_reports.add(key)
        if len(self._used_reports) > 100_000:
            self._used_reports.clear()
        target = self.table.targets[rep.mmsi]
        dims = target.dims_m()
        fwd = np.array([math.sin(p.heading_rad), math.cos(p.heading_rad)])
        stbd = np.array([fwd[1], -fwd[0]])
        point = p.antenna_en_m.copy()
        half_beam = 0.0
        if dims is not None:
            _, _, c, d = dims
            point = point + stbd * (d - c) / 2.0
            half_beam = (c + d) / 2.0
        r = float(np.hypot(*point))
        los = point / r
        sin_aspect = abs(float(los[0] * fwd[1] - los[1] * fwd[0]))
        point = point - los * NEAR_SHARE * half_beam * sin_aspect  # half way to the near side (module doc)
        world = enu_to_world(np.array([point[0], point[1], 0.0]), self.site.heading_deg)
        bearing = math.degrees(math.atan2(point[0], point[1])) % 360.0
        fb = self.focal_px * self.baseline_m
        sigma_d = f.sigma_m * fb / max(f.range_m, 1.0) ** 2 if math.isfinite(f.sigma_m) else math.inf
        res = residual(rep.mmsi, f.disparity_px, sigma_d, f.bearing_deg, world, bearing,
                       float(np.hypot(*point)), math.hypot(SIGMA_ACCURATE_M, 0.5 * half_beam),
                       self.focal_px, self.baseline_m)
        self.disparity.add(res.mmsi, res.disparity_px, res.disparity_sigma_px)
        self.bearing.add(res.mmsi, res.bearing_deg, res.bearing_sigma_deg)

    # ------------------------------------------------------------ reporting
    def estimates(self) -> tuple[Estimate, Estimate]:
        """(disparity offset px, bearing offset deg)."""
        return self.disparity.estimate(), self.bearing.estimate()

    def fault(self) -> str | None:
        d, b = self.estimates()
        parts = []
        if d.fault and d.value is not None:
            parts.append(f"disparity offset {d.value:+.3f} px (sigma {d.sigma:.3f}, {d.ships} ships)")
        if b.fault and b.value is not None:
            parts.append(f"bearing offset {b.value:+.3f} deg (sigma {b.sigma:.3f}, {b.ships} ships)")
        return "calibration check: " + "; ".join(parts) if parts else None

    def health_counters(self) -> dict[str, int]:
        """Integer counters for the `ais` health stage; the monitor's values in milli-units
        (the Modbus health block reads them from here)."""
        out = dict(self.counters.as_dict())
        out["targets"] = sum(1 for t in self.table.targets.values() if t.position is not None)
        d, b = self.estimates()
        for name, e in (("disparity_offset_mpx", d), ("bearing_offset_mdeg", b)):
            if e.value is not None and e.sigma is not None:
                out[name] = round(1000.0 * e.value)
                out[name.replace("offset", "sigma")] = round(1000.0 * e.sigma)
        out["monitor_ships"] = max(d.ships, b.ships)
        out["disparity_fault"], out["bearing_fault"] = int(d.fault), int(b.fault)
        return out

    def _log_fault(self) -> None:
        """The journal gets the check's fault once when it is raised and once when it clears."""
        fault = self.fault()
        if (fault is None) != (self._fault_logged is None):
            if fault is not None:
                log.warning("%s", fault)
            else:
                log.info("calibration check: offsets back within their bounds")
            self._fault_logged = fault
