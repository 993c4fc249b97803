"""Median and least-squares line of the few values a track keeps.

In plain Python on purpose: np.median and np.polyfit cost 20-40 us a call, more than the work
itself on a handful of values.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence


def median(values: Iterable[float]) -> float:
    """Median of a short sequence (sorted(); np.median's overhead is ~20 us on a handful of values)."""
    v = sorted(values)
    n = len(v)
    return float(v[n // 2] if n % 2 else 0.5 * (v[n // 2 - 1] + v[n // 2]))


def line_fit(points: Sequence[tuple[float, float]]) -> tuple[float, float]:
    """Least-squares line through (t, y) points: (y at the last t, slope per unit t)."""
    t_last = points[-1][0]
    n = len(points)
    st = sum(p[0] - t_last for p in points)
    sy = sum(p[1] for p in points)
    stt = sum((p[0] - t_last) ** 2 for p in points)
    sty = sum((p[0] - t_last) * p[1] for p in points)
    den = n * stt - st * st
    slope = (n * sty - st * sy) / den if den else 0.0
    return (sy - slope * st) / n, slope
