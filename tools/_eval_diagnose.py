"""Where a simulated recording's range error comes from: geometry, raw disparity, filter.

Used by `tools/evaluate --diagnose`. For every T track of the product pipeline in every pair it
casts the left camera's ray through the track's point (rectified -> raw pixel, the simulator's
own camera model and ship bodies at the pair time) and finds the surface point the window is
centred on. The fix's range error against the bridge (truth.csv) then splits exactly into

    e = R(d_filtered) - R_bridge
      = [R_point - R_bridge]                 (a) geometry: which point of the ship is followed
      + [R(d_filtered) - R(d_point)]         (b+c) measurement of that point

with R_point the true horizontal range of the surface point and d_point its true disparity (the
point projected into the right camera and rectified). (b+c) is split again into the raw
disparity's error d_raw - d_point (b: matcher noise, outliers, windows mixing ship and
background) and what the filter does with it, d_filtered - d_point (c: smoothing, lag). Also
per fix: the share of the 15x15 window's rays that hit the same ship (a window mostly on sea or
sky measures their disparity) and the part of the ship hit (hull, decks, bridge ...).
"""

from __future__ import annotations

import copy
import math
from collections import defaultdict
from dataclasses import dataclass

import numpy as np

from edge.core.rectify import Rectifier
from edge.fix import TrackStatus
from edge.schema import load_yaml
from edge.sim.rays import CameraRays, cast
from edge.sim.scenario import scenario_from_dict, scenario_path
from edge.sim.simulator import Simulation

BINS_M = ((0, 1000), (1000, 2000), (2000, 3000), (3000, 4000), (4000, 5000))


@dataclass
class Probe:
    """One T track in one pair, against the simulator's geometry."""

    range_m: float  # truth (bridge) horizontal range
    part: str  # what the point's ray hits: a part name, or "sea"/"sky"
    geometry_m: float  # (a) R_point - R_bridge
    raw_px: float  # (b) d_raw - d_point (nan: no raw measurement this pair)
    filtered_px: float  # (c) d_filtered - d_point
    filtered_m: float  # R(d_filtered) - R_point
    total_m: float  # R(d_filtered) - R_bridge, along the line of sight of the point
    ship_share: float  # share of the window's rays that hit the ship


class Diagnoser:
    """The simulator's view of a recording, probed at the pipeline's track points."""

    def __init__(self, meta: dict, rect: Rectifier, window: int) -> None:
        # the scenario as rendered: NAME@WIDTH (tools/render-variant) is NAME with the recording's
        # (scaled) calibration
        name = str(meta["scenario"])
        path = scenario_path(name.split("@")[0])
        data = copy.deepcopy(load_yaml(path))
        data["calibration"] = meta["calibration"]
        data["site"] = meta.get("site", data.get("site"))
        self.sim = Simulation(scenario_from_dict(data, path, name), int(meta.get("seed", 0)))
        rig = self.sim.rig
        half = rig.baseline_m / 2.0
        self.left = CameraRays(rig.left, rig.width, rig.height, -half)
        self.right = CameraRays(rig.right, rig.width, rig.height, half)
        self.rect, self.window = rect, window
        self.fb = rect.f_px * rig.baseline_m

    def _disparity(self, world: np.ndarray) -> np.ndarray:
        """True rectified disparity of world points (N, 3)."""
        ul = self.rect.raw_to_rect(self.left.project(world), 0)
        ur = self.rect.raw_to_rect(self.right.project(world), 1)
        return ul[:, 0] - ur[:, 0]

    def probe(self, t_ns: int, track, bridges: dict[int, np.ndarray]) -> Probe | None:
        """The track's point against the ship its window sees (bridges: ship id -> truth xyz)."""
        p = track.point
        if p.disparity is None or p.disparity <= 0:
            return None
        posed = self.sim.posed_ships(t_ns / 1e9)
        h = self.window // 2
        offs = np.arange(-h, h + 1, dtype=np.float64)
        uu, vv = np.meshgrid(p.u + offs, p.v + offs)
        uv = np.stack([np.r_[p.u, uu.ravel()], np.r_[p.v, vv.ravel()]], -1)
        raw = self.rect.rect_to_raw(uv, 0)
        hits = cast(self.left.origin, self.left.dirs(raw[:, 0], raw[:, 1]), posed)
        on = np.flatnonzero(hits.ship >= 0)
        if on.size == 0:
            return None  # the whole window is off every ship (sea or sky): counted apart
        # the point's own ray, or (a window centred on the outline) the nearest ray that hits a ship
        j = int(on[np.argmin(np.hypot(uv[on, 0] - p.u, uv[on, 1] - p.v))])
        ship = hits.ship[j]
        bridge_xyz = bridges.get(self.sim.ships[ship].ship_id)
        if bridge_xyz is None:
            return None
        share = float(np.mean(hits.ship[1:] == ship))
        part = posed[ship].model.parts[hits.part[j]].name
        point = self.left.origin + hits.t[j] * self.left.dirs(raw[j:j + 1, 0], raw[j:j + 1, 1])[0]
        d_point = float(self._disparity(point[None])[0])
        r_point = math.hypot(point[0], point[2])
        r_bridge = math.hypot(bridge_xyz[0], bridge_xyz[2])
        # ranges along the point's own line of sight: Z scales with 1/d, horizontal range with Z
        r_filtered = r_point * d_point / p.disparity
        raw_px = math.nan if p.raw_disparity is None else p.raw_disparity - d_point
        return Probe(r_bridge, part, r_point - r_bridge, raw_px, p.disparity - d_point,
                     r_filtered - r_point, r_filtered - r_bridge, share)


