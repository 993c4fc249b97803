"""TrackTable: box overlap, the sea/ship slope test on synthetic planes, where a track's point may sit on
its ship (off glints, off the ends), ids and the Q -> T lifecycle on rendered recordings."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest
from helpers import band_texture, shifted_u8
from hypothesis import given, settings
from hypothesis import strategies as st

from drivers.camera.replay import ReplaySource
from edge.config.calibration import recording_calibration
from edge.core.camera import PinholeCamera, StereoRig
from edge.core.rectify import Rectifier
from edge.fix import TrackStatus
from edge.measure.anchor import CLIPPED_DN
from edge.measure.filter_designs import Designs
from edge.measure.point import TrackPoint
from edge.measure.settings import PointSettings
from edge.measure.tracks import WINDOW_VOTES, TableSettings, Track, TrackTable
from edge.pipeline import Pipeline
from edge.recording.format import read_truth

W, H, F, B, HEIGHT = 400, 300, 900.0, 8.0, 25.0


def _pair(disparity_of_row) -> tuple[np.ndarray, np.ndarray]:
    """Textured left image and a right image shifted row by row by disparity_of_row(v)."""
    rng = np.random.default_rng(3)
    tex = 128 + 50 * cv2.GaussianBlur(rng.normal(0, 1, (H, W + 80)), (0, 0), 1.0)
    tex = tex[:, 40:W + 40].astype(np.float32)
    vv, uu = np.mgrid[0:H, 0:W].astype(np.float32)
    d = np.array([disparity_of_row(v) for v in range(H)], np.float32)[:, None]
    right = cv2.remap(tex, uu + d, vv, cv2.INTER_CUBIC, borderMode=cv2.BORDER_REFLECT)
    to8 = lambda a: np.clip(np.round(a), 0, 255).astype(np.uint8)  # noqa: E731
    return to8(tex), to8(right)


def _table() -> TrackTable:
    cam = PinholeCamera(F, F, (W - 1) / 2, (H - 1) / 2)
    s = PointSettings(fps=10.0, max_disparity=64, baseline_m=B, focal_px=F)
    return TrackTable(Rectifier(StereoRig(B, W, H, cam, cam)), HEIGHT, s, TableSettings())


def _ship_on_a_textured_sea(seed: int, box: tuple[int, int, int, int]) -> np.ndarray:
    """Left image: sea texture everywhere (the ship's ends stand against it), a textured ship in `box`."""
    x0, y0, x1, y1 = box
    left = shifted_u8(0.6 * band_texture(seed, H, W), 0.0)  # (~0.6 * 128 +- 36: nothing clips)
    left[y0:y1, x0:x1] = shifted_u8(0.3 * band_texture(seed + 1, y1 - y0, x1 - x0), 0.0)  # darker hull
    return left


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 10_000), st.integers(0, 59), st.integers(0, 11), st.integers(16, 60))
def test_candidates_keep_off_glints_and_off_the_ship_ends(seed: int, du: int, dv: int, length: int) -> None:
    """Every candidate's window lies within the ship's columns when the ship is wider than a window
    (else its centre lies on the ship); windows holding a clipped pixel (a glint on the upper part of
    the ship) come after all others, and the best one is clean whenever the ship has a column that
    glinted windows and their neighbourhoods (half a window each) cannot cover."""
    x0, y0, y1 = 150, 140, 160
    x1 = x0 + length
    left = _ship_on_a_textured_sea(seed, (x0, y0, x1, y1))
    gu, gv = x0 + du % length, y0 + dv
    left[gv - 1:gv + 2, gu - 1:gu + 2] = 255  # a clipped sun glint, a few pixels across
    table = _table()
    h = table.ps.window // 2
    points = table._candidates(left, np.array([x0, y0, x1, y1], float))
    assert points
    lo, hi = (x0 + h, x1 - h) if length > 2 * h + 1 else (x0, x1)
    assert all(lo <= u < hi and y0 <= v < y1 for u, v in points)
    glare = [bool(left[int(v) - h:int(v) + h + 1, int(u) - h:int(u) + h + 1].max() >= CLIPPED_DN)
             for u, v in points]
    assert glare == sorted(glare)  # clean ones first
    if any(abs(c - gu) > 2 * h + 1 for c in range(lo, hi)):
        assert not glare[0]


