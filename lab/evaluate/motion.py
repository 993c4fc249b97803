"""SOG and COG against the truth's own speed and course after 1 and 3 min of steady state (IMO
MSC.192(79) table 3), for tools/evaluate.

Truth motion comes from the scenario's scripted tracks (`edge.sim.routes.Route`: the ship's path,
not the bridge point, which sways with roll and pitch): velocity by central differences over
TRUTH_DT_S, turn rate and acceleration over the same. A ship is manoeuvring while its turn rate
exceeds STEADY_TURN_DEG_S or its acceleration STEADY_ACCEL_MPS2; a fix's *steady time* is the time
since the ship last manoeuvred, and at most the track's age (a track born on a steady ship has had
only its age to learn the motion). Table 3 (95 %): after 1 min of steady state course within 11
deg and speed within 1.5 kn or 10 % (the greater), after 3 min 5 deg and 0.5 kn or 1 %. A window
passes when its T fixes carry SOG and COG at least MIN_SHARE of the time and the 95th percentiles
of the errors are within the figures. Beside them RMS(e / sigma) of the reported speed and course,
which says whether their sigma is honest (1 for a calibrated sigma).
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass

import numpy as np

from edge.config.schema import load_yaml
from edge.core.geo import speed_course, world_to_latlon
from edge.core.site import Site
from edge.fix import ShipFix
from edge.sim.routes import Route
from edge.sim.scenario import build_ships, scenario_from_dict, scenario_path

TRUTH_DT_S = 0.5  # half-span of the central differences of the truth track
STEADY_TURN_DEG_S = 0.2  # turning faster than this is a manoeuvre
STEADY_ACCEL_MPS2 = 0.01  # speeding up or slowing down faster than this is one too
MIN_SHARE = 0.95  # T fixes of a window that must carry speed and course to pass


@dataclass(frozen=True)
class Window:
    """One row of table 3: the steady time after which it holds and its limits."""

    name: str
    steady_s: float
    course_deg: float
    speed_kn: float
    speed_share: float  # of the speed (the greater of the two)


TABLE3 = (Window("1 min", 60.0, 11.0, 1.5, 0.10), Window("3 min", 180.0, 5.0, 0.5, 0.01))


@dataclass(frozen=True)
class TruthMotion:
    speed_kn: float
    course_deg: float
    manoeuvring: bool


def truth_tracks(meta: dict) -> dict[int, Route] | None:
    """The scenario's ship tracks by ship id (NAME@WIDTH is NAME with the recording's calibration);
    None when the recording names no scenario that can be loaded."""
    name = meta.get("scenario")
    if not name:
        return None
    try:
        path = scenario_path(str(name).split("@")[0])
        data = copy.deepcopy(load_yaml(path))
    except Exception:  # a recording of a scenario that no longer exists: no truth motion
        return None
    data["calibration"] = meta["calibration"]
    data["site"] = meta.get("site", data.get("site"))
    sc = scenario_from_dict(data, path, str(name))
    return {s.ship_id: s.track for s in build_ships(sc.spec, path)}


def truth_motion(track: Route, t_s: float, site: Site) -> TruthMotion:
    """Speed (kn) and course (true deg at the ship) of a scripted track at t_s, and whether it
    manoeuvres then."""
    (x0, z0, h0), (x1, z1, h1) = track.pose(t_s - TRUTH_DT_S), track.pose(t_s + TRUTH_DT_S)
    v = np.array([(x1 - x0), 0.0, (z1 - z0)]) / (2 * TRUTH_DT_S)
    lat, lon, _ = world_to_latlon(np.array([(x0 + x1) / 2, 0.0, (z0 + z1) / 2]), site)
    sog, cog = speed_course(v, lat, lon, site)
    (xa, za, _), (xb, zb, _) = track.pose(t_s - 3 * TRUTH_DT_S), track.pose(t_s + 3 * TRUTH_DT_S)
    va = math.hypot(x0 - xa, z0 - za) / (2 * TRUTH_DT_S)
    vb = math.hypot(xb - x1, zb - z1) / (2 * TRUTH_DT_S)
    turn = abs((h1 - h0 + math.pi) % (2 * math.pi) - math.pi) / (2 * TRUTH_DT_S)
    accel = abs(vb - va) / (4 * TRUTH_DT_S)
    return TruthMotion(float(sog), float(cog),
                       math.degrees(turn) > STEADY_TURN_DEG_S or accel > STEADY_ACCEL_MPS2)


def steady_since_s(track: Route, times_s: np.ndarray, site: Site) -> np.ndarray:
    """For each of the sorted times, when the ship last manoeuvred (-inf: not since the first time)."""
    out = np.full(len(times_s), -math.inf)
    last = -math.inf
    for i, t in enumerate(times_s):
        if truth_motion(track, float(t), site).manoeuvring:
            last = float(t)
        out[i] = last
    return out


def _wrap_deg(a: float) -> float:
    return (a + 180.0) % 360.0 - 180.0


def motion_rows(fixes_by_t: dict[int, list[ShipFix]], matched: list, meta: dict, site: Site) -> list[dict]:
    """Per ship and table-3 window: T fixes in the window, the share with SOG / COG, the 95th
    percentiles of |SOG error| (kn) and |COG error| (deg) against the truth's own motion, their
    limits, RMS(e / sigma) of each, and pass/fail. `matched` are lab.evaluate.metrics.Matched."""
    tracks = truth_tracks(meta)
    if not tracks:
        return []
    fix_of = {(t, f.track_id): f for t, fs in fixes_by_t.items() for f in fs}
    rows = []
    for sid in sorted({m.ship_id for m in matched if m.ship_id in tracks}):
        ms = sorted((m for m in matched if m.ship_id == sid), key=lambda m: m.t_ns)
        times = np.array([m.t_ns / 1e9 for m in ms])
        since = steady_since_s(tracks[sid], times, site)
        samples = []  # (steady s, sog err, cog err, sog sigma, cog sigma, truth speed)
        for m, t, s0 in zip(ms, times, since, strict=True):
            f = fix_of[(m.t_ns, m.track_id)]
            truth = truth_motion(tracks[sid], float(t), site)
            steady = min(f.age_s, float(t) - s0)
            e_sog = None if f.sog_kn is None else f.sog_kn - truth.speed_kn
            e_cog = None if f.cog_deg is None else _wrap_deg(f.cog_deg - truth.course_deg)
            samples.append((steady, e_sog, e_cog, f.sog_sigma_kn, f.cog_sigma_deg, truth.speed_kn))
        for w in TABLE3:
            sel = [s for s in samples if s[0] >= w.steady_s]
            row: dict = {"ship": sid, "window": w.name, "fixes": len(sel)}
            if sel:
                speed = float(np.mean([s[5] for s in sel]))
                row.update(_errors(sel, w, speed))
            rows.append(row)
    return rows


def _errors(sel: list[tuple], w: Window, speed_kn: float) -> dict:
    sog = np.array([s[1] for s in sel if s[1] is not None])
    cog = np.array([s[2] for s in sel if s[2] is not None])
    sog_z = np.array([s[1] / s[3] for s in sel if s[1] is not None and s[3]])
    cog_z = np.array([s[2] / s[4] for s in sel if s[2] is not None and s[4]])
    speed_limit = max(w.speed_kn, w.speed_share * speed_kn)
    sog_p95 = float(np.percentile(np.abs(sog), 95)) if len(sog) else math.inf
    cog_p95 = float(np.percentile(np.abs(cog), 95)) if len(cog) else math.inf
    out = {"truth_kn": speed_kn, "sog_share": len(sog) / len(sel), "cog_share": len(cog) / len(sel),
           "sog_p95_kn": sog_p95 if len(sog) else None, "cog_p95_deg": cog_p95 if len(cog) else None,
           "sog_limit_kn": speed_limit, "cog_limit_deg": w.course_deg,
           "sog_rms_z": float(np.sqrt(np.mean(sog_z**2))) if len(sog_z) else None,
           "cog_rms_z": float(np.sqrt(np.mean(cog_z**2))) if len(cog_z) else None}
    out["pass"] = bool(len(sog) >= MIN_SHARE * len(sel) and len(cog) >= MIN_SHARE * len(sel)
                       and sog_p95 <= speed_limit and cog_p95 <= w.course_deg)
    return out


def print_motion(rows: list[dict]) -> None:
    """The table-3 table of `motion_rows`."""
    if not rows:
        print("speed/course (table 3): no scenario truth motion")
        return
    print("speed/course vs the truth's own (table 3, 95 %; steady = since the last turn/acceleration "
          "and the track's birth)")
    print(f"{'ship':>4} {'steady':>6} {'fixes':>5} {'truth kn':>8} {'SOG %':>5} {'SOG p95':>7} {'limit':>5} "
          f"{'COG %':>5} {'COG p95':>7} {'limit':>5} {'SOG e/s':>7} {'COG e/s':>7} {'table 3':>7}")

    def f(v: float | None, spec: str) -> str:
        return "-" if v is None else format(v, spec)

    for r in rows:
        if not r["fixes"]:
            print(f"{r['ship']:>4} {r['window']:>6} {0:>5}   (no T fixes that long steady)")
            continue
        print(f"{r['ship']:>4} {r['window']:>6} {r['fixes']:>5} {r['truth_kn']:>8.1f} "
              f"{100 * r['sog_share']:>5.0f} {f(r['sog_p95_kn'], '.2f'):>7} {r['sog_limit_kn']:>5.2f} "
              f"{100 * r['cog_share']:>5.0f} {f(r['cog_p95_deg'], '.1f'):>7} {r['cog_limit_deg']:>5.1f} "
              f"{f(r['sog_rms_z'], '.2f'):>7} {f(r['cog_rms_z'], '.2f'):>7} "
              f"{'pass' if r['pass'] else 'FAIL':>7}")


__all__ = ["TABLE3", "motion_rows", "print_motion", "steady_since_s", "truth_motion"]
