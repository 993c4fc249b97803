"""median() equals numpy's, line_fit() polyfit's."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from edge.core.linefit import median


@settings(max_examples=40, deadline=None)
@given(st.lists(st.floats(-1e3, 1e3), min_size=1, max_size=25))
def test_median_equals_numpy(values: list[float]) -> None:
    assert median(values) == pytest.approx(float(np.median(values)))
