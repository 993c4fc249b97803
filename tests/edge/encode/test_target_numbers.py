"""edge.encode.target_numbers: target numbers are unique among live tracks and never reused
within the quarantine."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from edge.encode.target_numbers import TargetNumbers


def test_numbers_start_at_one_and_stay_with_their_track() -> None:
    numbers = TargetNumbers()
    assert [numbers.assign(t, 0.0) for t in (10, 11, 12)] == [1, 2, 3]
    assert numbers.assign(11, 5.0) == 2 and numbers.number_of(11) == 2
    assert numbers.digits == 2 and TargetNumbers(999).digits == 3


def test_a_retired_number_waits_the_quarantine_then_is_lent_least_recently_used_first() -> None:
    numbers = TargetNumbers(max_number=3, quarantine_s=60.0)
    for track in (1, 2, 3):
        numbers.assign(track, 0.0)
    assert numbers.release(2) == 2
    assert numbers.assign(4, 1.0) is None  # lost: still reserved
    numbers.retire(2, 3.0)  # the last L went out at t = 3 s
    assert numbers.assign(4, 62.9) is None
    assert numbers.assign(4, 63.0) == 2
    numbers.release(1), numbers.retire(1, 70.0)
    numbers.release(3), numbers.retire(3, 65.0)
    assert numbers.assign(5, 200.0) == 3  # free since 125 s, before 1 (130 s)
    assert numbers.assign(6, 200.0) == 1


def test_all_busy_refuses_new_tracks_and_never_steals_a_live_number() -> None:
    numbers = TargetNumbers()
    assert [numbers.assign(t, 0.0) for t in range(1000, 1099)] == list(range(1, 100))
    assert numbers.assign(5000, 0.0) is None and numbers.busy() == 99
    assert all(numbers.number_of(t) == t - 999 for t in range(1000, 1099))


def test_a_track_that_comes_back_gets_its_old_number() -> None:
    numbers = TargetNumbers(max_number=5)
    numbers.assign(7, 0.0)
    numbers.release(7)
    assert numbers.assign(7, 1.0) == 1  # from "lost"
    numbers.release(7)
    numbers.retire(1, 2.0)
    assert numbers.assign(7, 3.0) == 1  # from quarantine
    with pytest.raises(ValueError):
        TargetNumbers(max_number=0)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.sampled_from(["assign", "release", "retire"]), st.integers(0, 30),
                          st.floats(0.0, 30.0)), max_size=300))  # fmt: skip
def test_random_histories_keep_numbers_unique_and_quarantined(ops: list[tuple[str, int, float]]) -> None:
    numbers = TargetNumbers(max_number=8, quarantine_s=60.0)
    now_s, next_track = 0.0, 0
    owner: dict[int, int] = {}  # number -> track id, live or lost
    retired_at: dict[int, tuple[int, float]] = {}  # number -> (track, time of its last use)
    for op, pick, dt_s in ops:
        now_s += dt_s
        if op == "assign":
            next_track += 1
            track = next_track if pick % 3 else max(1, next_track - pick)  # sometimes an old track returns
            if numbers.number_of(track) is not None:
                continue
            number = numbers.assign(track, now_s)
            if number is None:
                continue
            came_back = retired_at.get(number, (None, 0.0))[0] == track or owner.get(number) == track
            assert came_back or number not in owner, "number lent twice"
            if number in retired_at and not came_back:
                assert now_s - retired_at[number][1] >= 60.0, "number reused inside the quarantine"
            owner[number] = track
            retired_at.pop(number, None)
        elif op == "release" and owner:
            number = sorted(owner)[pick % len(owner)]
            if numbers.number_of(owner[number]) == number:
                assert numbers.release(owner[number]) == number
        elif op == "retire":
            lost = [n for n, t in owner.items() if numbers.number_of(t) != n]
            if lost:
                number = lost[pick % len(lost)]
                numbers.retire(number, now_s)
                retired_at[number] = (owner.pop(number), now_s)
