"""The verifier's additive model: integer path against the float reference, stored-form round trip,
known scores from hand-made tables, and malformed models refused."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from edge.core.shipscore import AdditiveModel, Q, model_from_dict, model_to_dict


def _model(seed: int, n_features: int = 5) -> AdditiveModel:
    rng = np.random.default_rng(seed)
    edges = tuple(np.sort(rng.choice(np.linspace(-3, 3, 61), size=rng.integers(0, 6), replace=False))
                  for _ in range(n_features))
    tables = tuple(rng.normal(0, 1.5, len(e) + 1) for e in edges)
    return AdditiveModel(tuple(f"f{i}" for i in range(n_features)), edges, tables,
                         float(rng.normal()), float(rng.normal()))


def test_known_scores_from_hand_made_tables() -> None:
    m = AdditiveModel(("a", "b"), (np.array([0.0, 1.0]), np.array([])),
                      (np.array([-1.0, 0.5, 2.0]), np.array([0.25])), bias=-0.5, threshold=1.0)
    x = np.array([[-1.0, 9.0], [0.0, 0.0], [0.5, 0.0], [1.0, 0.0], [7.0, -3.0]])
    # an edge belongs to the bin above it
    assert np.allclose(m.score_float(x), [-1.25, 0.25, 0.25, 1.75, 1.75])
    assert m.verified(x).tolist() == [False, False, False, True, True]


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 10_000), st.integers(1, 40))
def test_integer_score_is_the_float_one_within_rounding(seed: int, n: int) -> None:
    m = _model(seed)
    x = np.random.default_rng(seed + 1).normal(0, 2, (n, len(m.names)))
    diff = np.abs(m.score_q(x) / Q - m.score_float(x))
    assert diff.max() <= (len(m.names) + 1) / (2 * Q) + 1e-12
    # verified agrees with the float test except within that rounding of the threshold
    far = np.abs(m.score_float(x) - m.threshold) > (len(m.names) + 2) / (2 * Q)
    assert np.array_equal(m.verified(x)[far], (m.score_float(x) >= m.threshold)[far])


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 10_000))
def test_stored_form_round_trip(seed: int) -> None:
    m = _model(seed)
    back = model_from_dict(model_to_dict(m))
    assert back.names == m.names
    x = np.random.default_rng(seed).normal(0, 2, (20, len(m.names)))
    # the stored form rounds to 1e-4: the scores move by at most that per term (bins may move
    # only for features within 1e-4 of an edge, which these random values almost never are)
    assert np.abs(back.score_float(x) - m.score_float(x)).max() <= 1e-4 * (len(m.names) + 1) + 1e-9


def test_malformed_models_are_refused() -> None:
    with pytest.raises(ValueError, match="table entries"):
        AdditiveModel(("a",), (np.array([0.0]),), (np.array([1.0]),), 0.0, 0.0)
    with pytest.raises(ValueError, match="ascending"):
        AdditiveModel(("a",), (np.array([1.0, 0.0]),), (np.zeros(3),), 0.0, 0.0)
    with pytest.raises(ValueError, match="missing or malformed"):
        model_from_dict({"bias": 0.0, "features": {}})
    with pytest.raises(ValueError, match="features given"):
        AdditiveModel(("a",), (np.array([]),), (np.zeros(1),), 0.0, 0.0).score_float(np.zeros((2, 3)))
