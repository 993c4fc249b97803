"""Does the reported 1-sigma hold? Ruling 1's calibration criterion and ruling 4's hull error (issue 16).

Used by tools/evaluate (lab.evaluate.report). Pure computation over `Matched` fixes (no I/O).

**The hull error (ruling 4).** A fix is a position of the ship, as a radar echo is: for IMO its
error is its distance to the ship's hull, the nearest point of it in 3-D. On a simulator recording
whose scenario is at hand (`ModelHulls`) the hull is the rendered ship itself: its parts (convex
polyhedra, edge.sim.ships) at the pose of that instant (heading, roll, pitch, heave). Outside
every part e is the distance to the nearest part (Dykstra's projection onto its half-spaces);
inside, the distance to the surface of the part it is deepest in. Otherwise (`hull_error_m`) the
hull is the model's bounding box: length x beam along the truth heading (`Ship.corners`), from
DRAFT_M below the waterline to the model's highest part.

**The sigma's error.** The reported sigma is that of the measured point: the criterion's e is the
fix's range minus the range of the surface its line of sight meets on the ship (ray cast into the
posed model; a ray passing within a pixel of the ship's outline meets the ship where the nearest
ray does, since that pixel, blurred by the optics, sees the ship), and the hull distance where the
ray misses it by more. The hull distance folds a fix inside the ship to
its distance from the nearest plating, which no ranging sigma describes.

**The criterion (ruling 1).** On every recording at least 95 % of T fixes lie within 3 sigma of
the truth (e <= 3 sigma, sigma as the fix reports it to NMEA and Modbus) and
0.6 <= RMS(e / sigma) <= 1.5: a sigma two or three times too large is as wrong as one too small,
since it widens every gate a VTS draws.

**IMO against the hull (ruling 4)** is the pass/fail figure: e within max(50 m, 1 % of range)
and the bearing within 2 deg of the hull's angular extent, on at least 95 % of a range bin's T
fixes (MSC.192(79) states its accuracy at 95 % probability). The bridge-relative columns of
`lab.evaluate.metrics.bin_rows` stay as information.
"""

from __future__ import annotations

import math

import numpy as np

from edge.sim.ships import DRAFT_M
from lab.evaluate.metrics import BINS_M, Evaluation, Matched, Ship

WITHIN_SIGMAS = 3.0
MIN_SHARE_WITHIN = 0.95
RMS_RANGE = (0.6, 1.5)
IMO_SHARE = 0.95  # a bin passes IMO when this share of its T fixes meets the tolerances


def box_distance_m(p: np.ndarray, size: np.ndarray) -> float:
    """Distance from point p (3,) to the surface of the box [0, size] (3,): outside, to the box;
    inside, to its nearest face."""
    below, above = -p, p - size
    outside = np.maximum(np.maximum(below, above), 0.0)
    if outside.any():
        return float(np.linalg.norm(outside))
    return float(np.min(np.minimum(p, size - p)))


def hull_error_m(ship: Ship, i: int, x_m: float, y_m: float, z_m: float) -> float:
    """Ruling 4's e: the fix's distance to the nearest point of the ship's hull in 3-D at sample i.
    Without the model's heights (a ship from an old recording) the vertical is left out."""
    c = ship.corners(i)
    origin, ea, eb = c[2], c[1] - c[2], c[3] - c[2]
    la, lb = float(np.linalg.norm(ea)), float(np.linalg.norm(eb))
    q = np.array([x_m, z_m]) - origin
    local = [float(q @ ea) / la, float(q @ eb) / lb]
    size = [la, lb]
    if math.isfinite(ship.top_h_m):
        waterline_y = ship.xyz_m[i, 1] + ship.bridge_h_m  # world Y is down
        local.append(waterline_y - y_m + DRAFT_M)
        size.append(ship.top_h_m + DRAFT_M)
    return box_distance_m(np.array(local), np.array(size))


def polyhedron_distance_m(points: np.ndarray, planes: np.ndarray, iterations: int = 60) -> np.ndarray:
    """Signed distance of points (n, 3) to the surface of the convex polyhedron n . p <= c (planes
    (P, 4)): inside, minus the distance to the nearest face; outside, the distance to the nearest
    point (Dykstra's alternating projections onto the half-spaces, which converge to it)."""
    normals, offsets = planes[:, :3], planes[:, 3]
    slack = points @ normals.T - offsets  # (n, P), > 0 outside that face
    inside = (slack <= 0.0).all(axis=1)
    out = np.empty(len(points))
    out[inside] = slack[inside].max(axis=1)
    if (~inside).any():
        x = points[~inside].copy()
        corr = np.zeros((len(planes),) + x.shape)
        for _ in range(iterations):
            for k in range(len(planes)):
                y = x + corr[k]
                excess = np.maximum(y @ normals[k] - offsets[k], 0.0)
                x_new = y - excess[:, None] * normals[k]
                corr[k] = y - x_new
                x = x_new
        out[~inside] = np.linalg.norm(points[~inside] - x, axis=1)
    return out


