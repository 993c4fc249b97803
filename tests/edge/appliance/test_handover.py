"""The capture hand-over: the newest pair wins, drops are counted, a source without pacing loses nothing."""

from __future__ import annotations


def test_capture_queue_keeps_the_newest_pair_and_counts_drops() -> None:
    import numpy as np

    from drivers.camera.base import FramePair
    from edge.appliance.handover import LatestPair

    q = LatestPair()
    img = np.zeros((4, 4), np.uint8)
    for k in range(3):
        q.put(FramePair(img, img, k, k, k, k, k))
    got = q.get(0.1)
    assert got is not None and got[0].t_ns == 2 and q.dropped == 2 and got[1] > 0
    assert q.get(0.01) is None and not q.ended
    q.end()
    assert q.get(1.0) is None and q.ended
