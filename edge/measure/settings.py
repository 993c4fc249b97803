"""The matching and filtering knobs every track shares, and their allowed choices.

The pipeline builds one `PointSettings` from its configuration; the track's point, its filter,
the batched core requests and the filter designs all read it. It lives apart from all of them
so that none has to import another to know its settings.
"""

from __future__ import annotations

from dataclasses import dataclass

SUBPIXELS = ("cancel6-gauss", "cancel", "parabola", "none")  # the lab adds research ones (lab.subpix)
FILTERS = ("kalman", "butterworth", "none")


@dataclass(frozen=True)
class PointSettings:
    """Matching and filtering knobs of every track (built by the pipeline from its configuration)."""

    fps: float = 10.0
    window: int = 15
    max_disparity: int = 128
    cost: str = "zssd"
    prefilter: str = "none"  # "xsobel": the right match compares clipped x-Sobel patches
    subpixel: str = "cancel6-gauss"
    filter: str = "kalman"
    butterworth_cutoff_hz: float = 0.5
    gate_sigma: float = 3.0
    reacquire_s: float = 3.0
    noise_dn: float = 2.0  # camera noise for the matcher's predicted sigma
    max_sigma_px: float = 0.5  # matches predicted worse than this are rejected (too little texture)
    sigma_meas_px: float = 0.08  # the Kalman's measurement noise until the track has measured its own
    sigma_accel_pxps2: float = 0.05  # the Kalman's white acceleration (max d'' of a ship)
    search_radius_px: int = 4  # disparity search around the prediction
    follow_radius_px: int = 4  # left-follow search around the predicted position
    follow_subpixel: str = "parabola"  # the core point tracker's sub-pixel method
    follow_every: int = 1  # run the point tracker every n-th pair (the motion fit carries it between)
    baseline_m: float = 0.0  # with focal_px: bounds the image motion and disparity rates (0: no bound)
    focal_px: float = 0.0
    alias_check: bool = True  # cross-check each match with a smaller window (edge.measure.aliascheck)
    depth_check: bool = True  # cross-check each match with four sub-windows (edge.measure.depthcheck)