def test_a_ship_all_glare_still_gets_a_point() -> None:
    left = _ship_on_a_textured_sea(1, (150, 140, 200, 160))
    left[130:170, 140:210] = 255
    assert len(_table()._candidates(left, np.array([150.0, 140.0, 200.0, 160.0]))) >= 1


def test_a_searching_point_restarts_on_its_ship_only_without_a_range_history() -> None:
    """Without a prediction a searching point cannot check a candidate, so the next detection puts it
    back on the ship; with one it keeps its place (its candidates must fit the range it has)."""
    table = _table()
    left, right = _pair(lambda v: 14.0)
    box = np.array([150.0, 150.0, 230.0, 175.0])
    fresh = TrackPoint(120.0, 200.0, table.ps, table.designs)  # never measured: no prediction
    ranged = TrackPoint(190.0, 160.0, table.ps, table.designs)
    for _ in range(8):
        ranged.step(left, right, table.rect)
    assert fresh.prediction() is None and ranged.prediction() is not None
    for point in (fresh, ranged):
        point.searching = True
        before = (point.u, point.v)
        table._confirm_start(Track(1, 0, point, box, 5), box, left)
        if point is fresh:
            assert not point.searching and (point.u, point.v) == table._reference(left, box)
        else:
            assert point.searching and (point.u, point.v) == before


def test_slopes_of_many_points_equal_each_points_slope() -> None:
    """The association's slope tests answered together (batched when three or more share settings)
    give each point's own `_slope`, with and without a prediction, valid or not (flat rows)."""
    table = _table()
    left, right = _pair(lambda v: 10.0 + 0.05 * v)
    left[250:, :], right[250:, :] = 120, 120                 # no texture: no match, no slope
    points = [TrackPoint(float(u), float(v), table.ps, table.designs)
              for u, v in [(150, 100), (200.5, 120.3), (260, 140), (310.7, 160), (180, 262), (120, 90)]]
    for p in points[:3]:
        for _ in range(8):
            p.step(left, right, table.rect)                   # these have a prediction
    got = table._slopes(points, left, right)
    assert got == [table._slope(p, left, right) for p in points]
    assert sum(s is not None for s in got) >= 4 and got[4] is None


@pytest.mark.parametrize("sea", [True, False])
def test_slope_tells_the_sea_from_a_ship_side(sea: bool) -> None:
    """The sea's disparity grows by L_B / h per row below the horizon (flat-sea approximation,
    exact enough here); a vertical hull keeps one disparity."""
    cam = PinholeCamera(F, F, (W - 1) / 2, (H - 1) / 2)
    rect = Rectifier(StereoRig(B, W, H, cam, cam))
    horizon = (H - 1) / 2 + F * 0.0028
    left, right = _pair((lambda v: max(0.0, B * (v - horizon) / HEIGHT)) if sea else (lambda v: 14.0))
    s = PointSettings(fps=10.0, max_disparity=64, baseline_m=B, focal_px=F)
    table = TrackTable(rect, HEIGHT, s, TableSettings())
    point = TrackPoint(200.0, 200.0, s, Designs(s))
    point.step(left, right, rect)
    slope = table._slope(point, left, right)
    assert slope is not None
    if sea:
        assert slope == pytest.approx(B / HEIGHT, rel=0.15)
    else:
        assert abs(slope) < 0.02


def test_ids_are_never_reused_and_q_needs_confirmations_and_a_running_filter(recording) -> None:
    path = recording("akashi-crossing", 30)
    with ReplaySource(path) as src:
        pairs, meta = list(src), src.meta
    pipe = Pipeline(recording_calibration(path, meta), fps=meta["fps"])
    seen_ids: list[int] = []
    first_t: dict[int, float] = {}
    born: dict[int, float] = {}
    for pair in pairs:
        pipe.step(pair)
        for t in pipe.table.tracks:
            if t.id not in born:
                born[t.id] = pair.t_ns / 1e9
                assert not seen_ids or t.id > max(seen_ids)  # fresh ids only, increasing
                seen_ids.append(t.id)
            if t.status is TrackStatus.TRACKING and t.id not in first_t:
                first_t[t.id] = pair.t_ns / 1e9
                assert t.point.updates >= pipe.table.s.min_updates  # the filter has run, not just started
    assert len(set(seen_ids)) == len(seen_ids) == pipe.table.births
    period = pipe.cfg.detect_every / meta["fps"]
    assert first_t, "the freighter must become T"
    for tid, t in first_t.items():  # confirm_n detection passes, the birth being the first
        assert t - born[tid] >= (pipe.table.s.confirm_n - 1) * period - 1e-9


