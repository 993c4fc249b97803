"""`mast-stereo budget`: the error budget of a rig (docs/method.md "Error model"), as a table or JSON.

    mast-stereo budget --width 720 --fov 43 --baseline 8.14 --delta 0.5 [--json]
        [--tolerance M ...] [--range M ...] [--ship-length M] [--min-pixels N]

Defaults: tolerances 35, 50, 150 m; ranges 500..6000 m step 500; a 50 m ship
on at least 20 pixels. `--tolerance` and `--range` repeat and replace the
defaults. Arguments that are not positive (or a field of view >= 180 deg) are
refused by argparse with exit status 2.

JSON keys (`--json`; lengths in metres, infinities as null):

- `width_px`, `fov_deg`, `baseline_m`, `delta_px`, `ship_length_m`,
  `min_pixels`: the inputs;
- `epsilon`: the matching error in normalised units, eq. 4.6;
- `focal_px`: N / (2 tan(theta/2));
- `z_near_m`: L_B / tan(theta/2), nearest range seen by both cameras;
- `detectable_range_m`: eq. 3.12, farthest range at which the ship covers
  `min_pixels` pixels;
- `max_ranges`: list of {`tolerance_m`, `z_max_m` (exact root of eq. 4.5),
  `z_max_first_order_m` (sqrt(E_z L_B / eps))};
- `range_errors`: list of {`range_m`, `k` (Z / L_B), `disparity_px`,
  `error_near_m` (matching error -delta, <= 0), `error_far_m` (+delta, >= 0,
  null when the error swallows the disparity), `error_near_pct`,
  `error_far_pct` (percent of the range)}.
"""

from __future__ import annotations

import argparse
import json
import math
from collections.abc import Callable

from edge.core.budget import (
    DEFAULT_MIN_PIXELS,
    DEFAULT_RANGES_M,
    DEFAULT_SHIP_LENGTH_M,
    DEFAULT_TOLERANCES_M,
    Budget,
    error_budget,
)


def _positive(kind: type) -> Callable[[str], float | int]:
    def parse(text: str) -> float | int:
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a positive {kind.__name__}, got {text!r}") from None
        if not (math.isfinite(value) and value > 0):
            raise argparse.ArgumentTypeError(f"expected a positive {kind.__name__}, got {text!r}")
        return value

    parse.__name__ = f"positive {kind.__name__}"
    return parse


def _fov(text: str) -> float:
    value = _positive(float)(text)
    if value >= 180.0:
        raise argparse.ArgumentTypeError(f"expected a field of view below 180 deg, got {text!r}")
    return value


def _listing(values: tuple[float, ...]) -> str:
    return ", ".join(f"{v:g}" for v in values)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    pos_float, pos_int = _positive(float), _positive(int)
    parser.add_argument("--width", type=pos_int, required=True, metavar="N", help="image width in pixels")
    parser.add_argument("--fov", type=_fov, required=True, metavar="DEG", help="horizontal angle of view")
    parser.add_argument(
        "--baseline", type=pos_float, required=True, metavar="M", help="baseline L_B in metres"
    )
    parser.add_argument(
        "--delta", type=pos_float, required=True, metavar="PX", help="matching error in pixels"
    )
    parser.add_argument("--json", action="store_true", help="print JSON instead of tables")
    parser.add_argument(
        "--tolerance", type=pos_float, action="append", metavar="M",
        help=f"tolerated range error for Z_max (repeatable; default {_listing(DEFAULT_TOLERANCES_M)})",
    )  # fmt: skip
    parser.add_argument(
        "--range", type=pos_float, action="append", metavar="M", dest="ranges",
        help="range at which to report the error (repeatable; default 500..6000 step 500)",
    )  # fmt: skip
    parser.add_argument(
        "--ship-length", type=pos_float, default=DEFAULT_SHIP_LENGTH_M, metavar="M",
        help=f"ship length for the detectable distance (default {DEFAULT_SHIP_LENGTH_M:g})",
    )  # fmt: skip
    parser.add_argument(
        "--min-pixels", type=pos_float, default=DEFAULT_MIN_PIXELS, metavar="N",
        help=f"pixels the ship must cover to be detected (default {DEFAULT_MIN_PIXELS:g})",
    )  # fmt: skip


def run(args: argparse.Namespace) -> int:
    budget = error_budget(
        width_px=args.width,
        fov_deg=args.fov,
        baseline_m=args.baseline,
        delta_px=args.delta,
        tolerances_m=args.tolerance or DEFAULT_TOLERANCES_M,
        ranges_m=args.ranges or DEFAULT_RANGES_M,
        ship_length_m=args.ship_length,
        min_pixels=args.min_pixels,
    )
    print(json.dumps(budget.to_dict(), indent=2) if args.json else format_table(budget))
    return 0


def format_table(b: Budget) -> str:
    """The budget as human-readable tables."""

    def num(value: float, fmt: str) -> str:
        return format(value, fmt) if math.isfinite(value) else "unmeasurable"

    lines = [
        f"Error budget: N = {b.width_px} px, theta = {b.fov_deg:g} deg, L_B = {b.baseline_m:g} m, "
        f"delta = {b.delta_px:g} px",
        f"  epsilon (eq. 4.6)              {b.epsilon:.4e}  (normalised units)",
        f"  focal length                   {b.focal_px:.1f} px",
        f"  Z_near = L_B / tan(theta/2)    {b.z_near_m:.1f} m",
        f"  detectable range (eq. 3.12)    {b.detectable_range_m:.0f} m  "
        f"({b.ship_length_m:g} m ship on >= {b.min_pixels:g} px)",
        "",
        "Maximum range for a tolerated range error (eq. 4.5)",
        f"  {'tolerance_m':>11}  {'z_max_m':>9}  {'first_order_m':>13}",
    ]
    lines += [
        f"  {m.tolerance_m:>11g}  {m.z_max_m:>9.0f}  {m.z_max_first_order_m:>13.0f}" for m in b.max_ranges
    ]
    lines += [
        "",
        "Range error for a matching error of -/+delta (eq. 4.5)",
        f"  {'range_m':>8}  {'k':>7}  {'disp_px':>8}  {'near_m':>9}  {'far_m':>12}  "
        f"{'near_%':>7}  {'far_%':>12}",
    ]
    lines += [
        f"  {r.range_m:>8g}  {r.k:>7.1f}  {r.disparity_px:>8.2f}  {r.error_near_m:>9.1f}  "
        f"{num(r.error_far_m, '.1f'):>12}  {r.error_near_pct:>7.2f}  {num(r.error_far_pct, '.2f'):>12}"
        for r in b.range_errors
    ]
    return "\n".join(lines)
