"""The AIS stage end to end on synthetic fixes: AIS lines from pyais's encoder at positions
computed with the site's own geodesy, fixes at the same ships; names, MMSI, the dark flag, the
monitor recovering an injected disparity and bearing offset (known answer), and garbage on the
input that never stops the tracking."""

from __future__ import annotations

import dataclasses
import math
import random

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from pyais import encode_dict

from drivers.ais_input import VirtualAisInput
from edge.ais.live import LiveAis
from edge.ais.monitor import OffsetEstimator, huber_mean
from edge.ais.stage import AisStage
from edge.config.ais import AisConfig
from edge.core.geo import world_to_latlon
from edge.core.site import Site
from edge.fix import ShipFix, TrackStatus

SITE = Site(34.63, 135.02, 25.0, 180.0)
F_PX, B_M = 2600.0, 8.14
S = 1_000_000_000


def ais_position(mmsi: int, x: float, z: float, sog_kn: float = 0.0, cog_deg: float = 0.0) -> list[str]:
    lat, lon, _ = world_to_latlon(np.array([x, 0.0, z]), SITE)
    return encode_dict(
        {
            "type": 1,
            "mmsi": mmsi,
            "lat": float(lat),
            "lon": float(lon),
            "speed": sog_kn,
            "course": cog_deg,
            "heading": int(cog_deg),
            "accuracy": 1,
        },
        talker_id="AI",
        sentence_type="VDM",
    )


def fix(tid: int, t_ns: int, x: float, z: float, d_offset: float = 0.0, b_offset: float = 0.0) -> ShipFix:
    r = math.hypot(x, z)
    brg = (SITE.heading_deg + math.degrees(math.atan2(x, z)) + b_offset) % 360.0
    d = F_PX * B_M / z + d_offset
    lat, lon, _ = world_to_latlon(np.array([x, 0.0, z]), SITE)
    return ShipFix(
        t_ns,
        tid,
        TrackStatus.TRACKING,
        x,
        0.0,
        z,
        r,
        brg,
        float(lat),
        float(lon),
        None,
        None,
        r * r * 0.05 / (F_PX * B_M),
        d,
    )


def test_huber_mean_known_answer_and_outlier() -> None:
    x = np.array([1.0, 1.2, 0.8, 1.1, 0.9, 50.0])
    mu, sd = huber_mean(x, np.full(6, 0.1))
    assert abs(mu - 1.0) < 0.1 and sd > 0.0  # the outlier moves the mean by < 0.1, not by 8
    e = OffsetEstimator(0.05, 3.0, 5)
    for k in range(30):
        e.add(k % 3, 0.09 + 0.01 * math.sin(k), 0.02)
    est = e.estimate()
    assert abs(est.value - 0.09) < 0.01 and est.fault and est.ships == 3


@given(offset=st.floats(-0.2, 0.2), bearing=st.floats(-0.5, 0.5))
@settings(max_examples=6, deadline=None)
def test_monitor_recovers_injected_offsets(offset: float, bearing: float) -> None:
    stage = AisStage(AisConfig(), SITE, F_PX, B_M)
    stage.start(0)
    for k in range(0, 300, 10):  # a stationary ship at 2 km (no static data: antenna = the point)
        for line in ais_position(431000001, 100.0, 2000.0):
            stage.feed(k * S, line)
        stage.annotate([fix(1, k * S + 500_000_000, 100.0, 2000.0, offset, bearing)])
    d, b = stage.estimates()
    assert d.value is not None and abs(d.value - offset) < 0.005  # lat/lon resolution: 0.2 m at 2 km
    assert b.value is not None and abs(b.value - bearing) < 0.003
    enough = d.reports >= 20
    assert d.fault == (enough and abs(d.value) - 3.0 * (d.sigma or 0.0) > 0.05)
    assert b.fault == (enough and abs(b.value) - 3.0 * (b.sigma or 0.0) > 0.1)
    assert (stage.fault() is not None) == (d.fault or b.fault)


