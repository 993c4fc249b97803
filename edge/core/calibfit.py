"""Fit both cameras' models and rotations from surveyed landmarks (eq. 3.3/3.4) and tie points (eq. 3.7).

Input rows: a landmark has world coordinates (metres, world frame) and its
pixel in the left and/or right image; a tie point has no world coordinates
but its pixel in both images (a distant feature both cameras see).

**What is minimised, and why.** Eq. 3.3/3.4 minimise sum_i |k_i R f(u_i) +
T0 - P_i|^2 over the model and the depths k_i. With the camera centre T0
fixed at (-+L_B/2, 0, 0) each k_i can be eliminated, but what is left is a
distance in metres from P_i to the pixel's ray: far landmarks would weigh
(Z/f)^2 times more than near ones although every pixel is measured equally
well. We minimise the reprojection error in pixels instead: project P_i
through the camera (`normalised_to_pixel`: rotation, then the model's
normalised -> pixel map, closed form for pinhole, converged Newton for poly10)
and compare with the observed pixel. With independent Gaussian pixel noise
that is the maximum-likelihood fit, and its residuals are in the unit the
noise is specified in.

**Tie points, eq. 3.7.** k_l R_l p_l - k_r R_r p_r = [L_B, 0, 0] has two
unknown depths and three equations; eliminating the depths leaves one
condition, coplanarity of both rays with the baseline, which in
rotation-compensated coordinates is y_l = y_r. Its residual (y_l - y_r) * f
is the vertical disparity in pixels (the matcher searches along rows, so this
is exactly what a calibration must get right). With tie points present, a
second stage fits both cameras jointly: landmark reprojection residuals plus
tie residuals divided by sqrt(2) (the difference of two pixels has sqrt(2)
times the noise). Without tie points the per-camera fits are already the
maximum-likelihood estimate (independent noise, disjoint parameters): a joint
stage would return them unchanged, so it is skipped.

**Parameters and gauge.** The principal point (cx, cy) is fixed (default: the
image centre): a shift of it and a pan/tilt of the camera move the image in
the same way up to a term ~ x^2 (< 16 % across a 43 deg field), so fitting
both trades one for the other with large errors. pinhole: fx, fy, k1, k2,
p1, p2 (k3 optional) + rx, ry, rz (9 or 10). poly10: a6 is fixed at 0, the
rest + rx, ry, rz (12): the linear part of eq. 3.5 is a general 2x2 matrix [[a0, a1], [a6, a5]]
and a roll about the optical axis multiplies it by a 2-D rotation, so roll
and (a1, a6) are one freedom up to the weak cubic terms. a6 = 0 is the
upper-triangular gauge of OpenCV's K (a1 plays the skew); roll then carries
the camera's physical roll. There is no scale freedom: the third component
of [f_x, f_y, 1] is 1, so a0, a5 are 1 / focal length.

**Refusals** (`CalibrationError`): fewer landmarks than a camera's parameters;
a landmark behind the rig; landmarks collinear or clustered as seen from a
camera (near one plane through its centre, or in a small patch: tested on the
singular values of the centred pixel cloud, since directions are what the
model is fitted to — depth does not enter once the centre is fixed, so
landmarks all at one range are fine if they cover the image); and, as a last
guard, parameters the Jacobian cannot resolve (column-scaled condition number).

**Error bars.** Standard errors are sqrt(diag((J^T J)^-1)) * sigma with
sigma^2 = SSR / (N - P), the unbiased pixel-noise estimate (the raw RMS is
smaller by sqrt((N - P) / N)). They are honest (tests check z-scores over many
seeds) and show what the data allow: a roll is seen only through the image
radius, sigma_roll ~ noise / (r_rms sqrt(n)), about 0.02 deg for 12 landmarks
at 0.3 px; pan and tilt about noise / (f sqrt(n)), 0.005 deg.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import cast

import numpy as np
from scipy.optimize import least_squares

from edge.core.calibmodel import (
    BAD_RESIDUAL_PX,
    CameraParams,
    angles_from_matrix,
    directions,
    initial_guess,
    reprojection,
)
from edge.core.calibsigma import CameraSigma, RigSigma
from edge.core.camera import CameraModel, StereoRig, rotation_matrix

MIN_SPREAD_RATIO = 0.05  # weaker / stronger RMS spread of the landmark directions
MIN_SPREAD_OF_WIDTH = 0.03  # RMS spread along the stronger axis / image width
MAX_CONDITION = 1e10  # of the column-scaled Jacobian at the solution


class CalibrationError(ValueError):
    """The landmarks cannot determine the calibration: which camera, what was needed, what was found."""

    def __init__(self, subject: str, expected: str, found: object = None) -> None:
        self.subject, self.expected, self.found = subject, expected, found
        tail = "" if found is None else f", found {found}"
        super().__init__(f"{subject}: expected {expected}{tail}")


@dataclass(frozen=True)
class Estimate:
    name: str
    value: float
    std_error: float


@dataclass(frozen=True)
class CameraFit:
    side: str  # "left" | "right"
    camera: CameraModel
    estimates: tuple[Estimate, ...]
    residuals_px: np.ndarray  # (n_rows, 2) reprojection residual (model - observed); NaN where not a landmark
    rms_px: float  # per coordinate
    sigma_px: float  # sqrt(SSR / (N - P)): the pixel noise estimate
    n_observations: int


@dataclass(frozen=True)
class RigFit:
    rig: StereoRig
    left: CameraFit
    right: CameraFit
    names: tuple[str, ...]
    vertical_px: np.ndarray  # (n_rows,) (y_l - y_r) * f in px for rows seen by both cameras, else NaN
    is_tie: np.ndarray  # (n_rows,) bool: row has no world coordinates (tie point)
    rms_px: float  # per coordinate over every landmark observation of both cameras
    sigma_px: float  # sqrt(SSR / (N - P)) over both cameras (and tie points)
    n_observations: int
    n_parameters: int

    def worst(self, count: int = 5) -> list[tuple[str, float]]:
        """Rows with the largest residual norm in px (landmark reprojection or tie vertical disparity)."""
        norms = np.fmax(
            np.fmax(np.hypot(*self.left.residuals_px.T), np.hypot(*self.right.residuals_px.T)),
            np.where(self.is_tie, np.abs(self.vertical_px), np.nan),
        )
        order = [i for i in np.argsort(-np.nan_to_num(norms, nan=-1.0)) if np.isfinite(norms[i])]
        return [(self.names[i], float(norms[i])) for i in order[:count]]


def _vertical(cam_l: CameraModel, cam_r: CameraModel, uv_l: np.ndarray, uv_r: np.ndarray) -> np.ndarray:
    """Eq. 3.7 with the depths eliminated: (y_l - y_r) in rotation-compensated coordinates, times f (px)."""
    dy = cam_l.pixel_to_normalised(uv_l)[:, 1] - cam_r.pixel_to_normalised(uv_r)[:, 1]
    return dy * 0.5 * (cam_l.focal_px() + cam_r.focal_px())


def _check_layout(
    side: str, world_m: np.ndarray, uv: np.ndarray, n_params: int, width: int, names: list[str]
) -> None:
    """Refuse too few landmarks, landmarks behind the rig, and clustered or collinear image layouts."""
    if len(world_m) < n_params:
        raise CalibrationError(
            f"{side} camera",
            f"at least {n_params} landmarks with world coordinates "
            f"and {side} pixels (one per fitted parameter)",
            len(world_m),
        )
    behind = np.flatnonzero(world_m[:, 2] <= 0.0)
    if behind.size:
        raise CalibrationError(
            f"landmark {names[behind[0]]!r}",
            "a point in front of the rig (Z > 0)",
            f"Z = {world_m[behind[0], 2]:.1f} m",
        )
    spread = np.linalg.svd(uv - uv.mean(axis=0), compute_uv=False) / math.sqrt(len(uv))  # RMS px per axis
    if spread[0] < MIN_SPREAD_OF_WIDTH * width:
        raise CalibrationError(
            f"{side} camera",
            "landmarks spread over the image (they sit in one patch)",
            f"RMS spread {spread[0]:.1f} px",
        )
    if spread[1] < MIN_SPREAD_RATIO * spread[0]:
        raise CalibrationError(
            f"{side} camera",
            "landmarks not all on one line in the image (a degenerate layout: seen from "
            "the camera they lie near one plane through its centre); add landmarks above and below that line",
            f"spread ratio {spread[1] / spread[0]:.3f} < {MIN_SPREAD_RATIO}",
        )


def _solve(fun, x0: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    result = least_squares(
        fun, x0, method="trf", x_scale="jac", ftol=1e-14, xtol=1e-14, gtol=1e-14, max_nfev=400 * len(x0)
    )
    return result.x, result.fun, result.jac


def _std_errors(jac: np.ndarray, resid: np.ndarray, names: tuple[str, ...], subject: str) -> np.ndarray:
    """sqrt(diag((J^T J)^-1) * SSR / (N - P)); refuse parameters the data leave undetermined."""
    n, p = jac.shape
    norms = np.linalg.norm(jac, axis=0)
    scaled = jac / np.where(norms > 0.0, norms, 1.0)
    _, s, vt = np.linalg.svd(scaled, full_matrices=False)
    if s[-1] <= 0.0 or s[0] / s[-1] > MAX_CONDITION or np.any(norms == 0.0):
        weak = np.argsort(-np.abs(vt[-1]))[:2]
        raise CalibrationError(
            subject,
            "landmarks that determine every parameter (spread them over the whole image)",
            f"{', '.join(names[i] for i in weak)} not determined",
        )
    cov_scaled = (vt.T / s**2) @ vt
    sigma2 = float(resid @ resid) / max(n - p, 1)
    return np.sqrt(np.diag(cov_scaled) * sigma2) / np.where(norms > 0.0, norms, 1.0)


def _camera_fit(
    side: str,
    model: CameraParams,
    x: np.ndarray,
    std: np.ndarray,
    resid_rows: np.ndarray,
    n_rows: int,
    rows: np.ndarray,
    n_params: int,
) -> CameraFit:
    residuals = np.full((n_rows, 2), np.nan)
    residuals[rows] = resid_rows.reshape(-1, 2)
    values = x * model.factor
    estimates = tuple(
        Estimate(name, float(v), float(e * abs(f)))
        for name, v, e, f in zip(model.names, values, std, model.factor, strict=True)
    )
    ssr, n_obs = float(resid_rows @ resid_rows), resid_rows.size
    return CameraFit(
        side,
        model.camera(x),
        estimates,
        residuals,
        math.sqrt(ssr / n_obs),
        math.sqrt(ssr / max(n_obs - n_params, 1)),
        n_obs,
    )


def fit_rig(
    world_m: np.ndarray,
    uv_left: np.ndarray,
    uv_right: np.ndarray,
    *,
    model: str,
    baseline_m: float,
    width: int,
    height: int,
    principal_point: tuple[float, float] | None = None,
    fit_k3: bool = False,
    names: list[str] | None = None,
) -> RigFit:
    """Fit a StereoRig. world_m (n, 3), NaN rows for tie points; uv_* (n, 2), NaN where not seen.

    model: "pinhole" or "poly10"; principal_point defaults to the image centre ((W-1)/2, (H-1)/2);
    fit_k3 adds the pinhole's sixth-order radial term (off: k1, k2 already cover a ~43 deg lens, and
    k1/k2/k3 are so correlated over such a field that k3 mostly adds variance, as OpenCV's
    CALIB_FIX_K3 advice says).
    """
    world_m, uv_left, uv_right = (np.asarray(a, dtype=np.float64) for a in (world_m, uv_left, uv_right))
    n = len(world_m)
    names = list(names) if names is not None else [f"#{i + 1}" for i in range(n)]
    if not (math.isfinite(baseline_m) and baseline_m > 0.0):
        raise CalibrationError("baseline", "a positive length in metres", baseline_m)
    cx, cy = principal_point if principal_point is not None else ((width - 1) / 2.0, (height - 1) / 2.0)
    has_world = cast(np.ndarray, np.isfinite(world_m).all(axis=1))  # numpy stubs: bool | ndarray
    seen = {"left": np.isfinite(uv_left).all(axis=1), "right": np.isfinite(uv_right).all(axis=1)}
    pixels = {"left": uv_left, "right": uv_right}
    centre = {"left": -0.5 * baseline_m, "right": 0.5 * baseline_m}
    models, xs, resids, jacs, rows = {}, {}, {}, {}, {}
    for side in ("left", "right"):
        rows[side] = np.flatnonzero(has_world & seen[side])
        models[side] = m = CameraParams(model, cx, cy, 0.5 * width, fit_k3)
        pts, uv = world_m[rows[side]], pixels[side][rows[side]]
        _check_layout(side, pts, uv, len(m.names), width, [names[i] for i in rows[side]])
        xy = directions(pts, centre[side])
        xs[side], resids[side], jacs[side] = _solve(
            lambda x, m=m, xy=xy, uv=uv: reprojection(m, x, xy, uv), initial_guess(m, xy, uv)
        )
    tie = np.flatnonzero(~has_world & seen["left"] & seen["right"])
    p_l, p_r = len(models["left"].names), len(models["right"].names)
    if tie.size:  # stage 2: eq. 3.7 tie points join the landmarks in one fit of both cameras
        xy_l = directions(world_m[rows["left"]], centre["left"])
        xy_r = directions(world_m[rows["right"]], centre["right"])

        def joint(x: np.ndarray) -> np.ndarray:
            parts = [
                reprojection(models["left"], x[:p_l], xy_l, uv_left[rows["left"]]),
                reprojection(models["right"], x[p_l:], xy_r, uv_right[rows["right"]]),
            ]
            try:
                v = _vertical(
                    models["left"].camera(x[:p_l]),
                    models["right"].camera(x[p_l:]),
                    uv_left[tie],
                    uv_right[tie],
                )
            except ValueError:
                v = np.full(tie.size, BAD_RESIDUAL_PX)
            return np.concatenate([*parts, np.nan_to_num(v, nan=BAD_RESIDUAL_PX) / math.sqrt(2.0)])

        x, resid, jac = _solve(joint, np.concatenate([xs["left"], xs["right"]]))
        std = _std_errors(jac, resid, models["left"].names + models["right"].names, "stereo rig")
        xs = {"left": x[:p_l], "right": x[p_l:]}
        n_l = 2 * rows["left"].size
        resids = {"left": resid[:n_l], "right": resid[n_l : n_l + 2 * rows["right"].size]}
        stds = {"left": std[:p_l], "right": std[p_l:]}
        all_resid = resid
    else:
        stds = {
            side: _std_errors(jacs[side], resids[side], models[side].names, f"{side} camera")
            for side in ("left", "right")
        }
        all_resid = np.concatenate([resids["left"], resids["right"]])
    fits = {
        side: _camera_fit(
            side, models[side], xs[side], stds[side], resids[side], n, rows[side], len(models[side].names)
        )
        for side in ("left", "right")
    }
    rig = StereoRig(baseline_m, width, height, fits["left"].camera, fits["right"].camera)
    both = seen["left"] & seen["right"]
    vertical = np.full(n, np.nan)
    if both.any():
        vertical[both] = _vertical(rig.left, rig.right, uv_left[both], uv_right[both])
    landmark_resid = np.concatenate([resids["left"], resids["right"]])
    n_obs, n_par = all_resid.size, p_l + p_r
    return RigFit(
        rig,
        fits["left"],
        fits["right"],
        tuple(names),
        vertical,
        ~has_world,
        math.sqrt(float(landmark_resid @ landmark_resid) / landmark_resid.size),
        math.sqrt(float(all_resid @ all_resid) / max(n_obs - n_par, 1)),
        n_obs,
        n_par,
    )


def camera_sigma(fit: CameraFit) -> CameraSigma:
    """The standard errors the calibration file carries for one camera: its three angles (deg) and
    its focal length (px: pinhole fx; poly10 f = 1 / a0, so sigma_f = sigma_a0 / a0^2)."""
    est = {e.name: e for e in fit.estimates}
    if "fx" in est:
        focal_sigma = est["fx"].std_error
    else:
        a0 = est["a0"]
        focal_sigma = a0.std_error / a0.value**2
    angles = (est["rx_deg"].std_error, est["ry_deg"].std_error, est["rz_deg"].std_error)
    return CameraSigma(angles, float(focal_sigma))


def rig_sigma(fit: RigFit) -> RigSigma:
    """Both cameras' `camera_sigma`: what `mast-stereo calibrate` writes into the calibration file."""
    return RigSigma(camera_sigma(fit.left), camera_sigma(fit.right))


def relative_rotation_deg(rig: StereoRig) -> np.ndarray:
    """(rx, ry, rz) of the right camera relative to the left: R_l^T R_r, degrees."""
    return angles_from_matrix(
        rotation_matrix(rig.left.rotation_deg).T @ rotation_matrix(rig.right.rotation_deg)
    )
