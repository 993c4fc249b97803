"""edge.measure.boxes: the association's box overlaps and containment, against known answers and against a
pair-by-pair reference written from the definition."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from edge.measure.boxes import contains, inside, overlaps


def _one(a: list[float], b: list[float]) -> float:
    return float(overlaps(np.array([a]), np.array([b]))[0, 0])


def test_overlap_is_a_column_iou_for_boxes_in_the_same_rows() -> None:
    a = [10.0, 100.0, 50.0, 110.0]
    assert _one(a, a) == pytest.approx(1.0)
    b = [30.0, 98.0, 70.0, 112.0]
    assert _one(a, b) == pytest.approx(20 / 60) == pytest.approx(_one(b, a))
    assert _one(a, [10.0, 140.0, 50.0, 150.0]) == 0.0  # far below: another ship
    assert _one(a, [55.0, 100.0, 95.0, 110.0]) == 0.0  # no common column


def _reference(a: list[float], b: list[float]) -> float:
    """The definition pair by pair, in Python floats."""
    inter = min(a[2], b[2]) - max(a[0], b[0])
    if inter <= 0 or abs((a[1] + a[3]) - (b[1] + b[3])) > (a[3] - a[1]) + (b[3] - b[1]) + 4.0:
        return 0.0
    return inter / (max(a[2], b[2]) - min(a[0], b[0]))


_coord = st.floats(0.0, 500.0, allow_nan=False)
_box = st.tuples(_coord, _coord, st.floats(0.5, 200.0), st.floats(0.5, 60.0)).map(
    lambda t: [t[0], t[1], t[0] + t[2], t[1] + t[3]])


@given(st.lists(_box, min_size=1, max_size=6), st.lists(_box, min_size=1, max_size=6))
@settings(max_examples=200, deadline=None)
def test_overlaps_of_all_pairs_equal_the_definition_pair_by_pair(a: list, b: list) -> None:
    got = overlaps(np.array(a), np.array(b))
    assert got.shape == (len(a), len(b))
    for i, ba in enumerate(a):
        for j, bb in enumerate(b):
            assert got[i, j] == _reference(ba, bb)  # the same IEEE operations: equal, not close


@given(st.lists(_box, min_size=1, max_size=6), st.lists(st.tuples(_coord, _coord), min_size=1, max_size=6))
@settings(max_examples=200, deadline=None)
def test_inside_is_contains_for_every_point_and_box(boxes: list, points: list) -> None:
    u, v = [p[0] for p in points], [p[1] for p in points]
    got = inside(np.array(boxes), u, v)
    for i, (pu, pv) in enumerate(points):
        for j, box in enumerate(boxes):
            assert bool(got[i, j]) == contains(np.array(box), pu, pv)
    assert contains(np.array([0.0, 0.0, 10.0, 5.0]), 0.0, 4.99)
    assert not contains(np.array([0.0, 0.0, 10.0, 5.0]), 10.0, 2.0)  # right and bottom edges are out