def test_ships_among_glints_become_t_within_3_s_and_glints_never_do(recording) -> None:
    """The glints scenario (40 one-view glints a second, a third on the ships): both ships cover
    more than 20 px from the start (30 m at 800 m, 75 m at 2 km: 34 px at f = 914 px) and must be
    T within 3 s; every T fix points at a ship (bearing within its half-length) and lies within
    3 reported sigma of a disc around the ship's bridge that holds its whole hull."""
    path = recording("glints", 40)
    with ReplaySource(path) as src:
        pairs, meta = list(src), src.meta
    truth = read_truth(path)
    size = {int(s["id"]): math.hypot(float(s["length_m"]), float(s["beam_m"])) for s in meta["ships"]}
    pipe = Pipeline(recording_calibration(path, meta), fps=meta["fps"])
    first_t: dict[int, float] = {}
    for k, pair in enumerate(pairs):
        for fix in pipe.step(pair):
            if fix.status is not TrackStatus.TRACKING:
                continue
            ship = min(truth, key=lambda i: abs(math.atan2(fix.x_m, fix.z_m)
                                                - math.atan2(truth[i][k, 1], truth[i][k, 3])))
            x, z = truth[ship][k, 1], truth[ship][k, 3]
            assert abs(math.atan2(fix.x_m, fix.z_m) - math.atan2(x, z)) * math.hypot(x, z) <= size[ship]
            assert math.hypot(fix.x_m - x, fix.z_m - z) <= size[ship] + 3.0 * fix.sigma_m
            first_t.setdefault(ship, pair.t_ns / 1e9)
    assert set(first_t) == set(truth) and max(first_t.values()) <= 3.0, first_t


def _small_ship_pair(box: tuple[int, int, int, int], disparity: float) -> tuple[np.ndarray, np.ndarray]:
    """A textured ship in `box` on a flat background (far sea and sky), the right image shifted by
    `disparity`."""
    x0, y0, x1, y1 = box
    rng = np.random.default_rng(5)
    tex = np.full((H, W), 120.0, np.float32)
    tex[y0:y1, x0:x1] = 120 + 50 * cv2.GaussianBlur(rng.normal(0, 1, (y1 - y0, x1 - x0)), (0, 0), 1.0)
    vv, uu = np.mgrid[0:H, 0:W].astype(np.float32)
    right = cv2.remap(tex, uu + disparity, vv, cv2.INTER_CUBIC, borderMode=cv2.BORDER_REFLECT)
    to8 = lambda a: np.clip(np.round(a), 0, 255).astype(np.uint8)  # noqa: E731
    return to8(tex), to8(right)


def test_a_ship_shrunk_into_the_spanning_window_takes_it_after_some_passes_and_keeps_its_filter() -> None:
    """A track on the configured window whose ship is narrow enough for edge.measure.anchor.ship_window's
    spanning window takes it once WINDOW_VOTES detection passes in a row call for it, at the same
    point and with the same filter, and goes on measuring the ship's disparity; a track already on
    its own window keeps it when the ship grows past two windows."""
    table = _table()
    box_px = (150, 140, 170, 156)
    left, right = _small_ship_pair(box_px, 14.0)
    box = np.array(box_px, float)
    spanning = table._ship_window(left, box)
    assert spanning > table.ps.window  # the premise: a small ship on a quiet background
    point = TrackPoint(160.0, 147.0, table.ps, table.designs)
    for _ in range(8):
        assert point.step(left, right, table.rect)
    track = Track(1, 0, point, box, 5)
    updates, position = point.updates, (point.u, point.v)
    for _ in range(WINDOW_VOTES - 1):
        table._confirm_start(track, box, left)
        assert point.s.window == table.ps.window
    table._confirm_start(track, box, left)
    assert point.s.window == spanning and point.updates == updates and (point.u, point.v) == position
    for _ in range(5):
        assert point.step(left, right, table.rect)
    assert point.updates == updates + 5 and point.disparity == pytest.approx(14.0, abs=0.05)
    wide = np.array([100.0, 140.0, 100.0 + 3 * table.ps.window, 156.0])
    for _ in range(2 * WINDOW_VOTES):
        table._confirm_start(track, wide, left)
    assert point.s.window == spanning


