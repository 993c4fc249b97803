"""How fast a ship can move in the image: bounds on its disparity's change.

The bound. A ship at depth Z (disparity
d = f L_B / Z) moving at speed <= v with acceleration <= a (speed change or turn) has
|Z'| <= v and |Z''| <= a, so differentiating d = f L_B / Z twice,

    d'' = f L_B (2 Z'^2 / Z^3 - Z'' / Z^2)
    |d''| <= a d^2 / (f L_B) + 2 v^2 d^3 / (f L_B)^2                        (px/s^2)

At 5 km with the 2048 px rig (f L_B = 21 165 px m) that is ~6e-4 px/s^2, eighty times less than
the filter's configured white acceleration (which is what a ship can do at a few hundred metres),
so a constant-velocity Kalman designed for the far ship may average over much longer. The design
is taken from a ladder of factors of 2 below the configured value, so that few tables are built
and shared, and the ladder stops at 1/16: the matcher's error on a ship is not white (it follows
the window's texture as the ship's pose changes, over seconds), so deeper designs average it into
a persistent offset instead (docs/decisions.md).

(Speed and course come from the ground-plane filter, edge.measure.groundtrack, not from these rates.)
"""

from __future__ import annotations

MAX_SHIP_SPEED_MPS = 25.0  # ~50 kn: no ship's range changes faster
MAX_SHIP_ACCEL_MPS2 = 0.5  # speed change or turn (12 kn on a 120 m radius is 0.32 m/s^2)
ACCEL_RUNGS = 4  # the ladder goes down to the configured acceleration / 2^4 (see the module doc)


def disparity_accel_bound(disparity_px: float, fb_px_m: float, *, speed_mps: float = MAX_SHIP_SPEED_MPS,
                          accel_mps2: float = MAX_SHIP_ACCEL_MPS2) -> float:
    """|d''| (px/s^2) a ship at this disparity can show (module doc); inf without a rig scale."""
    if fb_px_m <= 0:
        return float("inf")
    d = max(disparity_px, 0.0)
    return accel_mps2 * d * d / fb_px_m + 2.0 * speed_mps**2 * d**3 / fb_px_m**2


def accel_rung(disparity_px: float, fb_px_m: float, top_pxps2: float) -> float:
    """The white acceleration for the filter's design: the smallest top / 2^k (k <= ACCEL_RUNGS)
    that is at least the physical bound; `top` (the configured value) when the bound exceeds it."""
    bound = disparity_accel_bound(disparity_px, fb_px_m)
    rung = top_pxps2
    for _ in range(ACCEL_RUNGS):
        if rung / 2.0 < bound:
            break
        rung /= 2.0
    return rung
