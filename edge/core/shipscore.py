"""The verifier's score: an additive model of lookup tables, one per candidate feature, in integers.

Why: the features of a candidate (edge.core.shipfeatures) do not act linearly: a body too flat
is a crest and one too tall for its row is a mast or a post, a contrast ratio helps up to a point
and then says no more. An additive model of one table per feature (each feature cut into a few
bins by fixed edges, one score per bin, the scores summed: a generalised additive model, fitted
as a logistic regression on the bin indicators by lab/evaluate/detect_train.py) follows such
curves, stays readable (one row of numbers per feature, plotted in docs/detection-real.md) and
is integer: a candidate's score is the sum of its bins' entries in Q8 and the test is one
comparison with the threshold in Q8.

    bin_i(x)   = number of edges_i <= x_i             (0 .. len(edges_i))
    score(x)   = bias + sum_i table_i[bin_i(x_i)]     (the log-odds of "a vessel")
    verified   : score >= threshold

`score_q` is the integer path (tables, bias and threshold rounded to 1/256); `score_float` the
float reference; they differ by at most (n_features + 1) / 512 (rounding of each term).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

Q = 256  # score units per log-odds unit in the integer path


@dataclass(frozen=True)
class AdditiveModel:
    """Per feature: ascending bin edges and len(edges) + 1 scores; a bias and a threshold."""

    names: tuple[str, ...]
    edges: tuple[np.ndarray, ...]
    tables: tuple[np.ndarray, ...]
    bias: float
    threshold: float

    def __post_init__(self) -> None:
        if not len(self.names) == len(self.edges) == len(self.tables):
            raise ValueError("one name, one edge list and one table per feature")
        for name, e, t in zip(self.names, self.edges, self.tables, strict=True):
            if len(t) != len(e) + 1:
                raise ValueError(f"{name}: {len(e)} edges need {len(e) + 1} table entries, got {len(t)}")
            if len(e) > 1 and not np.all(np.diff(e) > 0):
                raise ValueError(f"{name}: bin edges must be strictly ascending")

    def bins(self, features: np.ndarray) -> np.ndarray:
        """(n, F) bin index of each feature (int)."""
        x = np.atleast_2d(np.asarray(features, dtype=np.float64))
        if x.shape[1] != len(self.names):
            raise ValueError(f"{x.shape[1]} features given, the model has {len(self.names)}")
        return np.stack([np.searchsorted(e, x[:, i], side="right") for i, e in enumerate(self.edges)],
                        axis=1)

    def score_float(self, features: np.ndarray) -> np.ndarray:
        """Float reference: the log-odds of each row of `features`."""
        b = self.bins(features)
        return self.bias + sum(t[b[:, i]] for i, t in enumerate(self.tables))

    def tables_q(self) -> tuple[list[np.ndarray], int, int]:
        """(tables, bias, threshold) in Q8 integers."""
        tabs = [np.round(np.asarray(t) * Q).astype(np.int32) for t in self.tables]
        return tabs, int(round(self.bias * Q)), int(round(self.threshold * Q))

    def score_q(self, features: np.ndarray) -> np.ndarray:
        """Integer path: the log-odds in Q8 (int64)."""
        tabs, bias, _ = self.tables_q()
        b = self.bins(features)
        total = np.full(b.shape[0], bias, np.int64)
        for i, t in enumerate(tabs):
            total += t[b[:, i]]
        return total

    def verified(self, features: np.ndarray) -> np.ndarray:
        """Boolean per row: the integer score reaches the integer threshold."""
        _, _, thr = self.tables_q()
        return self.score_q(features) >= thr


def model_from_dict(data: dict) -> AdditiveModel:
    """The model from its stored form: {bias, threshold, features: {name: {edges, table}}}."""
    try:
        feats = data["features"]
        names = tuple(str(k) for k in feats)
        return AdditiveModel(names, tuple(np.asarray(feats[n]["edges"], np.float64) for n in names),
                             tuple(np.asarray(feats[n]["table"], np.float64) for n in names),
                             float(data["bias"]), float(data["threshold"]))
    except (KeyError, TypeError) as exc:
        raise ValueError(f"verifier model: missing or malformed {exc}") from exc


def model_to_dict(model: AdditiveModel) -> dict:
    """The stored form (plain lists of floats, rounded to 1e-4)."""
    return {"bias": round(model.bias, 4), "threshold": round(model.threshold, 4),
            "features": {n: {"edges": [round(float(v), 4) for v in e],
                             "table": [round(float(v), 4) for v in t]}
                         for n, e, t in zip(model.names, model.edges, model.tables, strict=True)}}
