"""Accuracy of the pipeline on simulator recordings, against their ground truth (truth.csv).

    .venv/bin/python tools/evaluate RECORDING... [--plots DIR] [--json FILE] [--stages | --no-stages]

For each recording it runs the same Pipeline as `mast-stereo replay` (calibration, site and
frame rate from meta.yaml, default pipeline settings) and prints, per range bin (0-1 .. 4-5 km
of true range): T fixes, RMS / p95 / max range error in m and % of range, bearing error, the
share meeting IMO MSC.192(79) target accuracy (50 m or 1 % of range, whichever is greater,
and 2 deg) against the bridge (truth.csv), the detection rate (pairs where a ship covering
>= 20 px has a T fix), and the IMO share against the hull outline instead ("IMO hull": how
often the point of the ship a fix measures is measured to IMO accuracy); then per
ship the id switches and the time from covering 20 px to the first T fix, false fixes, and
how the reported 1-sigma holds (fixes more than 3 sigma outside the hull outline); then
ruling 1's calibration criterion against ruling 4's 3-D hull error and IMO against the hull as
the pass/fail column (lab/evaluate/sigma.py).

With --stages (the default for akashi-crossing) it also runs the thesis's stages side by
side on the same pairs: whole-pixel matching, sub-pixel parabola (eq. 5.2), Butterworth
(eq. 6.1, thesis-style SSD), and the product (ZSSD + half-pixel cancellation + Kalman), and
prints the range-error envelope of the main ship beside eq. 4.5's prediction for
delta = 0.5 / 0.15 / 0.11 px; --plots DIR then writes DIR/<recording>-xz.png (the X-Z track
like the thesis's Fig. 6.2) and DIR/<recording>-range-error.png (range error against range).
matplotlib is the optional `plots` extra, imported only for --plots.

--diagnose (simulated recordings) splits each T fix's range error per range bin into the
followed point's offset from the bridge, the raw disparity error of that point and what the
filter does with it (lab/evaluate/diagnose.py).
"""

from __future__ import annotations

import argparse
import json
import sys
from collections import defaultdict
from pathlib import Path

import numpy as np

import lab.evaluate.ais as eais
import lab.evaluate.alerts as evaluate_alerts
import lab.evaluate.metrics as em
import lab.evaluate.motion as evaluate_motion
import lab.evaluate.sigma as es
import lab.subpix  # noqa: F401  (registers the research sub-pixel methods, "refit")
from edge.chain import Chain
from edge.config.app import ExperimentalConfig, PipelineConfig
from edge.config.calibration import recording_calibration
from edge.core.triangulation import range_error
from edge.measure.settings import SUBPIXELS, PointSettings
from edge.pipeline import Pipeline
from edge.recording.format import read_truth
from edge.replay import open_recording, recorded_ais
from edge.sim.ships import KINDS, ShipModel
from lab.evaluate.stages import stage_pipelines

THESIS_DELTAS_PX = {"whole-pixel": 0.5, "sub-pixel": 0.15, "butterworth": 0.11, "product": 0.11}


def load_ships(root: Path, meta: dict) -> list[em.Ship]:
    truth = read_truth(root)
    ships = []
    for info in meta.get("ships", []):
        sid = int(info["id"])
        if sid not in truth:
            continue
        kind, length = info.get("kind"), float(info.get("length_m", 0.0))
        model = ShipModel.build(kind, length) if kind in KINDS else None
        bridge_a = float(model.tracked_local[0]) if model is not None else 0.0
        rows = truth[sid]
        ships.append(em.Ship(sid, length, float(info.get("beam_m", length / 6)), bridge_a,
                             rows[:, 0].astype(np.int64), rows[:, 1:4],
                             **({} if model is None else {"bridge_h_m": float(model.tracked_local[2]),
                                                          "top_h_m": float(model.extent_local[1, 2])})))
    return ships


