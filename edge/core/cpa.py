"""Closest point of approach between two constant-velocity tracks, and its uncertainty.

Pure computation on east/north states (m, m, m/s, m/s) such as the ground-plane filter's
(`edge.measure.groundtrack`), for every pair of tracks at once (numpy, no loops over pairs: a
full table of 99 tracks is 4851 pairs per step).

With p = p_B - p_A and v = v_B - v_A (the relative position and velocity, eq. 18.1):

    TCPA  t = -(p . v) / |v|^2                                   eq. 18.2
    miss  m = (p_e v_n - p_n v_e) / |v|    (signed; CPA = |m|)    eq. 18.3

m is the signed distance of the relative track from the origin: the CPA vector p + t v is
perpendicular to v with length |m|. Its sign says on which side B passes A. Working with m rather
than CPA = |m| keeps the function smooth through a zero CPA (a collision course), where |m| has
no gradient, so the linearised uncertainty holds there too.

Uncertainty (first order): the two tracks' filters are independent, so the relative state
(p, v) has covariance C = P_A + P_B (4x4, state order e, n, ve, vn; eq. 18.4), and
(sigma_m^2, sigma_t^2) are the diagonal of J C J^T with the Jacobian

    dm/dp = (v_n, -v_e) / |v|              dm/dv = (-p_n, p_e) / |v| - m v / |v|^2
    dt/dp = -v / |v|^2                     dt/dv = -(p + 2 t v) / |v|^2            eq. 18.5

It holds while the relative velocity's error is small against |v| (the Monte Carlo test in
tests/edge/core/test_cpa.py checks the agreement); a pair whose relative speed is below
`MIN_REL_SPEED_MPS` has no defined TCPA (inf) and a CPA equal to its current distance.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

MIN_REL_SPEED_MPS = 0.05  # about 0.1 kn: slower relative motion has no meaningful TCPA


@dataclass(frozen=True)
class PairCpa:
    """CPA/TCPA of pairs (i, j), i < j, as arrays of one length (one entry per pair)."""

    i: np.ndarray  # int, index of track A
    j: np.ndarray  # int, index of track B
    miss_m: np.ndarray  # signed miss distance m (eq. 18.3); CPA = |miss_m|
    tcpa_s: np.ndarray  # eq. 18.2; inf without relative motion, negative once past
    miss_sigma_m: np.ndarray  # 1-sigma of miss_m (eq. 18.5)
    tcpa_sigma_s: np.ndarray  # 1-sigma of tcpa_s (inf without relative motion)
    range_m: np.ndarray  # current distance between the two

    @property
    def cpa_m(self) -> np.ndarray:
        return np.abs(self.miss_m)


def relative_cpa(p: np.ndarray, v: np.ndarray, cov: np.ndarray | None = None
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(miss m, tcpa s, sigma miss m, sigma tcpa s) of relative positions `p` (..., 2) and
    velocities `v` (..., 2) with relative covariance `cov` (..., 4, 4) or None (sigmas 0)."""
    p, v = np.asarray(p, float), np.asarray(v, float)
    s = np.einsum("...k,...k->...", v, v)  # |v|^2
    moving = s > MIN_REL_SPEED_MPS**2
    s_safe = np.where(moving, s, 1.0)
    speed = np.sqrt(s_safe)
    t = np.where(moving, -np.einsum("...k,...k->...", p, v) / s_safe, np.inf)  # eq. 18.2
    dist = np.sqrt(np.einsum("...k,...k->...", p, p))
    cross = p[..., 0] * v[..., 1] - p[..., 1] * v[..., 0]
    m = np.where(moving, cross / speed, dist)  # eq. 18.3 (parallel: the current distance)
    if cov is None:
        zero = np.zeros_like(m)
        return m, t, zero, np.where(moving, zero, np.inf)
    cov = np.asarray(cov, float)
    t0 = np.where(moving, t, 0.0)
    jm = np.empty(m.shape + (4,))
    jm[..., 0] = v[..., 1] / speed
    jm[..., 1] = -v[..., 0] / speed
    jm[..., 2] = -p[..., 1] / speed - m * v[..., 0] / s_safe
    jm[..., 3] = p[..., 0] / speed - m * v[..., 1] / s_safe
    jt = np.empty_like(jm)
    jt[..., :2] = -v / s_safe[..., None]
    jt[..., 2:] = -(p + 2.0 * t0[..., None] * v) / s_safe[..., None]  # eq. 18.5
    # not moving: the distance's own gradient, p / |p|, on the positions
    unit = p / np.maximum(dist, 1e-9)[..., None]
    jm = np.where(moving[..., None], jm, np.concatenate([unit, np.zeros_like(unit)], axis=-1))
    var_m = np.einsum("...a,...ab,...b->...", jm, cov, jm)
    var_t = np.einsum("...a,...ab,...b->...", jt, cov, jt)
    sigma_m = np.sqrt(np.maximum(var_m, 0.0))
    sigma_t = np.where(moving, np.sqrt(np.maximum(var_t, 0.0)), np.inf)
    return m, t, sigma_m, sigma_t


def pair_cpa(states: np.ndarray, covs: np.ndarray) -> PairCpa:
    """Every pair i < j of `states` (n, 4: east m, north m, v east m/s, v north m/s) with their
    filters' covariances `covs` (n, 4, 4), independent between tracks (eq. 18.4)."""
    states, covs = np.asarray(states, float), np.asarray(covs, float)
    n = len(states)
    i, j = np.triu_indices(n, k=1)
    p = states[j, :2] - states[i, :2]  # eq. 18.1
    v = states[j, 2:] - states[i, 2:]
    m, t, sm, st = relative_cpa(p, v, covs[i] + covs[j])  # eq. 18.4
    return PairCpa(i, j, m, t, sm, st, np.hypot(p[:, 0], p[:, 1]))
