"""The per-fix CSV (docs/outputs.md): its header and one row per fix (`replay --tracks`,
`outputs.tracks_csv`).

Columns may be added at the end, never reordered or renamed (the contract). Numbers have fixed
decimals; an unknown value is an empty cell, never 0 and never 'nan'.
"""

from __future__ import annotations

import math

from edge.fix import ShipFix

CSV_HEADER = ("t_ns,track_id,status,x_m,y_m,z_m,range_m,bearing_deg,lat,lon,"
              "sog_kn,cog_deg,sigma_m,disparity_px")


def _num(value: float | None, decimals: int) -> str:
    """Fixed decimals, empty when unknown (never 0 for unknown, never 'nan')."""
    if value is None or not math.isfinite(value):
        return ""
    text = f"{value:.{decimals}f}"
    return "0" + text[2:] if text.startswith("-0") and float(text) == 0.0 else text


def csv_row(fix: ShipFix) -> str:
    """One line of the tracks CSV (docs/outputs.md column order), without the newline."""
    return ",".join((
        str(fix.t_ns), str(fix.track_id), fix.status.value,
        _num(fix.x_m, 3), _num(fix.y_m, 3), _num(fix.z_m, 3), _num(fix.range_m, 3),
        _num(fix.bearing_deg, 4), _num(fix.lat_deg, 8), _num(fix.lon_deg, 8),
        _num(fix.sog_kn, 3), _num(fix.cog_deg, 3), _num(fix.sigma_m, 3), _num(fix.disparity_px, 5),
    ))