class ModelHulls:
    """The rendered ships of a simulator recording, posed at any instant, for ruling 4's e."""

    def __init__(self, meta: dict) -> None:
        import copy

        from edge.config.schema import load_yaml
        from edge.sim.scenario import build_ships, scenario_from_dict, scenario_path
        from edge.sim.scene import World

        name = str(meta["scenario"])
        path = scenario_path(name.split("@")[0])  # NAME@WIDTH: tools/render-variant's, same ships
        data = copy.deepcopy(load_yaml(path))
        data["calibration"] = meta["calibration"]
        data["site"] = meta.get("site", data.get("site"))
        scenario = scenario_from_dict(data, path, name)
        spec = scenario.spec
        self.world = World(scenario.site.height_m, spec.atmosphere, spec.sky, spec.sea, spec.sun)
        self.ships = build_ships(spec, path)  # the simulator's own (edge.sim.simulator.Simulation)
        self.index = {s.ship_id: i for i, s in enumerate(self.ships)}
        self.left_origin = np.array([-0.5 * scenario.calibration.rig.baseline_m, 0.0, 0.0])
        self.f_px = float(scenario.calibration.rig.focal_px())

    def posed_ships(self, t_s: float) -> list:
        """The ships at time t_s, as the renderer poses them (Simulation.posed_ships)."""
        from edge.sim.rays import PosedShip

        return [PosedShip(i, s.model, *s.pose(t_s, self.world.surface_y_m)) for i, s in enumerate(self.ships)]

    def errors_m(self, ship_id: int, t_ns: np.ndarray, xyz_m: np.ndarray) -> np.ndarray:
        """e of fixes (n, 3) of one ship at their times."""
        i = self.index[ship_id]
        local = np.array([self.posed_ships(float(t) / 1e9)[i].to_local(p[None])[0]
                          for t, p in zip(t_ns, xyz_m, strict=True)])
        dist = np.stack([polyhedron_distance_m(local, part.planes) for part in self.ships[i].model.parts])
        deepest = dist.min(axis=0)  # < 0: inside some part, by the depth of the part it is deepest in
        return np.abs(deepest)

    def los_errors_m(self, ship_id: int, t_ns: np.ndarray, xyz_m: np.ndarray,
                     origin: np.ndarray) -> np.ndarray:
        """The fix's range from `origin` (the left camera) minus the range of the surface its line of
        sight meets on this ship, NaN where it misses the ship by more than `GRAZE_PX`. A ray that
        passes within GRAZE_PX (1 px) of the ship's outline stands for the ship's surface nearest it
        (`graze_hit_t`): the pixel itself, blurred by the optics, still sees the ship there, as the
        points followed on a superstructure top against the sky do (turn-2km: two thirds of the
        rays pass 0-0.3 px above the model). Not further: half the matcher's window (7 px) was
        tried, but on an end-on ship the nearest surface there can be 40 m nearer than the one the
        window's texture measured (approach-720 at 1-2 km), an error the fix never made."""
        out = np.full(len(t_ns), np.nan)
        i = self.index[ship_id]
        for k, (t, p) in enumerate(zip(t_ns, xyz_m, strict=True)):
            ray = (p - origin) / (p - origin)[2]
            hit_t = graze_hit_t(origin, ray, self.posed_ships(float(t) / 1e9), i, self.f_px)
            if hit_t is not None:
                out[k] = float(np.linalg.norm(p - origin) - hit_t[0] * np.linalg.norm(hit_t[1]))
        return out


GRAZE_PX = 1.0  # a pixel's own extent and the optics' blur (psf_sigma_px 0.7): it sees the ship there
_RING_DIRS = np.array([[1, 0], [1, 1], [0, 1], [-1, 1], [-1, 0], [-1, -1], [0, -1], [1, -1]], float)
_RING_RADII_PX = np.arange(1, int(10 * GRAZE_PX) + 1) / 10.0  # square rings, 0.1 px apart


