"""What a Modbus alert slot shows (issue 18): the alert manager's state as rows for the register map.

`edge.outputs.fanout` builds an `AlertImage` from the `AlertManager` and the first NMEA port's
target numbers; `edge.encode.registers.build_snapshot` writes it into the alert header
(addresses 60-64) and the alert block (900 onwards, see docs/modbus.md).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass


@dataclass(frozen=True, slots=True)
class AlertRow:
    """One active alert as the alert slot shows it (edge.outputs.fanout builds them)."""

    alert_id: int
    instance: int | None
    acknowledged: bool
    priority: str  # A alarm, W warning, C caution
    revision: int
    targets: tuple[int | None, int | None]
    tracks: tuple[int | None, int | None]
    cpa_m: float | None
    tcpa_s: float | None
    age_s: float


@dataclass(frozen=True, slots=True)
class AlertImage:
    """The alert manager's state for one register image."""

    rows: tuple[AlertRow, ...]  # most urgent first; those beyond the slots are counted only
    unacknowledged: int
    raised: int
    health_ok: bool

    def header(self, block_address: int) -> dict[str, float | None]:
        """The health block's alert fields (addresses 60-64)."""
        return {"ALERTS_ACTIVE": len(self.rows), "ALERTS_UNACK": self.unacknowledged,
                "ALERTS_RAISED": self.raised, "HBT_STATUS": 2 if self.health_ok else 1,
                "ALERT_BLOCK_ADDR": block_address}


def alert_values(row: AlertRow | None, names: Sequence[str]) -> dict[str, float | None]:
    """One alert slot's physical values by field name (`names`: the slot's fields; None: unknown)."""
    values: dict[str, float | None] = dict.fromkeys(names)
    values.update(ALERT_ID=0, ALERT_STATE=0, ALERT_PRIORITY=0, ALERT_REVISION=0)
    if row is None:
        return values
    values.update(ALERT_ID=row.alert_id, ALERT_INSTANCE=row.instance,
                  ALERT_STATE=2 if row.acknowledged else 1,
                  ALERT_PRIORITY={"E": 1, "A": 1, "W": 2, "C": 3}[row.priority], ALERT_REVISION=row.revision,
                  ALERT_TARGET_A=row.targets[0], ALERT_TARGET_B=row.targets[1], ALERT_TRACK_A=row.tracks[0],
                  ALERT_TRACK_B=row.tracks[1], ALERT_CPA=row.cpa_m,
                  ALERT_TCPA=None if row.tcpa_s is None or not math.isfinite(row.tcpa_s) else row.tcpa_s,
                  ALERT_AGE=row.age_s)
    return values
