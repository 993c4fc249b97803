"""ASTERIX on a replay against the NMEA of the same replay, decoded by asterix-decoder (issue 26's
acceptance on a short cached recording; tools/asterix-check runs it on the evaluation recordings)."""

from __future__ import annotations

import io
import math

import pytest

from edge.config.asterix import AsterixConfig
from edge.core.geo import range_bearing, world_to_latlon
from edge.core.site import Site
from edge.fix import ShipFix, TrackStatus
from edge.outputs.asterix import AsterixOutput
from edge.outputs.nmea_stream import NmeaStreamOutput
from edge.replay import replay
from lab.asterix_check import check_recording, compare, split_blocks

pytest.importorskip("asterix")  # asterix-decoder, the test extra


def test_replay_blocks_match_the_nmea_field_by_field(recording) -> None:
    check = check_recording(recording("akashi-crossing", 30))
    assert check.updates > 0 and check.unmatched == 0
    assert check.max_position_m <= 1.0
    assert check.number_changes == 0 and check.shared_numbers == 0
    assert check.tre_missing == 0 and check.numbers_ended >= check.tracks
    assert check.speed_bad == check.course_bad == check.velocity_missing == check.velocity_extra == 0
    assert check.velocity_bad == check.tre_midway == 0
    assert check.largest_block <= 1472 and check.passed


def test_no_track_ends_in_the_middle_on_akashi_crossing_95(recording) -> None:
    """The golden replay's recording: the far ship's point cannot be ranged on in some pairs from 6 s
    on. Its track coasts there (CST) under the same number and ends once, at its drop (TRE on
    its last report only); before every live track was in every step's list, it ended 4 times."""
    check = check_recording(recording("akashi-crossing", 95))
    assert check.tre_midway == 0 and check.tre_missing == 0 and check.number_changes == 0
    assert check.coasting_midway > 0  # the case is there: reports that coast and go on
    assert check.passed


def test_a_wrong_position_fails_the_check(recording) -> None:
    """The check is not vacuous: a TLL moved by 2 m no longer matches within 1 m."""
    nmea, blocks = io.StringIO(), io.BytesIO()
    replay(recording("akashi-crossing", 30), nmea=nmea, asterix=blocks)
    text = nmea.getvalue()
    line = next(x for x in text.splitlines() if "TLL" in x)
    fields = line.split(",")
    minutes = float(fields[2][2:]) + 2.0 / 1852.0  # 2 m north
    moved = ",".join([fields[0], fields[1], f"{fields[2][:2]}{minutes:07.4f}", *fields[3:]])
    check = compare("moved", split_blocks(blocks.getvalue()), text.replace(line, moved, 1))
    assert check.max_position_m > 1.5 and not check.passed


def _moving(track_id: int, t_s: float, sog_kn: float, cog_deg: float) -> ShipFix:
    """A fix of a ship on a straight course from a point 2 km out, at `t_s`."""
    site = Site(34.63, 135.02, 25.0, 180.0)
    v = sog_kn * 1852.0 / 3600.0
    east = 300.0 * track_id + v * t_s * math.sin(math.radians(cog_deg))
    north = -2000.0 + v * t_s * math.cos(math.radians(cog_deg))
    world = [[-east, 20.0, -north]]  # heading 180: +X west, +Z south
    range_m, bearing = range_bearing(world, site.heading_deg)
    lat, lon, _ = world_to_latlon(world, site)
    return ShipFix(round(t_s * 1e9), track_id, TrackStatus.TRACKING, -east, 20.0, -north, float(range_m[0]),
                   float(bearing[0]), float(lat[0]), float(lon[0]), sog_kn, cog_deg, 6.0, 20.0)


def test_speed_and_course_are_compared_within_their_lsbs() -> None:
    """I010/200 and /202 against TTM on fixes that carry a course (the short golden clips carry none):
    every update passes, and a TTM course or speed moved by more than the LSBs allow fails (by 3 deg
    and 0.8 kn, so I010/202 at 0.25 m/s sees it too)."""
    text, blocks, now = io.StringIO(), [], [0.0]
    nmea = NmeaStreamOutput(text, clock=None, newline="\r\n")
    out = AsterixOutput(AsterixConfig(enabled=True), clock=lambda: now[0])
    for k in range(60):
        now[0] = 0.1 * k
        fixes = [_moving(1, now[0], 12.34, 47.3), _moving(2, now[0], 3.1, 301.9)]
        nmea.publish(fixes, fixes[0].t_ns)
        blocks += out.publish(fixes, fixes[0].t_ns)
    blocks += out.finish()
    good = compare("straight", blocks, text.getvalue())
    assert good.speed_checked >= 10 and good.passed
    assert good.max_speed_kn <= 0.5 * 3600 / 2**14 + 0.05 and good.max_velocity_mps <= 0.125
    ttm = next(line for line in text.getvalue().splitlines() if "TTM" in line and ",47.3," in line)
    for old, new, bad in ((",47.3,", ",50.3,", "course_bad"), (",12.3,", ",13.1,", "speed_bad")):
        check = compare("moved", blocks, text.getvalue().replace(ttm, ttm.replace(old, new), 1))
        assert getattr(check, bad) == 1 and check.velocity_bad == 1 and not check.passed