def graze_hit_t(origin: np.ndarray, ray: np.ndarray, posed: list, ship_index: int,
                f_px: float) -> tuple[float, np.ndarray] | None:
    """(t, direction) of the ray (normalised: z = 1) itself where it meets ship `ship_index`, else of
    the nearest ray on square rings 0.1..GRAZE_PX px around it (8 points each) that does; None
    when none of them meets it."""
    from edge.sim.rays import cast

    hit = cast(origin, ray[None], posed)
    if hit.ship[0] == ship_index and np.isfinite(hit.t[0]):
        return float(hit.t[0]), ray
    offsets = (_RING_RADII_PX[:, None, None] * _RING_DIRS[None]).reshape(-1, 2) / f_px
    dirs = np.concatenate([ray[None, :2] + offsets, np.ones((len(offsets), 1))], axis=1)
    hits = cast(origin, dirs, posed)
    ok = np.flatnonzero((hits.ship == ship_index) & np.isfinite(hits.t))  # rings in order of radius
    return None if ok.size == 0 else (float(hits.t[ok[0]]), dirs[ok[0]])


def model_hulls(meta: dict) -> ModelHulls | None:
    """`ModelHulls` for a simulator recording whose scenario is at hand, else None (bounding boxes)."""
    from edge.errors import ConfigError

    try:
        return ModelHulls(meta)
    except (ConfigError, KeyError, OSError, ValueError):
        return None


def hull_errors(ev: Evaluation, ships: list[Ship], hulls: ModelHulls | None = None) -> np.ndarray:
    """e (m) of every matched fix, in `ev.matched`'s order (from the posed models when given)."""
    by_id = {s.ship_id: s for s in ships}
    out = np.empty(len(ev.matched))
    if hulls is not None:
        for sid in {m.ship_id for m in ev.matched}:
            sel = np.array([m.ship_id == sid for m in ev.matched])
            ms = [m for m in ev.matched if m.ship_id == sid]
            out[sel] = hulls.errors_m(sid, np.array([m.t_ns for m in ms]),
                                      np.array([[m.x_m, m.y_m, m.z_m] for m in ms]))
        return out
    for k, m in enumerate(ev.matched):
        s = by_id[m.ship_id]
        i = int(np.searchsorted(s.t_ns, m.t_ns))
        out[k] = hull_error_m(s, min(i, len(s.t_ns) - 1), m.x_m, m.y_m, m.z_m)
    return out


def imo_hull_3d_ok(m: Matched, e_m: float) -> bool:
    """IMO MSC.192(79) tolerances against the hull: e within max(50 m, 1 % of range) and the bearing
    within 2 deg of the hull's angular extent."""
    return e_m <= max(50.0, 0.01 * m.range_m) and m.bearing_outside_deg <= 2.0


def criterion(e_m: np.ndarray, sigma_m: np.ndarray) -> dict:
    """Ruling 1 on one set of fixes: share within 3 sigma, RMS(e / sigma), PASS/FAIL."""
    if len(e_m) == 0:
        return {"fixes": 0, "share_within_3sigma": None, "rms_e_over_sigma": None, "verdict": "-"}
    z = np.asarray(e_m) / np.asarray(sigma_m)
    share = float(np.mean(z <= WITHIN_SIGMAS))
    rms = float(np.sqrt(np.mean(z**2)))
    ok = share >= MIN_SHARE_WITHIN and RMS_RANGE[0] <= rms <= RMS_RANGE[1]
    return {"fixes": int(len(z)), "share_within_3sigma": share, "rms_e_over_sigma": rms,
            "median_e_m": float(np.median(e_m)), "median_sigma_m": float(np.median(sigma_m)),
            "verdict": "PASS" if ok else "FAIL"}


def los_errors(ev: Evaluation, hulls: ModelHulls) -> np.ndarray:
    """The ranging error along each matched fix's line of sight (NaN where its ray misses its ship)."""
    los = np.full(len(ev.matched), np.nan)
    for sid in {m.ship_id for m in ev.matched}:
        sel = np.array([m.ship_id == sid for m in ev.matched])
        ms = [m for m in ev.matched if m.ship_id == sid]
        los[sel] = hulls.los_errors_m(sid, np.array([m.t_ns for m in ms]),
                                      np.array([[m.x_m, m.y_m, m.z_m] for m in ms]), hulls.left_origin)
    return los


