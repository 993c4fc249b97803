"""The AIS input of the chain: the configured driver (its own thread and bounded queue,
`drivers.ais_input`) or a recording's ais.csv (`RecordedAis`), and the `AisStage`, with the `ais`
health stage.

The processing thread calls `step(fixes, geometry, health, t_ns)` once per pair: it takes the lines
received so far (a driver's queue, drained without blocking; a recording's lines stamped up to the
pair's exposure), feeds them to the stage and returns the annotated fixes, and beats the
health stage with the driver's fault (receiver gone) or the calibration check's fault, and the
counters (the Modbus health block reads the monitor's values from them). A failure inside the
AIS stage is counted and logged once and the fixes go out unannotated: AIS never stops tracking.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass, field

from drivers.ais_input import AisInputBase, SerialAisInput, UdpAisInput
from edge.ais.stage import AisStage, Geometry
from edge.appliance.health import HealthMonitor, Stage
from edge.config.ais import AisConfig, AisSerialInput
from edge.core.site import Site
from edge.fix import ShipFix

log = logging.getLogger(__name__)

AIS_STAGE_CODE = 90  # FAULT_CODE 901 (no heartbeat) / 902 (receiver gone or calibration check)


def ais_stage(stale_s: float) -> Stage:
    """The `ais` health stage: non-critical (tracking goes on without AIS)."""
    return Stage("ais", AIS_STAGE_CODE, max(5.0, stale_s), critical=False)


def build_input(cfg: AisConfig) -> AisInputBase | None:
    src = cfg.input
    if src is None:
        return None
    if isinstance(src, AisSerialInput):
        return SerialAisInput(src.url, src.baud, max_lines=cfg.queue_lines)
    return UdpAisInput(src.port, src.host, src.group, max_lines=cfg.queue_lines)


@dataclass
class RecordedAis:
    """A recording's AIS lines (ais.csv, the recording's clock), handed out up to each pair."""

    lines: Sequence[tuple[int, str]]
    next: int = field(default=0, init=False)

    def until(self, t_ns: int) -> list[tuple[int, str]]:
        """The lines stamped at or before `t_ns` not handed out yet."""
        start = self.next
        while self.next < len(self.lines) and self.lines[self.next][0] <= t_ns:
            self.next += 1
        return list(self.lines[start:self.next])


AisSource = AisInputBase | RecordedAis


class LiveAis:
    """The configured AIS source and the stage that associates its reports with the tracks."""

    def __init__(self, cfg: AisConfig, site: Site, focal_px: float, baseline_m: float,
                 source: AisSource | None = None) -> None:
        self.cfg = cfg
        self.stage = AisStage(cfg, site, focal_px, baseline_m)
        self.source = source if source is not None else build_input(cfg)
        self.failures = 0

    def start(self, t_ns: int) -> None:
        if isinstance(self.source, AisInputBase):
            self.source.start()
        if self.source is not None:
            self.stage.start(t_ns)

    def close(self) -> None:
        if isinstance(self.source, AisInputBase):
            self.source.close()

    def step(self, fixes: Sequence[ShipFix], geometry: Geometry | None, health: HealthMonitor | None,
             t_ns: int = 0) -> list[ShipFix]:
        """The fixes annotated with the lines received up to now (a recording's: up to `t_ns`)."""
        out = list(fixes)
        try:
            if isinstance(self.source, RecordedAis):
                for t_line_ns, text in self.source.until(t_ns):
                    self.stage.feed(t_line_ns, text)
            elif self.source is not None:
                if self.source.stats().fault is not None:  # receiver gone: no dark flags meanwhile
                    self.stage.input_lost()
                for t_line_ns, line in self.source.drain():
                    self.stage.feed(t_line_ns, line)
            out = self.stage.annotate(fixes, geometry)
        except Exception as exc:  # a bug or a bad line the decoder missed: count, never stop
            self.failures += 1
            if self.failures == 1:
                log.warning("AIS stage failed (counted, logged once): %r", exc)
        if health is not None:
            counters = self.stage.health_counters()
            fault = self.stage.fault()
            if isinstance(self.source, AisInputBase):
                st = self.source.stats()
                counters.update(input_lines=st.lines, input_dropped=st.dropped, input_errors=st.errors,
                                input_reconnects=st.reconnects)
                fault = st.fault or fault
            counters["stage_failures"] = self.failures
            health.beat("ais", fault=fault, counters=counters)
        return out
