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

Outline split (a small ship the window spans, the far-ship case of edge.measure.anchor.ship_window): in
the point's row, the ship's left and right outlines (its leftmost and rightmost columns within a
window of the point, from the same ray cast) are matched alone with an OUTLINE_WINDOW window and
the product's matcher settings; the table gives their mean disparity minus the bridge's true
disparity ("L/R"), for approaching and receding ships apart (the sign of the bridge's true range
rate). Seen bow- or stern-on, one outline is the corner of the face towards the rig and the
other the far end of the side the rig sees (up to a ship length farther); a window spanning both
measures a disparity between the two. (Which outline is which cannot be told from a ray through
the outline pixel's centre: the side is often narrower than a pixel.) Also per fix the track's
window side and the raw disparity against the bridge's own disparity.

Window scan: the product's match at the followed point with windows of SCAN_WINDOWS px (the
track's own settings otherwise), minus the bridge's true disparity, per range bin and leg: how
much of the error is the window's size (which outlines and faces it takes in) rather than the
point, and whether another size would meet the tolerance there.
"""

from __future__ import annotations

import copy
import math
from collections import defaultdict
from dataclasses import dataclass, replace

import numpy as np

from edge.config.schema import load_yaml
from edge.core.rectify import Rectifier
from edge.fix import TrackStatus
from edge.measure.batch import match_settings, stereo_request
from edge.sim.rays import CameraRays, cast
from edge.sim.scenario import scenario_from_dict, scenario_path
from edge.sim.simulator import Simulation

BINS_M = ((0, 1000), (1000, 2000), (2000, 3000), (3000, 4000), (4000, 5000))
OUTLINE_WINDOW = 9  # px: the window matched on one outline alone (narrower than the far ships)
SCAN_WINDOWS = (9, 15, 21, 27)  # px: window sides matched at the followed point (the window scan)


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
    window: int = 0  # the track's window side, px
    raw_bridge_px: float = math.nan  # d_raw - the bridge's true disparity
    left_px: float = math.nan  # the ship's left outline matched alone - d_bridge
    right_px: float = math.nan  # the ship's right outline matched alone - d_bridge
    receding: bool = False  # the bridge's true range grows
    scan_px: tuple[float, ...] = ()  # SCAN_WINDOWS matched at the point: d - d_bridge each (nan: invalid)


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

    def _outlines(self, p, ship: int, posed, images: tuple[np.ndarray, np.ndarray],
                  d_bridge: float) -> tuple[float, float]:
        """The left and right outline's disparity - d_bridge in the point's row (nan: the ship is
        wider than two windows there, or the outline does not match)."""
        w = p.s.window
        xs = np.arange(round(p.u) - w, round(p.u) + w + 1, dtype=np.float64)
        raw = self.rect.rect_to_raw(np.stack([xs, np.full_like(xs, round(p.v))], -1), 0)
        dirs = self.left.dirs(raw[:, 0], raw[:, 1])
        hits = cast(self.left.origin, dirs, posed)
        on = np.flatnonzero(hits.ship == ship)
        if on.size < 2 or on[0] == 0 or on[-1] == xs.size - 1:
            return math.nan, math.nan
        s = replace(p.s, window=OUTLINE_WINDOW, search_radius_px=4, max_sigma_px=2.0)
        measured = []
        for k in (on[0], on[-1]):  # the outline's own column, in the point's (whole) row
            m = stereo_request(s, *images, self.rect, xs[k], round(p.v), d_bridge, match_settings(s)).run()
            measured.append(m.disparity_px - d_bridge if m.valid else math.nan)
        return measured[0], measured[1]

    def probe(self, t_ns: int, track, bridges: dict[int, np.ndarray], images=None,
              receding: dict[int, bool] | None = None) -> Probe | None:
        """The track's point against the ship its window sees (bridges: ship id -> truth xyz;
        images: the pair's raw (left, right), for the outline split; receding: ship id -> the
        bridge's range grows)."""
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
        ship_id = self.sim.ships[ship].ship_id
        bridge_xyz = bridges.get(ship_id)
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
        d_bridge = float(self._disparity(bridge_xyz[None])[0])
        scan: tuple[float, ...]
        ends, scan = (math.nan, math.nan), ()
        if images is not None:
            ends = self._outlines(p, ship, posed, images, d_bridge)
            scan = self._scan(p, images, d_bridge)
        return Probe(r_bridge, part, r_point - r_bridge, raw_px, p.disparity - d_point,
                     r_filtered - r_point, r_filtered - r_bridge, share, p.s.window,
                     math.nan if p.raw_disparity is None else p.raw_disparity - d_bridge, *ends,
                     bool(receding and receding.get(ship_id, False)), scan)

    def _scan(self, p, images: tuple[np.ndarray, np.ndarray], d_bridge: float) -> tuple[float, ...]:
        """The product's match at the followed point with each of SCAN_WINDOWS (the track's settings
        otherwise, its filtered disparity as the prediction), minus the bridge's true disparity."""
        out = []
        for w in SCAN_WINDOWS:
            s = replace(p.s, window=w)
            m = stereo_request(s, *images, self.rect, p.u, p.v, p.disparity, match_settings(s)).run()
            out.append(m.disparity_px - d_bridge if m.valid else math.nan)
        return tuple(out)


def diagnose(pipe, diag: Diagnoser, source, truth: dict[int, np.ndarray]) -> tuple[list[Probe], dict]:
    """Run the product pipeline over `source`, probing every T track each pair; truth: ship -> rows."""
    misses: defaultdict[str, int]
    probes, misses = [], defaultdict(int)
    index = {sid: {int(r[0]): r[1:4] for r in rows} for sid, rows in truth.items()}
    receding = {(sid, int(r[0])): bool(g > 0) for sid, rows in truth.items() if len(rows) >= 2
                for r, g in zip(rows, np.gradient(np.hypot(rows[:, 1], rows[:, 3])), strict=True)}
    with source:
        for pair in source:
            pipe.step(pair)
            for track in pipe.table.tracks:
                if track.status is not TrackStatus.TRACKING:
                    continue
                bridges = {sid: rows[pair.t_ns] for sid, rows in index.items() if pair.t_ns in rows}
                going = {sid: receding.get((sid, pair.t_ns), False) for sid in bridges}
                probe = diag.probe(pair.t_ns, track, bridges, (pair.left, pair.right), going)
                if probe is None:
                    misses["window off every ship"] += 1
                else:
                    probes.append(probe)
    return probes, dict(misses)


def _rms(x: np.ndarray) -> float:
    x = x[np.isfinite(x)]
    return float(np.sqrt(np.mean(x**2))) if x.size else math.nan


def _mean(values: list[float]) -> str:
    """Mean of the finite values and how many, '-' for none."""
    x = np.array(values, float)
    x = x[np.isfinite(x)]
    return f"{np.mean(x):+.3f} ({x.size})" if x.size else "-"


def _pair(ps: list[Probe]) -> str:
    """Mean left / right outline errors (px) and how many fixes have both."""
    x = np.array([(p.left_px, p.right_px) for p in ps], float).reshape(-1, 2)
    x = x[np.isfinite(x).all(axis=1)]
    return f"{np.mean(x[:, 0]):+.3f}/{np.mean(x[:, 1]):+.3f} ({len(x)})" if len(x) else "-"


def scan_table(probes: list[Probe]) -> list[str]:
    """Per range bin, approaching and receding apart: the mean (RMS) of d - d_bridge of the product's
    match at the followed point with each of SCAN_WINDOWS, px."""
    out = ["range     leg        n " + " ".join(f"{f'win {w}':>15}" for w in SCAN_WINDOWS)]
    for lo, hi in BINS_M:
        for receding in (False, True):
            ps = [p for p in probes if lo <= p.range_m < hi and p.receding == receding and p.scan_px]
            if not ps:
                continue
            x = np.array([p.scan_px for p in ps], float)
            cells = []
            for k in range(x.shape[1]):
                col = x[np.isfinite(x[:, k]), k]
                cells.append(f"{np.mean(col):+.3f} ({_rms(col):.3f})" if col.size else "-")
            leg = "receding" if receding else "approach"
            out.append(f"{lo / 1000:.0f}-{hi / 1000:.0f} km  {leg:<9}{len(ps):>3} "
                       + " ".join(f"{c:>15}" for c in cells))
    return out


def table(probes: list[Probe]) -> list[str]:
    """Per range bin: the error parts (m) and the disparity errors (px) of the followed point."""
    heads = ("range", "n", "tol m", "geom mean", "geom RMS", "meas RMS m", "raw mean px", "raw RMS px",
             "raw MAD px", "filt mean px", "filt RMS px", "IMO", "IMO geom=0", "IMO meas=0", "ship%",
             "win", "raw-bridge px", "L/R approaching px", "L/R receding px")
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
        parts: defaultdict[str, int] = defaultdict(int)
        for p in ps:
            parts[p.part] += 1
        values = (f"{lo / 1000:.0f}-{hi / 1000:.0f} km", str(len(ps)), f"{np.mean(tol):.0f}",
                  f"{np.mean(geo):.1f}", f"{_rms(geo):.1f}", f"{_rms(meas):.1f}",
                  f"{np.mean(raw_f) if raw_f.size else math.nan:.3f}", f"{_rms(raw):.3f}", f"{mad:.3f}",
                  f"{np.mean(filt):.3f}", f"{_rms(filt):.3f}", f"{100 * np.mean(np.abs(total) <= tol):.0f}%",
                  f"{100 * np.mean(np.abs(meas) <= tol):.0f}%", f"{100 * np.mean(np.abs(geo) <= tol):.0f}%",
                  f"{100 * np.mean([p.ship_share for p in ps]):.0f}%",
                  "/".join(str(w) for w in sorted({p.window for p in ps})),
                  _mean([p.raw_bridge_px for p in ps]), _pair([p for p in ps if not p.receding]),
                  _pair([p for p in ps if p.receding]))
        part_s = " ".join(f"{k}:{100 * v / len(ps):.0f}%" for k, v in sorted(parts.items()))
        cells = (f"{v:>{max(len(h), 5)}}" for h, v in zip(heads, values, strict=True))
        out.append(" ".join(cells) + "  " + part_s)
    return out
