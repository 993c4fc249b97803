"""The one processing chain: a frame pair in, the step's fixes out, with AIS and alerts applied.

pipeline (detect, track, match, filter, triangulate, ground track) -> AIS annotation (names,
MMSI, the dark flag) -> the alert step (new target, close quarters, dark, capacity, health).
The daemon, `replay` and `tools/evaluate` all run this object, so what a recording replays is what
the mast would have sent; outputs are transports that render the fixes and the alert manager's
state, and never compute either.

AIS lines come from the live receiver's queue (`LiveAis` with a driver) or from a recording's
ais.csv (`LiveAis` with `RecordedAis`), fed up to each pair's exposure either way. The alert
manager is stepped with the step's UTC and, on the appliance, the health snapshot; `idle` steps
its health part while no pair comes, `stop` ends every alert when the appliance stops.
"""

from __future__ import annotations

from drivers.camera.base import FramePair
from edge.ais.live import AisSource, LiveAis
from edge.alerts.manager import AlertManager
from edge.appliance.health import HealthMonitor, HealthSnapshot
from edge.config.ais import AisConfig
from edge.config.app import AppConfig
from edge.fix import ShipFix
from edge.pipeline import Pipeline


class Chain:
    """Pipeline, AIS and alerts in their one order; `step` once per pair."""

    def __init__(self, pipeline: Pipeline, ais: LiveAis | None = None,
                 alerts: AlertManager | None = None) -> None:
        self.pipeline, self.ais, self.alerts = pipeline, ais, alerts

    @staticmethod
    def build_ais(cfg: AisConfig | None, pipeline: Pipeline,
                  source: AisSource | None = None) -> LiveAis | None:
        """The AIS stage for `pipeline`'s geometry: the configured receiver, or `source` (a recording's
        lines); None when AIS is off (no `ais:` block and no recorded lines)."""
        if cfg is None and source is None:
            return None
        return LiveAis(cfg or AisConfig(), pipeline.site, pipeline.rect.f_px, pipeline.rig.baseline_m,
                       source=source)

    @classmethod
    def from_config(cls, config: AppConfig, pipeline: Pipeline, ais_source: AisSource | None = None) -> Chain:
        """The chain a configuration asks for around `pipeline`."""
        alerts = AlertManager(config.alerts, config.pipeline.max_tracks) if config.alerts.enabled else None
        return cls(pipeline, cls.build_ais(config.ais, pipeline, ais_source), alerts)

    def start(self, t_ns: int) -> None:
        """Open the AIS input (its thread), with `t_ns` as the stage's start on the lines' clock."""
        if self.ais is not None:
            self.ais.start(t_ns)

    def step(self, pair: FramePair, utc_ns: int | None = None, health: HealthMonitor | None = None
             ) -> list[ShipFix]:
        """The pair's fixes, annotated by AIS; the alert manager stepped with them at `utc_ns`
        (default: the pair's own clock, as replay runs it)."""
        fixes = self.pipeline.step(pair)
        if self.ais is not None:  # never raises: a failure is counted and the fixes go out unannotated
            fixes = self.ais.step(fixes, self.pipeline.ground.position, health, pair.t_ns)
        if self.alerts is not None:
            snapshot = None if health is None else health.snapshot()
            self.alerts.step(fixes, pair.t_ns if utc_ns is None else utc_ns, snapshot)
        return fixes

    def idle(self, utc_ns: int, health: HealthSnapshot) -> None:
        """No pair came: the alerts still follow the health (a camera gone raises its alert)."""
        if self.alerts is not None:
            self.alerts.health_step(utc_ns, health)

    def stop(self, utc_ns: int) -> None:
        """The appliance stops: every active alert ends (none is raised now)."""
        if self.alerts is not None:
            self.alerts.stop(utc_ns)

    def close(self) -> None:
        if self.ais is not None:
            self.ais.close()
