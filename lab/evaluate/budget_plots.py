"""Plots of the error budget (docs/method.md, "Error model"), and the tables behind them.

    .venv/bin/python tools/error-budget --out DIR [--width 2048] [--delta 0.11] [--tolerance 150]

Writes
  DIR/max-range-vs-baseline.png  exact Z_max (eq. 4.5 solved for Z) against the baseline L_B for
                                 several horizontal fields of view, at one width, delta and tolerance;
  DIR/range-error-vs-k.png       range error in % of Z against k = Z / L_B (eq. 7.1) for matching
                                 errors delta = 0.5 / 0.15 / 0.11 px (whole pixel, sub-pixel fit,
                                 Butterworth filter in the thesis) on the thesis rig
                                 (720 px, 43 deg), +delta solid (too far), -delta dashed (too near);
and prints the same numbers as tables. matplotlib is the optional `plots` extra
(pip install -e .[plots]); it is imported only here.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from edge.core.budget import max_range
from edge.core.triangulation import epsilon, relative_range_error_k

FOVS_DEG = (20.0, 30.0, 43.0, 60.0, 90.0)
DELTAS_PX = (0.5, 0.15, 0.11)
TABLE_BASELINES_M = (2.0, 4.0, 8.14, 12.0, 20.0, 30.0)
TABLE_K = (50, 100, 200, 300, 400, 500, 600, 700)
THESIS_BASELINE_M = 8.14
TARGET_RANGE_M = 5500.0  # ~3 nautical miles, where near-shore collisions happen (docs/method.md)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, required=True, help="directory for the PNG files")
    parser.add_argument("--width", type=int, default=2048, help="image width in px for the Z_max plot")
    parser.add_argument("--delta", type=float, default=0.11, help="matching error in px for the Z_max plot")
    parser.add_argument("--tolerance", type=float, default=150.0, help="tolerated range error in m")
    parser.add_argument("--k-width", type=int, default=720, help="image width (px) for the %%-error plot")
    parser.add_argument("--k-fov", type=float, default=43.0, help="field of view (deg) for the %%-error plot")
    args = parser.parse_args(argv)
    if min(args.width, args.delta, args.tolerance, args.k_width, args.k_fov) <= 0:
        parser.error("all numbers must be positive")
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("error-budget: matplotlib is missing: pip install -e .[plots]", file=sys.stderr)
        return 1
    args.out.mkdir(parents=True, exist_ok=True)
    print(max_range_plot(plt, args.out / "max-range-vs-baseline.png", args.width, args.delta, args.tolerance))
    print()
    print(error_vs_k_plot(plt, args.out / "range-error-vs-k.png", args.k_width, args.k_fov))
    print(f"\nwrote {args.out / 'max-range-vs-baseline.png'} and {args.out / 'range-error-vs-k.png'}")
    return 0


def max_range_plot(plt, path: Path, width: int, delta: float, tolerance: float) -> str:  # noqa: ANN001
    baselines = np.linspace(0.5, 30.0, 300)
    fig, ax = plt.subplots(figsize=(8, 5.5), dpi=120)
    rows = []
    for fov in FOVS_DEG:
        eps = float(epsilon(delta, width, fov))
        ax.plot(baselines, max_range(tolerance, eps, baselines) / 1000.0, lw=2, label=f"{fov:g}°")
        cells = (f"{max_range(tolerance, eps, b):>7.0f}" for b in TABLE_BASELINES_M)
        rows.append(f"  {fov:>7g}  " + "  ".join(cells))
    ax.axhline(TARGET_RANGE_M / 1000.0, color="grey", ls=":", lw=1.5)
    ax.text(17.5, TARGET_RANGE_M / 1000.0, "3 nmi (5.5 km)", va="bottom", color="grey")
    ax.axvline(THESIS_BASELINE_M, color="grey", ls="--", lw=1)
    ax.text(THESIS_BASELINE_M, 0.2, " thesis 8.14 m", color="grey")
    ax.set(
        xlabel="baseline $L_B$ (m)",
        ylabel=f"max range for ±{tolerance:g} m error (km)",
        title=f"Measurable range, eq. 4.5 exact root  ({width} px wide, δ = {delta:g} px)",
        xlim=(0, 30),
        ylim=(0, None),
    )
    ax.grid(alpha=0.3)
    ax.legend(title="horizontal field of view", loc="upper left")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    head = "  fov_deg  " + "  ".join(f"{b:>7g}" for b in TABLE_BASELINES_M)
    return "\n".join(
        [f"Z_max (m), {tolerance:g} m range error, {width} px, delta {delta:g} px; columns L_B (m)", head]
        + rows
    )


def pct(k: float, eps: float) -> float:
    """Range error in % of Z at k = Z / L_B (eq. 7.1)."""
    return 100.0 * float(relative_range_error_k(k, eps))


def error_vs_k_plot(plt, path: Path, width: int, fov: float) -> str:  # noqa: ANN001
    k = np.linspace(10.0, 800.0, 400)
    fig, ax = plt.subplots(figsize=(8, 5.5), dpi=120)
    rows = []
    for delta, colour in zip(DELTAS_PX, ("tab:red", "tab:orange", "tab:blue"), strict=True):
        eps = float(epsilon(delta, width, fov))
        far = 100.0 * relative_range_error_k(k, eps)
        near = 100.0 * relative_range_error_k(k, -eps)
        ax.plot(k, far, color=colour, lw=2, label=f"δ = {delta:g} px")
        ax.plot(k, near, color=colour, lw=1.5, ls="--")
        cells = (f"{pct(kk, eps):>+6.1f}/{pct(kk, -eps):>+5.1f}" for kk in TABLE_K)
        rows.append(f"  {delta:>5g}  " + "  ".join(cells))
    ax.set(
        xlabel="k = Z / $L_B$",
        ylabel="range error (% of Z)",
        title=f"Range error against k, eq. 4.5 / 7.1  ({width} px, {fov:g}°; solid +δ, dashed −δ)",
        xlim=(0, 800),
        ylim=(-40, 60),
    )
    to_km = (lambda kk: kk * THESIS_BASELINE_M / 1000.0, lambda z: z * 1000.0 / THESIS_BASELINE_M)
    top = ax.secondary_xaxis("top", functions=to_km)
    top.set_xlabel(f"range Z (km) for $L_B$ = {THESIS_BASELINE_M} m")
    ax.axhline(0.0, color="black", lw=0.8)
    ax.grid(alpha=0.3)
    ax.legend(loc="upper left")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    head = "  delta  " + "  ".join(f"{f'k={kk}':>12}" for kk in TABLE_K)
    return "\n".join(
        [f"Range error % of Z (+delta / -delta), {width} px, {fov:g} deg; k = Z / L_B", head] + rows
    )


if __name__ == "__main__":
    sys.exit(main())
