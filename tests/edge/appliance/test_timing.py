"""Latency histograms: known observations land in the buckets Prometheus' `le` semantics says
(a value equal to a bound counts in that bound's bucket), cumulative counts end at the total."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from edge.appliance.timing import BOUNDS_S, STAGES, StageTimes


def test_known_values() -> None:
    t = StageTimes()
    for v in (0.0005, 0.001, 0.0011, 0.05, 7.0):
        t.observe({"chain": v})
    h = t.snapshot()["chain"]
    cum = dict(h.cumulative())
    assert (cum["0.001"], cum["0.002"], cum["0.05"], cum["5.0"], cum["+Inf"]) == (2, 3, 4, 4, 5)
    assert h.count == 5 and h.sum_s == pytest.approx(0.0005 + 0.001 + 0.0011 + 0.05 + 7.0)
    assert t.snapshot()["queue"].count == 0


@given(st.lists(st.floats(0.0, 10.0), max_size=50))
def test_cumulative_counts_are_the_number_at_or_below_each_bound(values: list[float]) -> None:
    t = StageTimes()
    for v in values:
        t.observe(dict.fromkeys(STAGES, v))
    for h in t.snapshot().values():
        cum = h.cumulative()
        for (bound, n), b in zip(cum, BOUNDS_S, strict=False):
            assert n == sum(v <= b for v in values), bound
        assert cum[-1] == ("+Inf", len(values))
