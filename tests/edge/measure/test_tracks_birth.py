"""Where tracks may be born and what reaches T: site masks, the pool of weak candidates (M of N passes),
short-lived glints, and one track per ship on the akashi-crossing recording."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from drivers.camera.replay import ReplaySource
from edge.config.calibration import recording_calibration
from edge.core.camera import PinholeCamera, StereoRig
from edge.core.rectify import Rectifier
from edge.fix import TrackStatus
from edge.measure.boxes import waterline_masked
from edge.measure.candidates import CandidatePool
from edge.measure.settings import PointSettings
from edge.measure.tracks import TableSettings, TrackTable
from edge.pipeline import Pipeline, waterline_open
from lab.evaluate import metrics as em
from lab.evaluate.report import load_ships

W, H, F, B, HEIGHT = 400, 300, 900.0, 8.0, 25.0
BOX = np.array([100.0, 100.0, 130.0, 110.0])


def _run(pool: CandidatePool, seen: list[bool]) -> list[int]:
    """The passes (0-based) at which a candidate at BOX, present on the passes marked True, is born."""
    return [k for k, here in enumerate(seen) if pool.step([BOX + k] if here else [])]


@pytest.mark.parametrize(("seen", "born"), [
    ([True, True, True], [2]),
    ([True, False, True, False, True], [4]),
    ([True, True, False, False, False, True, True, True], [7]),  # forgotten after 3 misses, then anew
    ([True, False, False, False, True, False, True], []),
    ([True, True] + [False] * 10, []),  # a glint or a whitecap: two passes, never born
])
def test_a_weak_candidate_is_born_once_seen_in_3_of_5_passes(seen: list[bool], born: list[int]) -> None:
    pool = CandidatePool(3, 5)
    assert _run(pool, seen) == born
    assert len(pool.candidates) <= 1


def test_candidates_follow_their_own_box() -> None:
    pool = CandidatePool(2, 3)
    a, b = np.array([10.0, 100, 40, 110]), np.array([200.0, 120, 240, 132])
    assert pool.step([a, b]) == []
    born = pool.step([b + 3, a + 2])
    assert sorted(x[0] for x in born) == [12.0, 203.0] and pool.candidates == []
    with pytest.raises(ValueError):
        CandidatePool(4, 3)


def _table(mask: np.ndarray | None = None) -> TrackTable:
    cam = PinholeCamera(F, F, (W - 1) / 2, (H - 1) / 2)
    s = PointSettings(fps=10.0, max_disparity=64, baseline_m=B, focal_px=F)
    table = TrackTable(Rectifier(StereoRig(B, W, H, cam, cam)), HEIGHT, s, TableSettings())
    table.search_mask = mask
    return table


def _sea_pair(seed: int) -> tuple[np.ndarray, np.ndarray]:
    """A textured sea: the right image shifted row by row by the sea's disparity (B / h per row below
    the horizon at this rig's dip)."""
    rng = np.random.default_rng(seed)
    tex = (128 + 40 * cv2.GaussianBlur(rng.normal(0, 1, (H, W + 80)), (0, 0), 1.2))[:, 40:W + 40]
    horizon = (H - 1) / 2 + F * 0.00152
    d = np.maximum(0.0, (np.arange(H) - horizon) * B / HEIGHT)[:, None].astype(np.float32)
    vv, uu = np.mgrid[0:H, 0:W].astype(np.float32)
    right = cv2.remap(tex.astype(np.float32), uu + d, vv, cv2.INTER_CUBIC, borderMode=cv2.BORDER_REFLECT)
    u8 = lambda a: np.clip(np.round(a), 0, 255).astype(np.uint8)  # noqa: E731
    return u8(tex), u8(right)


@pytest.mark.parametrize("weak", [False, True])
def test_a_glint_seen_on_two_passes_never_reaches_t(weak: bool) -> None:
    """A one-view glint (bright in the left image only) on the sea, detected on two passes and then gone:
    it never becomes T (a weak one is not even born)."""
    table = _table()
    box = np.array([192.0, 196.0, 214.0, 204.0])
    for k in range(60):
        left, right = _sea_pair(k)
        glint = 2 <= k < 10
        if glint:
            left[198:202, 200:206] = 255
        boxes = [box] if glint and k % 5 == 0 else ([] if k % 5 == 0 else None)
        tracks = table.step(left, right, k * 100_000_000, 0, boxes, [weak] * len(boxes or []))
        assert all(t.status is not TrackStatus.TRACKING for t in tracks)
    if weak:
        assert table.births == 0


def test_waterline_open_reads_the_bottom_centre() -> None:
    mask = np.ones((H, W), bool)
    mask[200:, :] = False
    assert waterline_open(mask, 100, 140, 200) and not waterline_open(mask, 100, 140, 201)
    table = _table(mask)
    assert waterline_masked(mask, table.rect, np.array([100.0, 180.0, 140.0, 205.0]))
    assert not waterline_masked(mask, table.rect, BOX)


def test_no_track_is_born_inside_a_mask(recording) -> None:
    path = recording("akashi-crossing", 30)
    with ReplaySource(path) as src:
        pairs, meta = list(src), src.meta
    cal = recording_calibration(path, meta)
    rig = cal.rig
    open_all = np.ones((rig.height, rig.width), bool)
    below = open_all.copy()
    below[rig.height // 2 - 30:] = False  # the sea from a little above the horizon down
    births = {}
    for name, mask in (("open", open_all), ("masked", below)):
        pipe = Pipeline(cal, fps=meta["fps"], search_mask=mask)
        for pair in pairs:
            pipe.step(pair)
        births[name] = (pipe.table.births, pipe.counters.masked)
    assert births["open"][0] >= 1 and births["open"][1] == 0
    assert births["masked"] == (0, births["masked"][1]) and births["masked"][1] >= 1


@pytest.mark.slow
def test_one_track_per_ship_on_akashi_crossing(recording) -> None:
    """The near freighter's bow crosses the far coaster at 33 s: the coaster's point slid onto the bow
    and its track followed it as a second T track on the freighter (30 false T fixes). Now every T fix
    belongs to a ship and no pair has two T tracks on one ship."""
    path = recording("akashi-crossing", 385)
    with ReplaySource(path) as src:
        pairs, meta = list(src), src.meta
    pipe = Pipeline(recording_calibration(path, meta), fps=meta["fps"])
    fixes = {pair.t_ns: pipe.step(pair) for pair in pairs}
    ev = em.evaluate(fixes, load_ships(path, meta), pipe.rect.f_px, pipe.rig.width)
    assert ev.false_fixes == []
    per_pair: dict[tuple[int, int], set[int]] = {}
    for m in ev.matched:
        per_pair.setdefault((m.t_ns, m.ship_id), set()).add(m.track_id)
    assert all(len(ids) == 1 for ids in per_pair.values())
    assert sum(m.ship_id == 1 for m in ev.matched) >= 370  # the freighter stays tracked throughout
