"""Benchmark of the matching and filtering core (research note §6), printed as tables.

    .venv/bin/python tools/bench-core [--quick] [--out DIR]
        [--sections subpixel,fixed,tracks,speed,real[,study]]

Sections
  subpixel  exact-shift renders (edge.sim.synth: fine scene at 32 samples/px, crops at integer
            sample offsets, area integration, Gaussian PSF, independent noise in L and R):
            per method x condition the RMS (gross excluded), max |bias(f)|, gross rate
            (|e| > 1 px), invalid rate and RMS / Cramer-Rao bound; integer vs float reference;
            DIR/pixel-locking.png (bias against the fractional disparity)
  fixed     Q14 Butterworth and Q24 Kalman against their float references, stuck-error check
  tracks    track test: ship and fast boat, approach / hold / recede, 10 and 30 fps, 2 %
            outliers and a 2 s glint burst; Butterworth vs Kalman (sigma_a tuned on tuning
            seeds, evaluated on others): lag, disparity RMS, range RMS / p99 per range bin, RMS and
            max of error / predicted sigma (plain 1-sigma and the per-track 3-sigma bound design)
  speed     microseconds per track per frame, 15x15 window, 128 px search, one core, with the
            ratio to the plain-numpy integer and float64 paths measured in the same run
  study     (opt-in) float sketches of other sub-pixel estimators (Gauss-Newton with interpolation,
            cosine / Gaussian curve models) on the tuning seeds; see lab/bench/subpix_study.py
  aliasing  sharp optics on periodic detail (issue 16): bias and 3-sigma share per set, and how the
            candidate detectors (Nyquist energy, window disagreement) separate aliased from clean
            windows; lab/bench/aliasing.py
  real      Middlebury 2014 motorcycle pair with ground truth (bundled with scikit-image, a
            bench/test-only dependency) against OpenCV StereoBM at the same textured points
Seeds: evaluation 1000+, tuning 5000+ (never mixed). Default run: a few minutes; --quick < 1 min.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")     # one core: set before numpy loads BLAS
os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse
import sys
import time
from pathlib import Path

import numpy as np

import lab.subpix  # noqa: F401  (registers the research sub-pixel methods, "refit")
from edge.core.butterworth import ButterworthFloat, ButterworthQ
from edge.core.kalman import DisparityKalman, DisparityKalmanFloat, design_kalman
from edge.core.match import match_point
from edge.core.prefilter import xsobel, xsobel_normalised
from edge.sim.synth import Condition, sweep_many
from lab.bench.common import table

EVAL_SEED0 = 1000
CONDITIONS = [
    Condition("textured, 1 DN"), Condition("textured, 4 DN", noise_dn=4.0),
    Condition("sharp (aliased), 1 DN", kind="sharp", psf_sigma_px=0.25),
    Condition("fog t=0.15, 1 DN", fog_t=0.15), Condition("fog t=0.06, 2 DN", fog_t=0.06, noise_dn=2.0),
    Condition("gain 0.9", gain=0.9), Condition("gain 1.1", gain=1.1),
    Condition("offset +10 DN", offset_dn=10.0), Condition("offset -10 DN", offset_dn=-10.0),
    Condition("vertical offset 0.25 px", vertical_8ths=2),
]
METHODS = {   # name -> (cost, subpixel, prefilter: "", "xsobel" or "normalised")
    "whole-pixel": ("zssd", "none", ""),
    "SSD+parabola (thesis)": ("ssd", "parabola", ""),
    "ZSSD+parabola": ("zssd", "parabola", ""),
    "ZSSD+cancel one-way": ("zssd", "cancel-oneway", ""),
    "ZSSD+cancel (previous default)": ("zssd", "cancel", ""),
    "ZSSD+cancel6": ("zssd", "cancel6", ""),
    "ZSSD+cancel6-gauss (default)": ("zssd", "cancel6-gauss", ""),
    "ZSSD+cancel+refit": ("zssd", "refit", ""),
    "xsobel15+ZSSD+cancel6-gauss": ("zssd", "cancel6-gauss", "xsobel"),
    "normalised x-Sobel+ZSSD+cancel6-gauss": ("zssd", "cancel6-gauss", "normalised"),
}
DEFAULT = "ZSSD+cancel6-gauss (default)"


def _matcher(cost: str, sub: str, pre: str, noise_dn: float, impl: str = "int"):
    def run(left: np.ndarray, right: np.ndarray, x: int, y: int):
        if pre:
            fn = xsobel if pre == "xsobel" else xsobel_normalised
            left, right = fn(left), fn(right)
        return match_point(left, right, x, y, max_disparity=12, cost=cost, subpixel=sub, noise_dn=noise_dn,
                           impl=impl)
    return run


def section_subpixel(args: argparse.Namespace, out: list[str]) -> dict[str, np.ndarray]:
    seeds = range(EVAL_SEED0, EVAL_SEED0 + args.seeds)
    worst_lsb: dict[str, float]
    rows, bias_curves, worst_lsb = [], {}, {}
    for cond in CONDITIONS:
        matchers = {name: _matcher(*spec, cond.noise_dn) for name, spec in METHODS.items()}
        for name, (cost, sub, pre) in METHODS.items():
            if sub not in ("none", "parabola") and not pre:
                matchers[f"float {name}"] = _matcher(cost, sub, pre, cond.noise_dn, impl="float")
        res = sweep_many(cond, seeds, matchers, n_fractions=args.fractions)
        crb = float(np.sqrt(np.mean(res[DEFAULT].crb_px ** 2)))
        for name in (n for n in METHODS if f"float {n}" in matchers):
            both = np.isfinite(res[name].errors) & np.isfinite(res[f"float {name}"].errors)
            diff = np.abs(res[name].errors - res[f"float {name}"].errors)[both]
            worst_lsb[name] = max(worst_lsb.get(name, 0.0), float(diff.max(initial=0.0)) * 256)
        for name in METHODS:
            e = res[name].errors
            valid = np.isfinite(e)
            gross = valid & (np.abs(np.nan_to_num(e)) > 1.0)
            good = np.where(valid & ~gross, e, np.nan)
            rms = float(np.sqrt(np.nanmean(good**2))) if np.isfinite(good).any() else np.nan
            with np.errstate(all="ignore"):
                bias = np.nanmean(good, axis=0)
            if cond.name == "textured, 1 DN" or cond.name.startswith("sharp"):
                bias_curves[f"{name} | {cond.name}"] = bias
            rows.append([cond.name, name, f"{rms:.4f}", f"{np.nanmax(np.abs(bias)):.4f}",
                         f"{gross.sum() / max(valid.sum(), 1):.3f}", f"{1 - valid.mean():.3f}",
                         f"{crb:.4f}", f"{rms / crb:.2f}"])
    out.append(f"Sub-pixel accuracy on exact-shift renders: {len(seeds)} texture seeds x {args.fractions} "
               f"fractions per condition, 15x15 window, d = 4 + k/{args.fractions} px; px units")
    out.append(table(["condition", "method", "RMS", "max|bias|", "gross", "invalid", "CRB", "RMS/CRB"], rows))
    out.append("CRB = noise * sqrt(2 / sum Ix^2) with the exact derivative of the clean rendered window and "
               "noise including uint8 rounding (sqrt(s^2 + 1/12)).")
    out.append("Integer (Q8) vs float64 reference, every valid sample of every condition: max difference "
               + ", ".join(f"{name} {lsb:.2f} LSB" for name, lsb in worst_lsb.items())
               + " (1 LSB = 1/256 px)\n")
    _plot_locking(bias_curves, args.fractions, args.out)
    return bias_curves


def _plot_locking(curves: dict[str, np.ndarray], n: int, out_dir: Path) -> None:
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("(matplotlib not installed: pixel-locking.png skipped; pip install -e .[plots])")
        return
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.5), sharey=True)
    f = np.arange(n) / n
    for ax, cond in zip(axes, ("textured, 1 DN", "sharp (aliased), 1 DN"), strict=True):
        for name in METHODS:
            if name != "whole-pixel":
                ax.plot(f, curves[f"{name} | {cond}"], marker=".", label=name)
        ax.axhline(0, color="k", lw=0.5)
        ax.set_title(f"bias b(f), {cond}")
        ax.set_xlabel("fractional disparity f (px)")
    axes[0].set_ylabel("mean error (px)")
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    out_dir.mkdir(parents=True, exist_ok=True)
    fig.savefig(out_dir / "pixel-locking.png", dpi=110)
    print(f"wrote {out_dir / 'pixel-locking.png'}")


def section_fixed(args: argparse.Namespace, out: list[str]) -> None:
    rng = np.random.default_rng(EVAL_SEED0)
    rows = []
    n = 3000 if args.quick else 20000
    x = 25 + np.cumsum(rng.normal(0, 0.01, n)) + rng.normal(0, 0.1, n)
    x_q8 = np.round(x * 256).astype(int)
    for fc, fs in ((0.5, 10.0), (0.2, 10.0), (0.5, 30.0), (0.2, 30.0), (0.1, 30.0)):
        fi, ff = ButterworthQ(fc, fs), ButterworthFloat(fc, fs)
        diff = max(abs(fi.update(int(v)) - 256 * ff.update(v / 256)) for v in x_q8)
        const = ButterworthQ(fc, fs)
        outs = [const.update(v) for v in [0] * 10 + [3333] * 10_000]
        rows.append([f"Butterworth {fc} Hz / {fs:g} fps", f"{diff:.2f}", str(outs[-1] - 3333)])
    for fs, sa in ((10.0, 0.05), (30.0, 0.2)):
        des = design_kalman(fs, 0.1, sa)
        ki, kf = DisparityKalman(des), DisparityKalmanFloat(des)
        zs = x + np.where(rng.random(n) < 0.02, 5.0, 0.0)
        diff = 0.0
        for z in zs:
            a, b = ki.update(float(z)), kf.update(float(z))
            if a.valid and b.valid:
                assert a.disparity_q8 is not None  # valid integer estimates carry it
                diff = max(diff, abs(a.disparity_q8 - 256 * b.disparity_px))
        kc = DisparityKalman(des)
        for z in [13.0] * 10_005:
            e = kc.update(z)
        assert e.disparity_q8 is not None  # running after 10 000 samples on a line
        rows.append([f"Kalman sigma_a {sa} / {fs:g} fps", f"{diff:.2f}", str(e.disparity_q8 - 13 * 256)])
    out.append(f"Fixed point vs float reference ({n} noisy samples; then 10 000 constant samples)")
    out.append(table(["filter", "max |int - float| (LSB)", "stuck error after 10 000 (LSB)"], rows) + "\n")


def section_speed(args: argparse.Namespace, out: list[str]) -> None:
    from edge.core.refpoint import follow_point
    from edge.sim.synth import make_scene, render_pair
    scene = make_scene(np.random.default_rng(7), 40, 290, "hull")
    pair = render_pair(scene, np.random.default_rng(8), 32 * 70 + 5, height_px=31, width_px=200)
    left, right = pair.left, pair.right
    reps = 200 if args.quick else 1000

    def timed(fn) -> float:
        fn()
        return min(_loop(fn, reps) for _ in range(3)) / reps * 1e6

    cases = {
        "match_point ZSSD+cancel6-gauss, int (default)": lambda: match_point(left, right, 180, 15),
        "match_point ZSSD+cancel+refit, int": lambda: match_point(left, right, 180, 15, subpixel="refit"),
        "match_point ZSSD+cancel, int (previous default)": lambda: match_point(left, right, 180, 15,
                                                                               subpixel="cancel"),
        "match_point ZSSD+cancel6, int": lambda: match_point(left, right, 180, 15, subpixel="cancel6"),
        "match_point ZSSD+parabola, int": lambda: match_point(left, right, 180, 15, subpixel="parabola"),
        "match_point SSD+parabola, int": lambda: match_point(left, right, 180, 15, subpixel="parabola",
                                                             cost="ssd"),
        "match_point ZSSD+cancel, plain-numpy int64": lambda: match_point(left, right, 180, 15,
                                                                          impl="int-ref"),
        "match_point ZSSD+cancel, float64 reference": lambda: match_point(left, right, 180, 15, impl="float"),
    }
    times = {name: timed(fn) for name, fn in cases.items()}
    base = times["match_point ZSSD+cancel, float64 reference"]
    kal = DisparityKalman(design_kalman(10, 0.1, 0.05))
    bw = ButterworthQ(0.5, 10)
    times["Kalman update (Q24)"] = timed(lambda: kal.update(70.2))
    times["Butterworth update (Q14)"] = timed(lambda: bw.update(17971))
    times["follow_point (reference point, 2-D)"] = timed(lambda: follow_point(left, left, 100.3, 15.2))
    rows = [[name, f"{t:.1f}", f"{t / base:.2f}" if name.startswith("match") else ""]
            for name, t in times.items()]
    out.append("Speed: 15x15 window, 128 px search (d = 0..128), one thread, CPU time, best of 3 x "
               f"{reps} calls; ratio to the float64 reference measured in this run")
    out.append(table(["routine", "us per call", "ratio to float"], rows) + "\n")


def _loop(fn, reps: int) -> float:
    """CPU seconds of this process for reps calls: unlike wall time, not inflated when other
    processes share the cores (one BLAS/OpenMP thread, so it is one core's time)."""
    t0 = time.process_time()
    for _ in range(reps):
        fn()
    return time.process_time() - t0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="fewer seeds and fractions (< 1 min)")
    parser.add_argument("--out", type=Path, default=Path("out/bench-core"), help="directory for PNG + tables")
    parser.add_argument("--sections", default="subpixel,fixed,tracks,speed,aliasing,real")
    parser.add_argument("--study-seeds", choices=("tuning", "evaluation"), default="tuning",
                        help="seed set of the opt-in study section (choose methods on tuning seeds only)")
    args = parser.parse_args()
    args.seeds, args.fractions = (8, 16) if args.quick else (32, 32)
    sections = set(args.sections.split(","))
    out: list[str] = []
    t0 = time.time()
    bias = None
    if "subpixel" in sections:
        bias = section_subpixel(args, out)
        print("\n".join(out[-5:]), flush=True)
    for name, fn in (("fixed", section_fixed), ("speed", section_speed)):
        if name in sections:
            n = len(out)
            fn(args, out)
            print("\n".join(out[n:]), flush=True)
    if "tracks" in sections:
        from lab.bench.tracks import section_tracks
        n = len(out)
        section_tracks(args, out, bias)
        print("\n".join(out[n:]), flush=True)
    if "study" in sections:
        from lab.bench.subpix_study import section_study
        n = len(out)
        section_study(args, out)
        print("\n".join(out[n:]), flush=True)
    if "aliasing" in sections:
        from lab.bench.aliasing import section_aliasing
        n = len(out)
        section_aliasing(args, out)
        print("\n".join(out[n:]), flush=True)
    if "real" in sections:
        from lab.bench.real import section_real
        n = len(out)
        section_real(args, out)
        print("\n".join(out[n:]), flush=True)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "bench-core.txt").write_text("\n".join(out) + "\n")
    print(f"wrote {args.out / 'bench-core.txt'} ({time.time() - t0:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