def sigma_rows(ev: Evaluation, ships: list[Ship], hulls: ModelHulls | None = None) -> dict:
    """The recording's criterion (all T fixes), the same per range bin, and IMO against the hull per
    bin (the pass/fail column).

    The criterion's e is the error of what the fix measured: along its line of sight against the
    surface that line meets (the ranging error, which the reported sigma describes), and the hull
    distance where the ray misses the ship or no model is at hand. The hull distance alone would
    fold every fix that lands inside the ship to its distance from the nearest plating, so a
    well-sized sigma would look 2-6x too large on big near ships (docs/decisions.md); it stays the
    IMO pass/fail figure (ruling 4) and is printed beside the criterion as information."""
    e_hull = hull_errors(ev, ships, hulls)
    los = los_errors(ev, hulls) if hulls is not None and ev.matched else np.full(len(ev.matched), np.nan)
    e = np.where(np.isfinite(los), np.abs(los), e_hull)
    sigma = np.array([m.sigma_m for m in ev.matched])
    rng = np.array([m.range_m for m in ev.matched])
    bins = []
    for lo, hi in BINS_M:
        sel = (rng >= lo) & (rng < hi)
        if not sel.any():
            continue
        row = criterion(e[sel], sigma[sel])
        ok = [imo_hull_3d_ok(m, float(ek)) for m, ek, s in zip(ev.matched, e_hull, sel, strict=True) if s]
        row.update(bin=f"{lo / 1000:.0f}-{hi / 1000:.0f} km", imo_hull_share=float(np.mean(ok)),
                   imo_verdict="PASS" if np.mean(ok) >= IMO_SHARE else "FAIL")
        bins.append(row)
    whole = criterion(e, sigma)
    hit = np.isfinite(los)
    whole["los_fixes"] = int(hit.sum())
    whole["los_only"] = criterion(np.abs(los[hit]), sigma[hit])  # information: the rays that meet the ship
    whole["hull"] = criterion(e_hull, sigma)  # information
    if ev.matched:
        share = float(np.mean([imo_hull_3d_ok(m, float(ek))
                               for m, ek in zip(ev.matched, e_hull, strict=True)]))
        whole.update(imo_hull_share=share, imo_verdict="PASS" if share >= IMO_SHARE else "FAIL")
    return {"all": whole, "bins": bins}


def _f(value: float | None, spec: str) -> str:
    return "-" if value is None else format(value, spec)


def format_sigma(rows: dict) -> list[str]:
    """The table tools/evaluate prints: per bin and for the whole recording."""
    out = [f"sigma (e: the ranging error along the line of sight) and IMO vs the hull: "
           f"criterion >= {100 * MIN_SHARE_WITHIN:.0f} % within 3 sigma, "
           f"{RMS_RANGE[0]} <= RMS(e/sigma) <= {RMS_RANGE[1]}",
           f"{'range':>8} {'fixes':>6} {'med e m':>8} {'med sig':>8} {'<=3sig':>7} {'RMS e/s':>8} "
           f"{'sigma':>6} {'IMO hull':>8} {'IMO':>5}"]
    for r in [*rows["bins"], {**rows["all"], "bin": "all"}]:
        share = r.get("share_within_3sigma")
        imo = r.get("imo_hull_share")
        out.append(f"{r['bin']:>8} {r['fixes']:>6} {_f(r.get('median_e_m'), '.1f'):>8} "
                   f"{_f(r.get('median_sigma_m'), '.1f'):>8} "
                   f"{_f(None if share is None else 100 * share, '.1f'):>6}% "
                   f"{_f(r.get('rms_e_over_sigma'), '.2f'):>8} {r['verdict']:>6} "
                   f"{_f(None if imo is None else 100 * imo, '.1f'):>7}% {r.get('imo_verdict', ''):>5}")
    hull, los_only = rows["all"].get("hull"), rows["all"].get("los_only")
    if los_only and los_only["fixes"]:
        out.append(f"information, only the fixes whose ray meets the ship: RMS(e/sigma) "
                   f"{los_only['rms_e_over_sigma']:.2f}, "
                   f"{100 * los_only['share_within_3sigma']:.1f} % within 3 sigma")
    if hull and hull["fixes"]:
        out.append(f"e along the line of sight for {rows['all']['los_fixes']} of {rows['all']['fixes']} "
                   f"fixes "
                   f"(the rest: distance to the hull); information, e as the distance to the hull in 3-D: "
                   f"RMS(e/sigma) {hull['rms_e_over_sigma']:.2f}, "
                   f"{100 * hull['share_within_3sigma']:.1f} % within 3 sigma")
    return out
