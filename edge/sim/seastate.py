"""Sea state in numbers: the Douglas/WMO scale, the wind that raises it, whitecap cover and facet slopes.

A scenario names a sea state on the Douglas scale (WMO code 3700, 0 calm to 6
very rough). Each state is a band of significant wave height H_s; the wind
that raises a fully developed sea of the band's middle height follows from
the Pierson-Moskowitz relation H_s = 0.21 U^2 / g (U at 19.5 m, close enough
to the 10 m wind here). From the wind:

- whitecap cover, Monahan and O'Muircheartaigh (1980): W = 3.84e-6 U^3.41
  (fraction of the sea surface white; ~0.2 % at state 3, ~0.8 % at 4, ~4 % at 6);
- the mean square slope of the wave facets, Cox and Munk (1954), isotropic
  form: sigma^2 = 0.003 + 5.12e-3 U, which sets how wide the sun's glitter
  pattern spreads (`glitter`).

These are textbook figures; the simulator uses them to scale its effects, not
to model the sea's hydrodynamics.
"""

from __future__ import annotations

import math

import numpy as np

GRAVITY_MPS2 = 9.81
# Douglas / WMO 3700: significant wave height band (m) of each state 0..6
DOUGLAS_HS_M: tuple[tuple[float, float], ...] = (
    (0.0, 0.0),  # 0 calm (glassy)
    (0.0, 0.1),  # 1 calm (rippled)
    (0.1, 0.5),  # 2 smooth
    (0.5, 1.25),  # 3 slight
    (1.25, 2.5),  # 4 moderate
    (2.5, 4.0),  # 5 rough
    (4.0, 6.0),  # 6 very rough
)
MAX_STATE = len(DOUGLAS_HS_M) - 1


def wave_height_m(state: int) -> float:
    """The middle significant wave height of a Douglas sea state."""
    lo, hi = DOUGLAS_HS_M[_check(state)]
    return 0.5 * (lo + hi)


def wind_mps(state: int) -> float:
    """Wind that raises a fully developed sea of the state's middle height (Pierson-Moskowitz)."""
    return math.sqrt(wave_height_m(state) * GRAVITY_MPS2 / 0.21)


def whitecap_fraction(wind: float) -> float:
    """Monahan's whitecap cover W(U) = 3.84e-6 U^3.41 (a fraction, capped at 1)."""
    return min(3.84e-6 * max(wind, 0.0) ** 3.41, 1.0)


def slope_variance(wind: float) -> float:
    """Cox-Munk mean square facet slope (both axes together) for wind U, m/s."""
    return 0.003 + 5.12e-3 * max(wind, 0.0)


def slope_pdf_ratio(tan_tilt: np.ndarray, sigma2: float) -> np.ndarray:
    """Density of facets tilted by tan_tilt relative to level ones (isotropic Gaussian slopes)."""
    return np.exp(-(np.asarray(tan_tilt) ** 2) / sigma2)


def _check(state: int) -> int:
    if not 0 <= state <= MAX_STATE:
        raise ValueError(f"sea state must be 0 .. {MAX_STATE} (Douglas), got {state}")
    return int(state)


def specular_ratio(
    points: np.ndarray, eye: np.ndarray, sun_dir: np.ndarray, centre: np.ndarray, sigma2: float
) -> np.ndarray:
    """Relative density of sun-reflecting facets at sea points (..., 3) seen from `eye`: 1 at the glitter's
    centre, falling with the tilt a facet needs to send the sun into the eye (Cox-Munk). 0 with no sun."""
    if not np.any(sun_dir):
        return np.zeros(np.shape(points)[:-1])
    view = eye - points
    view = view / np.linalg.norm(view, axis=-1, keepdims=True)
    half = view + sun_dir
    half = half / np.linalg.norm(half, axis=-1, keepdims=True)
    up = points - centre
    up = up / np.linalg.norm(up, axis=-1, keepdims=True)
    cos_tilt = np.clip(np.einsum("...i,...i->...", half, up), 1e-6, 1.0)
    return slope_pdf_ratio(np.sqrt(1.0 / cos_tilt**2 - 1.0), sigma2)
