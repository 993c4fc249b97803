"""Where a track's time from birth to T goes: the Q -> T gate that held it, pair by pair.

    .venv/bin/python tools/track-gates RECORDING [--tracks 2,3] [--pairs FROM_S TO_S]

Runs the product Pipeline (as `mast-stereo replay` and tools/evaluate do) over a recording and,
for every track, charges each pair it spends ACQUIRING to the first Q -> T check it fails, as
`edge.measure.tracks.TrackTable.promotion_gate` (the one `_lifecycle` uses) names it:

  updates       the point's filter has taken fewer than `min_updates` measurements
  confirmations fewer than `confirm_n` of the last `confirm_m` detection passes confirmed it
  usable        the raw disparities scatter more than the filter's usable limit
  vertical      no slope test yet, or the disparity grows down the rows like the sea's
  height        the point stands less than max(min_height_m, 3 sigma) above the sea

Prints per track: birth, first accepted measurement, first T, drop (s from the recording's
start) and the seconds charged to each gate; with --pairs, a line per pair for the chosen
tracks (status, point, disparity, scatter, median slope and its limit, height and 3 sigma).
Why a far, small ship is late to T is the question it answers (issue 5: T within 3 s).
"""

from __future__ import annotations

import argparse
import sys
from collections import defaultdict
from pathlib import Path

import numpy as np

from edge.config.app import PipelineConfig
from edge.config.calibration import recording_calibration
from edge.fix import TrackStatus
from edge.measure.pointfilter import MAX_USABLE_NOISE_PX
from edge.measure.tracks import VERTICAL_SHARE, Track, TrackTable
from edge.pipeline import Pipeline
from edge.replay import open_recording

GATES = ("updates", "confirmations", "usable", "vertical", "height")  # TrackTable.promotion_gate's


def pair_line(table: TrackTable, track: Track, t_s: float) -> str:
    p = track.point
    out = f"t={t_s:6.1f} id{track.id} {track.status.name[0]} u={p.u:6.1f} v={p.v:6.1f} upd={p.updates:3d}"
    out += f" conf={''.join('1' if c else '0' for c in track.confirmations):5s}"
    scatter = p.scatter_px()
    out += " d=-" if p.disparity is None else f" d={p.disparity:.2f}+-{p.sigma_px:.2f}"
    out += " scatter=-" if scatter is None else f" scatter={scatter:.2f}/{MAX_USABLE_NOISE_PX:.2f}"
    if track.slopes:
        out += f" slope={float(np.median(track.slopes)):+.3f}/{VERTICAL_SHARE * table._sea_slope():.3f}"
    if p.disparity is not None and np.isfinite(p.sigma_px):
        height, sigma = table.height_m(p)
        out += f" height={height:5.1f}/3sig={3.0 * sigma:4.1f} m"
    if track.status is TrackStatus.ACQUIRING:
        out += f" held by {table.promotion_gate(track)}"
    return out


def run(root: Path, show: set[int], window_s: tuple[float, float] | None) -> dict[int, dict]:
    """Per track id: its event times (s) and the seconds charged to each gate."""
    source = open_recording(root)
    meta = source.meta
    fps = float(meta["fps"])
    pipe = Pipeline(recording_calibration(root, meta), PipelineConfig(), fps=fps)
    table = pipe.table
    info: dict[int, dict] = {}
    t0_ns: int | None = None
    with source:
        for pair in source:
            t0_ns = pair.t_ns if t0_ns is None else t0_ns
            t_s = (pair.t_ns - t0_ns) / 1e9
            before = {t.id: t for t in table.tracks}
            pipe.step(pair)
            alive = {t.id: t for t in table.tracks}
            for tid in before.keys() - alive.keys():
                info[tid]["dropped"] = t_s
            for tid, track in alive.items():
                rec = info.setdefault(tid, {"born": t_s, "measured": None, "T": None, "dropped": None,
                                            "gates": defaultdict(float)})
                if rec["measured"] is None and track.point.updates > 0:
                    rec["measured"] = t_s
                if track.status is TrackStatus.ACQUIRING:
                    gate = table.promotion_gate(track)
                    rec["gates"][gate or "passed"] += 1.0 / fps
                elif track.status is TrackStatus.TRACKING and rec["T"] is None:
                    rec["T"] = t_s
                if tid in show and window_s is not None and window_s[0] <= t_s <= window_s[1]:
                    print(pair_line(table, track, t_s))
    return info


def fmt(value: float | None) -> str:
    return "-" if value is None else f"{value:.1f}"


def track_ids(text: str) -> set[int]:
    """--tracks: comma-separated integers (argparse reports the ValueError of a typo by name)."""
    return {int(x) for x in text.split(",") if x.strip()}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("recording", type=Path)
    ap.add_argument("--tracks", type=track_ids, default=set(),
                    help="comma-separated track ids for the per-pair lines")
    ap.add_argument("--pairs", nargs=2, type=float, metavar=("FROM_S", "TO_S"),
                    help="print per-pair lines in this time window (s from the recording's start)")
    args = ap.parse_args(argv)
    info = run(args.recording, args.tracks, tuple(args.pairs) if args.pairs else None)
    print(f"{'track':>5} {'born s':>7} {'1st upd':>7} {'1st T':>7} {'drop':>7}  "
          + " ".join(f"{g:>13}" for g in GATES))
    for tid, rec in sorted(info.items()):
        gates = " ".join(f"{rec['gates'].get(g, 0.0):13.1f}" for g in GATES)
        print(f"{tid:>5} {fmt(rec['born']):>7} {fmt(rec['measured']):>7} {fmt(rec['T']):>7} "
              f"{fmt(rec['dropped']):>7}  {gates}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