def run(root: Path, stages: bool, subpixel: str | None = None,
        alias_check: bool = True) -> tuple[dict[str, dict[int, list]], Pipeline, dict]:
    """Fixes by stage name and pair time; the product pipeline (for its counters and geometry),
    with another sub-pixel method than its default if `subpixel` is given, and with
    pipeline.experimental.alias_check off unless `alias_check` (the default: on; the other stages
    stay the thesis's)."""
    source = open_recording(root)
    meta = source.meta
    cal = recording_calibration(root, meta)
    fps = float(meta["fps"])
    pipes = stage_pipelines(cal, PipelineConfig(), fps=fps) if stages else \
        {"product": Pipeline(cal, PipelineConfig(), fps=fps)}
    if subpixel is not None or alias_check != ExperimentalConfig.alias_check:
        product = PipelineConfig(experimental=ExperimentalConfig(alias_check=alias_check))
        pipes["product"] = Pipeline(cal, product, fps=fps, subpixel=subpixel or PointSettings.subpixel)
    fixes: dict[str, dict[int, list]] = {name: defaultdict(list) for name in pipes}
    ais = recorded_ais(root)  # the product runs in the chain replay runs: AIS from ais.csv when present
    chain = Chain(pipes["product"], Chain.build_ais(None, pipes["product"], ais))
    if ais is not None and ais.lines:
        chain.start(min(ais.lines[0][0], 0))
    with source:
        for pair in source:
            for name, pipe in pipes.items():
                fixes[name][pair.t_ns] = chain.step(pair) if name == "product" else pipe.step(pair)
    if chain.ais is not None:
        meta = {**meta, "_ais_stage": chain.ais.stage}
    for name, pipe in pipes.items():  # a pipeline error is counted, not raised: its figures would lie
        if pipe.counters.failed:
            print(f"evaluate: {root}: {pipe.counters.failed} pairs abandoned by the {name} pipeline "
                  "(errors logged above); its figures are not the pipeline's", file=sys.stderr)
    return fixes, pipes["product"], meta


def fmt(value: float | None, spec: str = ".1f") -> str:
    return "-" if value is None else format(value, spec)


def print_bins(rows: list[dict]) -> None:
    print(f"{'range':>8} {'fixes':>6} {'RMS m':>7} {'p95 m':>7} {'max m':>7} {'RMS %':>6} {'p95 %':>6} "
          f"{'max %':>6} {'brg RMS':>7} {'brg max':>7} {'IMO':>6} {'detect':>6} {'IMO hull':>8}")
    for r in rows:
        print(f"{r['bin']:>8} {r['fixes']:>6} {fmt(r.get('rms_m')):>7} {fmt(r.get('p95_m')):>7} "
              f"{fmt(r.get('max_m')):>7} {fmt(r.get('rms_pct'), '.2f'):>6} {fmt(r.get('p95_pct'), '.2f'):>6} "
              f"{fmt(r.get('max_pct'), '.2f'):>6} {fmt(r.get('bearing_rms_deg'), '.2f'):>7} "
              f"{fmt(r.get('bearing_max_deg'), '.2f'):>7} "
              f"{fmt(None if 'imo_share' not in r else 100 * r['imo_share'], '.1f'):>5}% "
              f"{fmt(None if r['detection'] is None else 100 * r['detection'], '.1f'):>5}% "
              f"{fmt(None if 'imo_hull_share' not in r else 100 * r['imo_hull_share'], '.1f'):>7}%")


def stage_envelopes(results: dict[str, em.Evaluation], ship_id: int, focal_px: float,
                    baseline_m: float) -> list[dict]:
    rows = []
    for name, ev in results.items():
        ms = [m for m in ev.matched if m.ship_id == ship_id]
        if not ms:
            rows.append({"stage": name, "fixes": 0})
            continue
        e = np.array([m.range_error_m for m in ms])
        z = float(np.mean([m.range_m for m in ms]))
        eps = THESIS_DELTAS_PX[name] / focal_px
        rows.append({"stage": name, "fixes": len(ms), "mean_range_m": z, "min_m": float(e.min()),
                     "max_m": float(e.max()), "rms_m": float(np.sqrt(np.mean(e**2))),
                     "half_envelope_m": float((e.max() - e.min()) / 2), "bias_m": float(np.mean(e)),
                     "delta_px": THESIS_DELTAS_PX[name],
                     "eq45_near_m": float(range_error(z, -eps, baseline_m)),
                     "eq45_far_m": float(range_error(z, eps, baseline_m))})
    return rows


