"""The Modbus health registers of issue 17's AIS stage (calibration check, input counters), from its
health counters: milli-units there, so the registers carry them unchanged. Kept apart from
edge.encode.registers, which declares the fields, so that the map module stays small."""

from __future__ import annotations

from edge.appliance.health import HealthSnapshot

AIS_FAULT_DISPARITY, AIS_FAULT_BEARING = 1 << 0, 1 << 1  # AIS_MONITOR_FAULTS bits


def ais_values(h: HealthSnapshot, names: list[str]) -> dict[str, float | None]:
    """The AIS health registers `names` from the `ais` stage's counters (all "not available"
    without it)."""
    c = next((s.counters for s in h.stages if s.name == "ais"), None)
    values: dict[str, float | None] = dict.fromkeys(names)
    if c is None:
        return values

    def milli(key: str) -> float | None:
        return c[key] / 1000.0 if key in c else None

    values.update(
        AIS_DISP_OFFSET=milli("disparity_offset_mpx"), AIS_DISP_SIGMA=milli("disparity_sigma_mpx"),
        AIS_BRG_OFFSET=milli("bearing_offset_mdeg"), AIS_BRG_SIGMA=milli("bearing_sigma_mdeg"),
        AIS_MONITOR_SHIPS=c.get("monitor_ships", 0),
        AIS_MONITOR_FAULTS=(AIS_FAULT_DISPARITY if c.get("disparity_fault") else 0)
        | (AIS_FAULT_BEARING if c.get("bearing_fault") else 0),
        AIS_TARGETS=c.get("targets", 0), AIS_LINES=c.get("lines", 0), AIS_DECODED=c.get("decoded", 0),
        AIS_CHECKSUM_ERRORS=c.get("checksum_errors", 0),
        AIS_MALFORMED=c.get("malformed", 0) + c.get("unknown_type", 0),
        AIS_INCOMPLETE=c.get("incomplete", 0), AIS_TOO_OLD=c.get("too_old", 0),
        AIS_INPUT_ERRORS=c.get("input_errors", 0) + c.get("input_dropped", 0))
    return values
