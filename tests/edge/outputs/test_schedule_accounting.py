"""Every fix handed to the NMEA scheduler ends in exactly one of its counters (computed = emitted +
dropped by a documented reason + still held), whatever the tracks, statuses, budget and numbers do."""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st

from edge.fix import ShipFix, TrackStatus
from edge.outputs.schedule import NmeaSchedule, NmeaScheduler


def fix(track_id: int, status: TrackStatus) -> ShipFix:
    return ShipFix(t_ns=0, track_id=track_id, status=status, x_m=0.0, y_m=0.0, z_m=1000.0,
                   range_m=1000.0, bearing_deg=10.0, lat_deg=34.6, lon_deg=135.0, sog_kn=None,
                   cog_deg=None, sigma_m=5.0, disparity_px=7.0)


steps = st.lists(st.tuples(
    st.dictionaries(st.integers(1, 8), st.sampled_from(list(TrackStatus)), max_size=6),
    st.floats(0.0, 3.0),  # seconds to the next step
), max_size=60)


@settings(max_examples=150, deadline=None)
@given(steps=steps, max_number=st.integers(1, 4), budget=st.sampled_from([None, 60.0, 400.0]),
       acquiring=st.booleans())
def test_every_fix_is_sent_dropped_for_a_reason_or_held(steps, max_number, budget, acquiring) -> None:
    now = [0.0]
    sched = NmeaScheduler(NmeaSchedule(max_target_number=max_number, quarantine_s=5.0,
                                       send_acquiring=acquiring), budget, clock=lambda: now[0])
    handed = 0
    for tracks, dt_s in steps:
        fixes = [fix(tid, status) for tid, status in tracks.items()]
        handed += len(fixes)
        sched.step(fixes)
        s = sched.stats()
        assert s.fixes_in == handed
        assert s.fixes_in == s.fixes_sent + s.fixes_dropped + s.fixes_pending, s
        assert s.fixes_sent <= s.groups_sent
        now[0] += dt_s


def test_a_fix_replaced_inside_the_refresh_interval_is_superseded_not_lost() -> None:
    now = [0.0]
    sched = NmeaScheduler(NmeaSchedule(min_refresh_s=1.0), None, clock=lambda: now[0])
    for _ in range(10):  # 10 fixes of one track in 0.9 s: the first goes out, 8 superseded, 1 held
        sched.step([fix(1, TrackStatus.TRACKING)])
        now[0] += 0.1
    s = sched.stats()
    assert (s.fixes_sent, s.fixes_superseded, s.fixes_pending) == (1, 8, 1)
    now[0] = 1.0
    sched.step([])  # the track is gone: its held fix goes out as its first L
    s = sched.stats()
    assert (s.fixes_sent, s.fixes_superseded, s.fixes_pending, s.lost_groups_sent) == (2, 8, 0, 1)