def plots(out: Path, name: str, results: dict[str, em.Evaluation], ships: list[em.Ship], ship_id: int,
          focal_px: float, baseline_m: float) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out.mkdir(parents=True, exist_ok=True)
    ship = next(s for s in ships if s.ship_id == ship_id)
    fig, ax = plt.subplots(figsize=(8, 5))
    ax.plot(ship.xyz_m[:, 0], ship.xyz_m[:, 2], "k-", lw=2, label="truth (bridge)")
    for stage, ev in results.items():
        ms = [m for m in ev.matched if m.ship_id == ship_id]
        ax.plot([m.x_m for m in ms], [m.z_m for m in ms], ".", ms=3, label=stage)
    ax.set_xlabel("X (m, along the baseline)")
    ax.set_ylabel("Z (m, forward)")
    ax.set_title(f"{name}: ship {ship_id} track by stage (cf. thesis Fig. 6.2)")
    ax.legend()
    fig.tight_layout()
    fig.savefig(out / f"{name}-xz.png", dpi=120)
    fig, ax = plt.subplots(figsize=(8, 5))
    for stage, ev in results.items():
        ms = ev.matched
        ax.plot([m.range_m for m in ms], [m.range_error_m for m in ms], ".", ms=3, label=stage)
    ranges = np.linspace(max(100.0, min(m.range_m for ev in results.values() for m in ev.matched) * 0.8),
                         max(m.range_m for ev in results.values() for m in ev.matched) * 1.1, 200)
    for delta, style in ((0.5, ":"), (0.15, "--"), (0.11, "-.")):
        for sign in (-1, 1):
            ax.plot(ranges, range_error(ranges, sign * delta / focal_px, baseline_m), "k" + style, lw=0.8,
                    label=f"eq. 4.5, delta {delta} px" if sign > 0 else None)
    ax.axhline(0, color="k", lw=0.5)
    ax.set_yscale("symlog", linthresh=50)
    ax.set_xlabel("true range (m)")
    ax.set_ylabel("range error (m, symlog)")
    ax.set_title(f"{name}: range error against range, all ships")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / f"{name}-range-error.png", dpi=120)
    plt.close("all")


def evaluate_recording(root: Path, stages: bool | None, plot_dir: Path | None,
                       subpixel: str | None = None, alias_check: bool = True) -> dict:
    source_meta = open_recording(root).meta
    name = str(source_meta.get("scenario") or root.name)
    stages = name == "akashi-crossing" if stages is None else stages
    fixes, product, meta = run(root, stages, subpixel, alias_check)
    ships = load_ships(root, meta)
    f, width = product.rect.f_px, product.rig.width
    results = {stage: em.evaluate(fx, ships, f, width) for stage, fx in fixes.items()}
    ev = results["product"]
    rows = em.bin_rows(ev)
    print(f"\n== {name} ({root}): {product.counters.pairs} pairs, {product.counters.fixes} fixes, "
          f"{product.table.births} tracks born")
    print_bins(rows)
    delays = em.first_t_delays(ev)
    speeds = em.speed_rows(ev)
    for s in ships:
        if s.ship_id not in delays:
            first = "never covers 20 px"
        elif delays[s.ship_id] is None:
            first = "never T after covering 20 px"
        else:
            first = f"first T {delays[s.ship_id]:.1f} s after covering 20 px"
        print(f"ship {s.ship_id} ({s.length_m:.0f} m): id switches {ev.id_switches[s.ship_id]}, {first}")
        sp = speeds.get(s.ship_id)
        if sp:
            print(f"  speed: on {sp['with_speed']} of {sp['fixes']} T fixes (withheld while unsure); "
                  f"error RMS {fmt(sp['rms_kn'])} kn, max {fmt(sp['max_kn'])} kn")
    sig = em.sigma_check(ev)
    print(f"false T fixes {len(ev.false_fixes)}; 3-sigma check: {sig}")
    calibration = es.sigma_rows(ev, ships, es.model_hulls(meta) if ev.matched else None)
    print("\n".join(es.format_sigma(calibration)))
    summary = {"recording": str(root), "scenario": name, "counters": vars(product.counters), "bins": rows,
               "id_switches": ev.id_switches, "first_t_s": delays, "false_fixes": len(ev.false_fixes),
               "sigma": sig, "sigma_criterion": calibration,
               "motion": motion_table(fixes["product"], ev, meta, product),
               "alerts": alert_table(fixes["product"], root)}
    if "_ais_stage" in meta:  # issue 17: association, dark flag and the calibration check
        summary["ais"] = eais.ais_report(fixes["product"], ev, meta, meta["_ais_stage"], product)
    if stages and ships:
        main = max(ships, key=lambda s: sum(m.ship_id == s.ship_id for m in ev.matched)).ship_id
        env = stage_envelopes(results, main, f, product.rig.baseline_m)
        print(f"\nstages, ship {main}: range error vs the bridge (m); eq. 4.5 for +-delta at its mean range")
        print(f"{'stage':>12} {'fixes':>6} {'range':>7} {'min':>7} {'max':>7} {'RMS':>6} {'+-half':>7} "
              f"{'delta':>6} {'eq4.5 near':>10} {'eq4.5 far':>10}")
        for r in env:
            if r["fixes"]:
                print(f"{r['stage']:>12} {r['fixes']:>6} {r['mean_range_m']:>7.0f} {r['min_m']:>7.1f} "
                      f"{r['max_m']:>7.1f} {r['rms_m']:>6.1f} {r['half_envelope_m']:>7.1f} "
                      f"{r['delta_px']:>6.2f} "
                      f"{r['eq45_near_m']:>10.1f} {r['eq45_far_m']:>10.1f}")
        summary["stages"] = env
        if plot_dir is not None:
            plots(plot_dir, name, results, ships, main, f, product.rig.baseline_m)
    return summary


