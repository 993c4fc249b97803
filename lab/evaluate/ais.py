"""AIS figures of `tools/evaluate` for a recording with an ais.csv (issue 17).

From the product pipeline's fixes annotated by the AIS stage (as `replay` gives them) and the
truth matching of `lab.evaluate.metrics` (each T fix matched to the ship it measures):
- each track's ship is the ship most of its T fixes are matched to; the figures below compare
  a fix's MMSI and dark flag with that ship's (a pair-by-pair matching swaps two ships while one
  hides the other for a pair or two; those fixes are counted separately, `per_pair_*`);
- per AIS ship: the share of its T fixes carrying its own MMSI;
- wrong associations: T fixes carrying an MMSI not their ship's (a dark ship's fix carrying any
  MMSI included), and unmatched (false) fixes carrying one; must be 0;
- the dark flag per T fix: precision (flagged fixes that are of ships without AIS) and recall
  (fixes of ships without AIS that are flagged), AIS ships ever flagged, and per dark ship the
  time from its first T fix to its first flagged fix;
- the calibration check's final estimates beside the injected errors (meta.yaml `ais_injected`:
  the right camera's yaw as a disparity offset f x yaw, and the heading error).
"""

from __future__ import annotations

import math
from collections import Counter, defaultdict
from typing import Any

import lab.evaluate.metrics as em
from edge.ais.stage import AisStage
from edge.fix import ShipFix, TrackStatus
from edge.pipeline import Pipeline


def _mmsi_by_ship(meta: dict) -> dict[int, int | None]:
    return {
        int(s["id"]): (int(s["ais"]["mmsi"]) if isinstance(s.get("ais"), dict) else None)
        for s in meta.get("ships", [])
    }


def ais_figures(fixes: dict[int, list[ShipFix]], ev: em.Evaluation, meta: dict) -> dict:
    """The association and dark-flag figures (pure: from fixes, the truth matching and meta)."""
    mmsi_of = _mmsi_by_ship(meta)
    by_key = {(t, f.track_id): f for t, fx in fixes.items() for f in fx if f.status is TrackStatus.TRACKING}
    per_ship: dict[int, dict[str, int]] = defaultdict(lambda: {"fixes": 0, "right": 0, "wrong": 0, "dark": 0})
    first_t: dict[int, int] = {}
    first_dark: dict[int, int] = {}
    tp = fp = fn = 0
    votes: dict[int, Counter[int]] = defaultdict(Counter)
    for m in ev.matched:
        votes[m.track_id][m.ship_id] += 1
    ship_of = {tid: c.most_common(1)[0][0] for tid, c in votes.items()}
    per_pair_wrong = per_pair_dark_ais = 0
    for m in ev.matched:
        f = by_key.get((m.t_ns, m.track_id))
        if f is None:
            continue
        per_pair_wrong += int(f.ais_mmsi is not None and f.ais_mmsi != mmsi_of.get(m.ship_id))
        per_pair_dark_ais += int(f.dark and mmsi_of.get(m.ship_id) is not None)
        sid = ship_of[m.track_id]
        truth = mmsi_of.get(sid)
        row = per_ship[sid]
        row["fixes"] += 1
        row["right"] += int(truth is not None and f.ais_mmsi == truth)
        row["wrong"] += int(f.ais_mmsi is not None and f.ais_mmsi != truth)
        row["dark"] += int(f.dark)
        first_t.setdefault(sid, m.t_ns)
        if f.dark:
            first_dark.setdefault(sid, m.t_ns)
        dark_truth = truth is None
        tp += int(f.dark and dark_truth)
        fp += int(f.dark and not dark_truth)
        fn += int(dark_truth and not f.dark)
    false_with_mmsi = sum(1 for f in ev.false_fixes if f.ais_mmsi is not None)
    ships: list[dict[str, Any]] = []
    for sid, row in sorted(per_ship.items()):
        truth = mmsi_of.get(sid)
        delay = None
        if truth is None and sid in first_dark:
            delay = (first_dark[sid] - first_t[sid]) / 1e9
        share = row["right"] / row["fixes"] if truth is not None and row["fixes"] else None
        ships.append({"ship": sid, "mmsi": truth, **row, "right_share": share, "dark_after_first_t_s": delay})
    wrong = sum(r["wrong"] for r in ships) + false_with_mmsi
    return {
        "ships": ships,
        "wrong_associations": wrong,
        "false_fixes_with_mmsi": false_with_mmsi,
        "per_pair_wrong": per_pair_wrong,
        "per_pair_dark_ais": per_pair_dark_ais,
        "dark_precision": tp / (tp + fp) if tp + fp else None,
        "dark_recall": tp / (tp + fn) if tp + fn else None,
        "ais_ships_flagged_dark": sum(1 for r in ships if r["mmsi"] is not None and r["dark"] > 0),
    }