def test_names_mmsi_and_dark() -> None:
    stage = AisStage(AisConfig(confirm_s=0.0, dark_after_s=10.0, warmup_s=0.0), SITE, F_PX, B_M)
    stage.start(0)
    static = encode_dict(
        {
            "type": 5,
            "mmsi": 431000002,
            "shipname": "AKASHI MARU",
            "to_bow": 10,
            "to_stern": 10,
            "to_port": 3,
            "to_starboard": 3,
        },
        talker_id="AI",
        sentence_type="VDM",
        seq_id=1,
    )
    for line in static:
        stage.feed(0, line)
    named = unnamed = dark = None
    for k in range(0, 30):
        t = k * S
        if k % 10 == 0:
            for line in ais_position(431000002, -200.0, 900.0) + ais_position(431000003, 200.0, 900.0):
                stage.feed(t, line)
        out = stage.annotate([fix(1, t, -200.0, 900.0), fix(2, t, 200.0, 900.0), fix(3, t, 0.0, 600.0)])
        named, unnamed, dark = out
    assert (named.ais_mmsi, named.ais_name, named.dark) == (431000002, "AKASHI MARU", False)
    assert (unnamed.ais_mmsi, unnamed.ais_name, unnamed.dark) == (431000003, None, False)
    assert dark.ais_mmsi is None and dark.dark


def test_garbage_on_the_input_never_stops_tracking() -> None:
    rng = random.Random(5)
    source = VirtualAisInput(max_lines=20_000)
    live = LiveAis(AisConfig(), SITE, F_PX, B_M, source=source)
    live.start(0)
    try:
        good = ais_position(431000004, 0.0, 1000.0)[0]
        chunks = []
        for _ in range(10_000):
            kind = rng.random()
            if kind < 0.3:
                chunks.append(bytes(rng.getrandbits(8) for _ in range(rng.randint(1, 90))) + b"\n")
            elif kind < 0.6:
                chunks.append(good[: rng.randint(1, len(good))].encode() + b"\n")
            elif kind < 0.8:
                chunks.append(good.replace(",1,1,", ",3,2,7,", 1).encode() + b"\r\n")
            else:
                chunks.append(good[:-1].encode() + b"F\n")
        for i in range(0, len(chunks), 500):
            source.push(b"".join(chunks[i : i + 500]))
        deadline = 200
        steps = 0
        while steps < deadline and (source.stats().lines < 9000 or steps < 3):
            out = live.step([fix(1, steps * S, 0.0, 1000.0)], None, None)
            assert len(out) == 1 and out[0].track_id == 1  # the fix always comes through
            steps += 1
            import time

            time.sleep(0.01)
        live.step([fix(1, steps * S, 0.0, 1000.0)], None, None)
        c = live.stage.counters
        assert c.lines >= 9000 and live.failures == 0
        assert c.checksum_errors + c.malformed + c.incomplete > 5000
    finally:
        live.close()


def test_no_track_is_dark_while_the_receiver_is_gone() -> None:
    """An unplugged receiver is not a harbour without AIS: no dark flag until it is back and the
    warm-up has run again; then the boat without AIS turns dark."""
    import time

    cfg = AisConfig(confirm_s=0.0, dark_after_s=2.0, warmup_s=1.0)
    now_ns = [0]
    source = VirtualAisInput(clock=lambda: now_ns[0])  # lines stamped on the fixes' clock
    live = LiveAis(cfg, SITE, F_PX, B_M, source=source)
    source.set_present(False)
    live.start(0)
    try:
        deadline = time.monotonic() + 5.0
        while source.stats().fault is None and time.monotonic() < deadline:
            time.sleep(0.01)
        assert source.stats().fault is not None
        for k in range(100):  # 10 s of a boat nobody's AIS covers, receiver gone
            assert not live.step([fix(1, k * S, 0.0, 800.0)], None, None)[0].dark
        source.set_present(True)
        deadline = time.monotonic() + 10.0
        while source.stats().fault is not None and time.monotonic() < deadline:
            time.sleep(0.05)
        assert source.stats().fault is None
        now_ns[0] = 100 * S
        source.push((ais_position(431000006, 500.0, 2000.0)[0] + "\n").encode())
        deadline = time.monotonic() + 5.0
        while source.stats().lines == 0 and time.monotonic() < deadline:
            time.sleep(0.01)
        darks = []
        for k in range(100, 200):
            darks.append(live.step([fix(1, k * S, 0.0, 800.0)], None, None)[0].dark)
        assert darks[0] is False and darks[-1] is True  # dark again once the input runs
    finally:
        live.close()


def test_a_lost_track_keeps_its_identity() -> None:
    stage = AisStage(AisConfig(confirm_s=0.0), SITE, F_PX, B_M)
    stage.start(0)
    for line in ais_position(431000005, 0.0, 800.0):
        stage.feed(0, line)
    assert stage.annotate([fix(1, S, 0.0, 800.0)])[0].ais_mmsi == 431000005
    lost = dataclasses.replace(fix(1, 2 * S, 0.0, 800.0), status=TrackStatus.LOST)
    assert stage.annotate([lost])[0].ais_mmsi == 431000005
