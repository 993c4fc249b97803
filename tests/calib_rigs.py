"""Synthetic stereo rigs (pinhole and poly10, 720x480, 8.14 m baseline) and noise-free landmarks seen by
both cameras: the calibration fit's tests (test_calibfit, test_calibsigma) share them."""

from __future__ import annotations

import numpy as np

from edge.core.calibfit import fit_rig
from edge.core.camera import PinholeCamera, Poly10Camera, StereoRig

W, H, BASELINE = 720, 480, 8.14
CENTRE = ((W - 1) / 2, (H - 1) / 2)


def pinhole_rig(
    f: float = 914.0, k1: float = -0.08, rot=((-1.5, -0.15, 0.1), (-1.45, 0.1, -0.05))
) -> StereoRig:
    left = PinholeCamera(f, f * 1.002, *CENTRE, (k1, 0.05, 2e-4, -1e-4, 0.0), rot[0])
    right = PinholeCamera(f * 1.001, f * 1.003, *CENTRE, (k1 * 0.9, 0.04, -1e-4, 2e-4, 0.0), rot[1])
    return StereoRig(BASELINE, W, H, left, right)


def poly10_rig(f: float = 914.0, k: float = 0.08, rot=((-1.5, -0.15, 0.1), (-1.45, 0.1, -0.05))) -> StereoRig:
    c = k / f**3
    left = Poly10Camera(*CENTRE, (1 / f, 2e-6, 3e-9, c, c, 1 / (f * 1.002), 0.0, -2e-9, c, c), rot[0])
    right = Poly10Camera(
        *CENTRE, (1 / (f * 1.001), -1e-6, 1e-9, 0.9 * c, c, 1 / f, 0.0, 1e-9, c, 1.1 * c), rot[1]
    )
    return StereoRig(BASELINE, W, H, left, right)


RIGS = {"pinhole": pinhole_rig, "poly10": poly10_rig}


def landmarks(rig: StereoRig, n: int, rng: np.random.Generator, z_range=(50.0, 3000.0), margin: float = 15.0):
    """n world points whose pixels fall inside both images; returns (world, uv_left, uv_right) noise-free."""
    out = np.empty((0, 3))
    while len(out) < n:
        uv = rng.uniform((margin, margin), (W - margin, H - margin), size=(4 * n, 2))
        z = np.exp(rng.uniform(*np.log(z_range), size=4 * n))
        xy = rig.left.pixel_to_normalised(uv)
        pts = np.column_stack([xy * z[:, None], z]) - (BASELINE / 2, 0.0, 0.0)
        _, ur = rig.project(pts)
        inside = (
            np.isfinite(ur).all(axis=1)
            & (ur >= margin).all(axis=1)
            & (ur <= (W - margin, H - margin)).all(axis=1)
        )
        out = np.vstack([out, pts[inside]])
    pts = out[:n]
    ul, ur = rig.project(pts)
    return pts, ul, ur


def fit(model: str, pts, ul, ur, **kw):
    return fit_rig(pts, ul, ur, model=model, baseline_m=BASELINE, width=W, height=H, **kw)