@given(share=st.floats(0.0, 1.0), left_px=st.floats(-40.0, 40.0), right_px=st.floats(-40.0, 40.0),
       pairs=st.integers(1, 5))
@settings(max_examples=40, deadline=None)
def test_box_step_is_the_box_ends_motion_at_the_point_per_pair(share: float, left_px: float, right_px: float,
                                                               pairs: int) -> None:
    """A track's point a share along its box: the box's next ends moved by left_px and right_px over
    `pairs` pairs tell the point it moved by the ends' motion interpolated at its place, per pair; a
    box that overlaps it too little (another ship) tells it nothing."""
    table = _table()
    box = np.array([100.0, 150.0, 300.0, 175.0])
    point = TrackPoint(100.0 + 200.0 * share, 160.0, table.ps, table.designs)
    track = Track(1, 0, point, box, 5)
    table.tracks = [track]
    point.frame += pairs - 1  # the pairs since the box, less the coming one
    table._box_steps([box + np.array([left_px, 0.0, right_px, 0.0])], 0)
    expected = ((1.0 - share) * left_px + share * right_px) / pairs
    assert point.box_step_px == pytest.approx(expected, abs=1e-9)
    point.box_step_px = None
    table._box_steps([box + np.array([205.0, 0.0, 205.0, 0.0])], 0)
    assert point.box_step_px is None


def test_a_newborn_at_1_fps_lives_while_its_filter_takes_its_start_samples() -> None:
    """The Kalman starts from init_samples measurements: 4 s after birth at 1 fps, and one pair
    without a match (here a blank right image) makes it 5 s, longer than coast_s. Its samples count
    as measurements, so the track lives to take its first update."""
    table = _table()
    table.ps = PointSettings(fps=1.0, max_disparity=64, baseline_m=B, focal_px=F)
    left, right = _pair(lambda v: 14.0)
    blank = np.full_like(right, 128)
    box = np.array([150.0, 150.0, 230.0, 175.0])
    point = TrackPoint(*table._reference(left, box), table.ps, table.designs)
    assert point.step(left, right, table.rect) and point.collected
    track = Track(1, 0, point, box, 5)
    table.tracks = [track]
    init = point.kalman.design.init_samples
    for k in range(1, init + 1):
        table.step(left, blank if k == 2 else right, int(k * 1e9), boxes=[box])
        assert track.alive and track.status is TrackStatus.ACQUIRING
        assert point.collected == (k not in (2, init))
    assert init / table.ps.fps > table.s.coast_s
    assert point.updates == 1  # the filter started on its init_samples-th sample



def test_a_lost_track_lives_while_its_restarting_filter_takes_its_start_samples() -> None:
    """An L track is dropped drop_s after it turned L, but not while its Kalman restarts: its
    init_samples take init_samples / fps (5 s at 1 fps, as long as drop_s); once no sample came for
    that long, drop_s holds again."""
    table = _table()
    table.ps = PointSettings(fps=1.0, max_disparity=64, baseline_m=B, focal_px=F)
    left, right = _pair(lambda v: 14.0)
    box = np.array([150.0, 150.0, 230.0, 175.0])
    point = TrackPoint(*table._reference(left, box), table.ps, table.designs)
    track = Track(7, 0, point, box, 5)
    track.status, track.lost_since_ns = TrackStatus.LOST, 0
    init = point.kalman.design.init_samples
    for _ in range(init - 1):
        assert point.step(left, right, table.rect) and point.collected and not point.kalman.running
    late_ns = int((table.s.drop_s + 0.5) * 1e9)
    table._lifecycle(track, late_ns)
    assert track.alive  # restarting: drop_s has passed, the samples' time has not
    blank = np.full_like(right, 128)
    for _ in range(init):
        point.step(left, blank, table.rect)  # no more samples (nothing to match)
        assert not point.collected
    table._lifecycle(track, late_ns)
    assert not track.alive
