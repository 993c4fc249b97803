"""The AIS input of the running appliance: the configured driver (its own thread and bounded
queue, `drivers.ais_input`) and the `AisStage`, with the `ais` health stage.

The processing thread calls `step(fixes, geometry)` once per pair: it drains the driver's queue
without blocking, feeds the lines to the stage and returns the annotated fixes, and beats the
health stage with the driver's fault (receiver gone) or the calibration check's fault, and the
counters (the Modbus health block reads the monitor's values from them). A failure inside the
AIS stage is counted and logged once and the fixes go out unannotated: AIS never stops tracking.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence

from drivers.ais_input import AisInputBase, SerialAisInput, UdpAisInput
from edge.ais.stage import AisStage, Geometry
from edge.config.ais import AisConfig, AisSerialInput
from edge.core.site import Site
from edge.fix import ShipFix
from edge.health import HealthMonitor, Stage

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


class LiveAis:
    def __init__(self, cfg: AisConfig, site: Site, focal_px: float, baseline_m: float,
                 source: AisInputBase | None = None) -> None:
        self.cfg = cfg
        self.stage = AisStage(cfg, site, focal_px, baseline_m)
        self.source = source if source is not None else build_input(cfg)
        self.failures = 0

    def start(self, t_ns: int) -> None:
        if self.source is not None:
            self.source.start()
            self.stage.start(t_ns)

    def close(self) -> None:
        if self.source is not None:
            self.source.close()

    def step(self, fixes: Sequence[ShipFix], geometry: Geometry | None, health: HealthMonitor | None
             ) -> list[ShipFix]:
        out = list(fixes)
        try:
            if self.source is not None:
                if self.source.stats().fault is not None:  # receiver gone: no dark flags meanwhile
                    self.stage.input_lost()
                for t_ns, line in self.source.drain():
                    self.stage.feed(t_ns, line)
            out = self.stage.annotate(fixes, geometry)
        except Exception as exc:  # a bug or a bad line the decoder missed: count, never stop
            self.failures += 1
            if self.failures == 1:
                log.warning("AIS stage failed (counted, logged once): %r", exc)
        if health is not None:
            counters = self.stage.health_counters()
            fault = self.stage.fault()
            if self.source is not None:
                st = self.source.stats()
                counters.update(input_lines=st.lines, input_dropped=st.dropped, input_errors=st.errors,
                                input_reconnects=st.reconnects)
                fault = st.fault or fault
            counters["stage_failures"] = self.failures
            health.beat("ais", fault=fault, counters=counters)
        return out
