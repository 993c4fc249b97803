"""console: the live table shows every fix nearest first with its NMEA number, unknowns as '-',
redraws in place on a terminal and at most every few seconds on a pipe."""

from __future__ import annotations

import io

from edge.appliance.console import LiveTable, rows
from edge.appliance.health import HealthMonitor, standard_stages
from edge.fix import ShipFix, TrackStatus


def fix(track_id: int, range_m: float, sog: float | None) -> ShipFix:
    return ShipFix(0, track_id, TrackStatus.TRACKING, 0.0, 0.0, range_m, range_m, 123.4, 34.6, 135.0,
                   sog, None, 12.3, 5.0, age_s=7.25)


def test_rows_nearest_first_with_numbers_and_unknowns() -> None:
    lines = rows([fix(7, 2500.0, None), fix(3, 900.0, 11.5)], {3: 1})
    assert lines[0].split()[:4] == ["1", "3", "T", "900"] and "11.5" in lines[0]
    assert lines[1].split()[:2] == ["-", "7"] and lines[1].split()[5] == "-"  # no number, no SOG


class Tty(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_redraws_in_place_on_a_terminal_and_throttles_on_a_pipe() -> None:
    snap = HealthMonitor(standard_stages()).snapshot()
    now = [0.0]
    tty, pipe = Tty(), io.StringIO()
    views = [LiveTable(s, lambda fixes: {}, clock=lambda: now[0]) for s in (tty, pipe)]
    for step in range(10):
        now[0] = step * 1.0
        for v in views:
            v.update(10**18, [fix(1, 1000.0, 5.0)])
            v.draw(snap)
    assert tty.getvalue().count("\x1b[H\x1b[J") == 10
    assert "\x1b" not in pipe.getvalue() and pipe.getvalue().count("range m") == 2  # t = 0 and 5 s


def test_ais_name_and_dark_columns_only_when_there_is_ais() -> None:
    from edge.fix import ShipFix, TrackStatus

    base = ShipFix(
        0, 7, TrackStatus.TRACKING, 0.0, 0.0, 900.0, 900.0, 180.0, 34.6, 135.0, None, None, 2.0, 10.0
    )
    import dataclasses

    (plain,) = rows([base], {})
    (named,) = rows([dataclasses.replace(base, ais_mmsi=431000123, ais_name="AKASHI MARU")], {})
    (dark,) = rows([dataclasses.replace(base, dark=True)], {})
    assert named == plain + "  AKASHI MARU" and dark == plain + "  DARK7"