def diagnose(pipe, diag: Diagnoser, source, truth: dict[int, np.ndarray]) -> tuple[list[Probe], dict]:
    """Run the product pipeline over `source`, probing every T track each pair; truth: ship -> rows."""
    probes, misses = [], defaultdict(int)
    index = {sid: {int(r[0]): r[1:4] for r in rows} for sid, rows in truth.items()}
    with source:
        for pair in source:
            pipe.step(pair)
            for track in pipe.table.tracks:
                if track.status is not TrackStatus.TRACKING:
                    continue
                bridges = {sid: rows[pair.t_ns] for sid, rows in index.items() if pair.t_ns in rows}
                probe = diag.probe(pair.t_ns, track, bridges)
                if probe is None:
                    misses["window off every ship"] += 1
                else:
                    probes.append(probe)
    return probes, dict(misses)


def _rms(x: np.ndarray) -> float:
    x = x[np.isfinite(x)]
    return float(np.sqrt(np.mean(x**2))) if x.size else math.nan


def table(probes: list[Probe]) -> list[str]:
    """Per range bin: the error parts (m) and the disparity errors (px) of the followed point."""
    heads = ("range", "n", "tol m", "geom mean", "geom RMS", "meas RMS m", "raw mean px", "raw RMS px",
             "raw MAD px", "filt mean px", "filt RMS px", "IMO", "IMO geom=0", "IMO meas=0", "ship%")
    out = [" ".join(f"{h:>{max(len(h), 5)}}" for h in heads) + "  parts"]
    for lo, hi in BINS_M:
        ps = [p for p in probes if lo <= p.range_m < hi]
        if not ps:
            continue
        geo = np.array([p.geometry_m for p in ps])
        meas = np.array([p.filtered_m for p in ps])
        raw = np.array([p.raw_px for p in ps])
        filt = np.array([p.filtered_px for p in ps])
        tol = np.array([max(50.0, 0.01 * p.range_m) for p in ps])
        total = np.array([p.total_m for p in ps])
        raw_f = raw[np.isfinite(raw)]
        mad = 1.4826 * float(np.median(np.abs(raw_f - np.median(raw_f)))) if raw_f.size else math.nan
        parts = defaultdict(int)
        for p in ps:
            parts[p.part] += 1
        values = (f"{lo / 1000:.0f}-{hi / 1000:.0f} km", str(len(ps)), f"{np.mean(tol):.0f}",
                  f"{np.mean(geo):.1f}", f"{_rms(geo):.1f}", f"{_rms(meas):.1f}",
                  f"{np.mean(raw_f) if raw_f.size else math.nan:.3f}", f"{_rms(raw):.3f}", f"{mad:.3f}",
                  f"{np.mean(filt):.3f}", f"{_rms(filt):.3f}", f"{100 * np.mean(np.abs(total) <= tol):.0f}%",
                  f"{100 * np.mean(np.abs(meas) <= tol):.0f}%", f"{100 * np.mean(np.abs(geo) <= tol):.0f}%",
                  f"{100 * np.mean([p.ship_share for p in ps]):.0f}%")
        part_s = " ".join(f"{k}:{100 * v / len(ps):.0f}%" for k, v in sorted(parts.items()))
        cells = (f"{v:>{max(len(h), 5)}}" for h, v in zip(heads, values, strict=True))
        out.append(" ".join(cells) + "  " + part_s)
    return out