def _fmt(v: float | None, spec: str) -> str:
    return "-" if v is None or (isinstance(v, float) and not math.isfinite(v)) else format(v, spec)


def ais_report(
    fixes: dict[int, list[ShipFix]], ev: em.Evaluation, meta: dict, stage: AisStage, product: Pipeline
) -> dict:
    """Print and return the AIS figures of one recording."""
    out = ais_figures(fixes, ev, meta)
    print("AIS association (issue 17): T fixes by the ship their track follows (majority truth match)")
    print(
        f"{'ship':>5} {'mmsi':>10} {'T fixes':>8} {'right':>6} {'share':>6} {'wrong':>6} {'dark':>5} "
        f"{'dark after 1st T':>16}"
    )
    for r in out["ships"]:
        delay = r["dark_after_first_t_s"]
        delay_text = "-" if delay is None else f"{delay:.1f} s"
        print(
            f"{r['ship']:>5} {r['mmsi'] or 'none':>10} {r['fixes']:>8} {r['right']:>6} "
            f"{_fmt(r['right_share'], '.1%'):>6} {r['wrong']:>6} {r['dark']:>5} {delay_text:>16}"
        )
    print(
        f"wrong associations {out['wrong_associations']} (false fixes with an MMSI "
        f"{out['false_fixes_with_mmsi']}; against a pair-by-pair truth match: "
        f"{out['per_pair_wrong']} wrong, {out['per_pair_dark_ais']} dark on an AIS ship); "
        f"dark flag precision {_fmt(out['dark_precision'], '.1%')}, "
        f"recall {_fmt(out['dark_recall'], '.1%')} (per T fix); AIS ships ever dark "
        f"{out['ais_ships_flagged_dark']}"
    )
    d, b = stage.estimates()
    inj = meta.get("ais_injected") or {}
    yaw = float(inj.get("right_yaw_deg", 0.0))
    injected_px = product.rect.f_px * math.radians(yaw)
    heading = float(inj.get("heading_deg", 0.0))
    print(
        f"calibration check: disparity offset {_fmt(d.value, '+.4f')} px (sigma {_fmt(d.sigma, '.4f')}, "
        f"{d.reports} reports, {d.ships} ships, fault {d.fault}); injected yaw {yaw:g} deg = "
        f"{injected_px:.4f} px at f {product.rect.f_px:.0f} px"
    )
    print(
        f"                   bearing offset {_fmt(b.value, '+.4f')} deg (sigma {_fmt(b.sigma, '.4f')}, "
        f"fault {b.fault}); injected heading error {heading:g} deg"
    )
    print("AIS input: " + ", ".join(f"{k} {v}" for k, v in stage.counters.as_dict().items()))
    out["monitor"] = {
        "disparity_px": d.value,
        "disparity_sigma_px": d.sigma,
        "disparity_fault": d.fault,
        "bearing_deg": b.value,
        "bearing_sigma_deg": b.sigma,
        "bearing_fault": b.fault,
        "reports": d.reports,
        "ships": d.ships,
        "injected_yaw_deg": yaw,
        "injected_disparity_px": injected_px,
        "injected_heading_deg": heading,
    }
    return out