def motion_table(fixes: dict[int, list], ev: em.Evaluation, meta: dict, product: Pipeline) -> list[dict]:
    """SOG/COG after 1 and 3 min of steady state against table 3 (lab.evaluate.motion), printed."""
    rows = evaluate_motion.motion_rows(fixes, ev.matched, meta, product.site)
    evaluate_motion.print_motion(rows)
    return rows


def alert_table(fixes: dict[int, list], root: Path) -> list[dict]:
    """Close-quarters alerts: lead time against the truth's CPA, false and missed (lab.evaluate.alerts)."""
    rows, missed = evaluate_alerts.evaluate_alerts(fixes, read_truth(root))
    print("\nclose-quarters alerts (default alerts settings) against the truth's CPA/TCPA")
    print("\n".join(evaluate_alerts.format_rows(rows, missed)))
    return [vars(r) for r in rows] + [{"missed": m} for m in missed]


def diagnose_recording(root: Path, subpixel: str | None = None) -> None:
    """The error split of `lab.evaluate.diagnose` for one recording (needs its scenario to re-pose ships)."""
    import lab.evaluate.diagnose as ed

    source = open_recording(root)
    meta = source.meta
    pipe = Pipeline(recording_calibration(root, meta), PipelineConfig(), fps=float(meta["fps"]),
                    subpixel=subpixel or PointSettings.subpixel)
    diag = ed.Diagnoser(meta, pipe.rect, pipe.point_settings.window)
    probes, misses = ed.diagnose(pipe, diag, source, read_truth(root))
    print(f"\n== error split, {meta.get('scenario')}: T track points against the simulated ships "
          f"({len(probes)} on a ship, {misses} not)")
    print("geom: range of the followed surface point - bridge range; meas: R(filtered d) - range of that "
          "point;\nraw/filt px: raw / filtered disparity - the point's true disparity; "
          "IMO with each part zeroed")
    for line in ed.table(probes):
        print(line)
    print(f"\nwindow scan: the product's match at the followed point with windows of {ed.SCAN_WINDOWS} px, "
          "d - d_bridge mean (RMS), px")
    for line in ed.scan_table(probes):
        print(line)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("recordings", nargs="+", type=Path, metavar="RECORDING")
    parser.add_argument("--plots", type=Path, metavar="DIR", help="write PNG plots here (stages)")
    parser.add_argument("--json", type=Path, metavar="FILE", help="write the figures as JSON")
    parser.add_argument("--diagnose", action="store_true",
                        help="split the range error: geometry / raw disparity / filter (simulator runs)")
    group = parser.add_mutually_exclusive_group()
    group.add_argument("--stages", action="store_true", default=None, help="compare the thesis's stages")
    group.add_argument("--no-stages", dest="stages", action="store_false")
    parser.add_argument("--subpixel", choices=SUBPIXELS + ("refit",),
                        help="the product pipeline's sub-pixel method "
                        f"(default {PointSettings.subpixel})")
    parser.add_argument("--no-alias-check", dest="alias_check", action="store_false",
                        help="the product pipeline with pipeline.experimental.alias_check off (before/after)")
    args = parser.parse_args(argv)
    summaries = [evaluate_recording(r, args.stages, args.plots, args.subpixel, args.alias_check)
                 for r in args.recordings]
    if args.diagnose:
        for r in args.recordings:
            diagnose_recording(r, args.subpixel)
    if args.json is not None:
        args.json.write_text(json.dumps(summaries, indent=1, default=str))
    return 1 if any(s["counters"]["failed"] for s in summaries) else 0


if __name__ == "__main__":
    sys.exit(main())
