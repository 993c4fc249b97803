"""ASTERIX output: track numbers and TRE, status from the health (NOGO, TSV, OVL; event on change),
network faults counted and retried, the start-time checks, and datagrams that went over a real
loopback UDP socket decoded by tshark (an independent dissector) with no Malformed packet."""

from __future__ import annotations

import dataclasses
import shutil
import socket
import struct
import subprocess
from pathlib import Path

import pytest

from drivers.udp import MulticastUdpSender, VirtualUdpSender
from edge.appliance.health import HealthMonitor, Stage, Status
from edge.config.app import OutputsConfig
from edge.config.asterix import AsterixConfig, AsterixDestination, check_asterix
from edge.encode.asterix.blocks import MAX_BLOCK_BYTES
from edge.errors import ConfigError
from edge.fix import ShipFix, TrackStatus
from edge.outputs.asterix import AsterixOutput
from edge.outputs.fanout import Outputs

asterix = pytest.importorskip("asterix")  # asterix-decoder (GPL): test extra only
T0_NS = 1_700_000_000 * 10**9


def fix(track_id: int, t_s: float, status: TrackStatus = TrackStatus.TRACKING) -> ShipFix:
    return ShipFix(T0_NS + round(t_s * 1e9), track_id, status, 0.0, 0.0, 0.0, 1000.0 + 10 * track_id,
                   45.0 + track_id, 34.6 + 1e-3 * track_id, 135.0, 8.0, 90.0, 5.0, 20.0, sigma_across_m=0.4)


class Clock:
    def __init__(self) -> None:
        self.s = 0.0

    def __call__(self) -> float:
        return self.s


def records(blocks: list[bytes]) -> list[dict]:
    return [r for b in blocks for r in asterix.parse(b, verbose=False)]


def reports(blocks: list[bytes]) -> list[dict]:
    return [r for r in records(blocks) if r["category"] == 10 and r["I000"]["MsgTyp"]["val"] == 1]


def test_numbers_stay_with_their_tracks_and_the_last_report_has_tre() -> None:
    clock, sender = Clock(), VirtualUdpSender()
    out = AsterixOutput(AsterixConfig(enabled=True), tracks=sender, clock=clock)
    seen: dict[int, set[int]] = {}
    for k in range(30):
        clock.s = 0.1 * k
        alive = [1, 2] + ([3] if k < 10 else []) + ([4] if k >= 20 else [])
        status = {1: TrackStatus.TRACKING, 2: TrackStatus.ACQUIRING if k < 5 else TrackStatus.TRACKING,
                  3: TrackStatus.LOST, 4: TrackStatus.TRACKING}
        for r in reports(out.publish([fix(t, clock.s, status[t]) for t in alive], T0_NS)):
            seen.setdefault(r["I020"]["TYP"]["val"], set()).add(r["I161"]["TrkNb"]["val"])
    assert set(seen) == {3}  # PSR by default
    out.close()
    got = reports(sender.datagrams)
    by_number: dict[int, list[dict]] = {}
    for r in got:
        by_number.setdefault(r["I161"]["TrkNb"]["val"], []).append(r)
    assert len(by_number) == 4  # four tracks, four numbers, none reused
    for rs in by_number.values():
        assert [r["I170"]["TRE"]["val"] for r in rs] == [0] * (len(rs) - 1) + [1]  # TRE last, only there
    n3 = out.ended[0][1]
    assert out.ended[0][0] == 3 and by_number[n3][-1]["I170"]["CST"]["val"] == 3  # coasting (L)
    tentative = [r["I170"]["CNF"]["val"] for r in got if r["I161"]["TrkNb"]["val"] == dict(out.ended)[2]]
    assert tentative[:5] == [1] * 5 and set(tentative[5:]) == {0}
    fault, counters = out.health()
    assert fault is None and counters["asterix_fixes_in"] == counters["asterix_fixes_reported"] == 80
    assert counters["asterix_tracks_ended"] == 4 and counters["asterix_udp_dropped"] == 0


def test_a_track_that_comes_back_keeps_its_number_and_new_ones_do_not_take_it() -> None:
    clock = Clock()
    out = AsterixOutput(AsterixConfig(enabled=True), clock=clock)
    first = reports(out.publish([fix(1, 0.0)], T0_NS))[0]["I161"]["TrkNb"]["val"]
    clock.s = 1.0
    ended = reports(out.publish([fix(2, 1.0)], T0_NS))  # 1 gone: its TRE, 2 new
    assert [r["I170"]["TRE"]["val"] for r in ended] == [1, 0] and ended[1]["I161"]["TrkNb"]["val"] != first
    clock.s = 2.0
    back = reports(out.publish([fix(1, 2.0), fix(2, 2.0), fix(3, 2.0)], T0_NS))
    numbers = [r["I161"]["TrkNb"]["val"] for r in back]
    assert numbers[0] == first and len(set(numbers)) == 3


def health_with(clock: Clock) -> HealthMonitor:
    return HealthMonitor([Stage("camera_left", 1, 2.0), Stage("processing", 3, 2.0)], clock=clock)


def status_of(blocks: list[bytes]) -> list[tuple[int, int, int, int]]:
    return [(r["I000"]["MsgTyp"]["val"], r["I550"]["NOGO"]["val"], r["I550"]["OVL"]["val"],
             r["I550"]["TSV"]["val"]) for r in records(blocks) if r["category"] == 10 and "I550" in r]


def test_status_follows_the_health_at_once_and_periodically() -> None:
    clock = Clock()
    health = health_with(clock)
    health.set_flags(Status.TIME_SYNC)
    out = AsterixOutput(AsterixConfig(enabled=True, cat034=True), health=health.snapshot, clock=clock,
                        site=(34.6, 135.0, 40.0))
    health.beat("camera_left", frames=1)
    health.beat("processing", frames=1)
    first = out.publish_status(T0_NS)
    assert status_of(first) == [(3, 0, 0, 0)] and records(first)[-1]["category"] == 34
    clock.s = 0.5
    assert out.publish_status(T0_NS) == []  # nothing changed, the period has not passed
    clock.s = 3.0  # the camera has been silent for 3 s: STALLED -> NOGO now (event, then periodic)
    health.beat("processing", frames=1)
    assert status_of(out.publish_status(T0_NS)) == [(4, 2, 0, 0), (3, 2, 0, 0)]
    clock.s = 3.2
    health.beat("camera_left", frames=1)  # replugged: cleared at once
    assert status_of(out.publish_status(T0_NS)) == [(4, 0, 0, 0)]
    clock.s = 3.3
    health.set_flags(Status.TIME_SYNC, False)  # clock not synchronised: TSV
    health.beat("processing", frames=1, counters={"dropped_pairs": 2})  # pairs dropped: OVL
    assert status_of(out.publish_status(T0_NS)) == [(4, 0, 1, 1)]
    clock.s = 3.4
    health.beat("processing", frames=1, counters={"dropped_pairs": 2})  # no more drops: OVL clears
    assert status_of(out.publish_status(T0_NS)) == [(4, 0, 0, 1)]


def test_a_network_fault_is_counted_shown_and_retried() -> None:
    clock = Clock()
    sender = VirtualUdpSender(clock=clock, retry_initial_s=0.5)
    out = AsterixOutput(AsterixConfig(enabled=True), tracks=sender, clock=clock)
    out.publish([fix(1, 0.0)], T0_NS)
    sender.set_present(False)
    for k in range(1, 6):
        clock.s = 0.1 * k
        out.publish([fix(1, clock.s)], T0_NS)  # never raises, never blocks
    fault, counters = out.health()
    assert fault is not None and counters["asterix_udp_errors"] >= 1 and counters["asterix_udp_dropped"] >= 5
    sender.set_present(True)
    clock.s = 2.0
    out.publish([fix(1, 2.0)], T0_NS)
    fault, counters = out.health()
    assert fault is None and sender.stats().reconnects == 1
    assert counters["asterix_udp_datagrams"] + counters["asterix_udp_dropped"] == out.counts["blocks"]


def test_start_checks_name_the_key() -> None:
    bad = AsterixConfig(enabled=True, tracks=AsterixDestination(interface="no-such-if0"))
    with pytest.raises(ConfigError, match=r"outputs\.asterix\.tracks\.interface"):
        check_asterix(bad, "mast.yaml")
    unicast = AsterixConfig(enabled=True, status=AsterixDestination(address="127.0.0.1", interface="lo"))
    with pytest.raises(ConfigError, match=r"outputs\.asterix\.status\.interface"):
        check_asterix(unicast, "mast.yaml")
    foreign = AsterixConfig(enabled=True, tracks=AsterixDestination(interface="192.0.2.254"))
    with pytest.raises(ConfigError, match="local IPv4 address"):
        check_asterix(foreign, "mast.yaml")
    check_asterix(AsterixConfig(enabled=True, tracks=AsterixDestination(interface="lo")), "mast.yaml")
    check_asterix(AsterixConfig(enabled=True, tracks=AsterixDestination(interface="127.0.0.1")), "mast.yaml")


def test_fanout_builds_it_and_beats_its_stage() -> None:
    from edge.appliance.health import standard_stages
    from edge.outputs.fanout import output_stages

    cfg = dataclasses.replace(OutputsConfig(), asterix=AsterixConfig(
        enabled=True, tracks=AsterixDestination(address="127.0.0.1", port=9)))
    cfg = dataclasses.replace(cfg, modbus=dataclasses.replace(cfg.modbus, tcp=dataclasses.replace(
        cfg.modbus.tcp, enabled=False)))
    health = HealthMonitor(standard_stages(output_stages(cfg)))
    fanout = Outputs.from_config(cfg, health, max_tracks=32, site_lat_deg=34.6, site_lon_deg=135.0)
    (out,) = fanout.outputs
    assert isinstance(out, AsterixOutput)
    fanout.publish([fix(1, 0.0)], T0_NS)
    fanout.publish_health([], T0_NS)
    stage = next(s for s in health.snapshot().stages if s.name == "asterix")
    assert stage.fresh and stage.counters["asterix_fixes_reported"] == 1
    fanout.close()


def _pcap(datagrams: list[tuple[bytes, int, int]]) -> bytes:
    """A classic pcap (LINKTYPE_RAW: IPv4 packets) holding the received datagrams as UDP packets."""
    out = [struct.pack("<IHHiIII", 0xA1B2C3D4, 2, 4, 0, 0, 65535, 101)]
    for k, (payload, sport, dport) in enumerate(datagrams):
        udp = struct.pack(">HHHH", sport, dport, 8 + len(payload), 0) + payload
        ip = struct.pack(">BBHHHBBH4s4s", 0x45, 0, 20 + len(udp), k & 0xFFFF, 0, 64, 17, 0,
                         socket.inet_aton("127.0.0.1"), socket.inet_aton("127.0.0.1"))
        csum = sum(struct.unpack(">10H", ip))
        csum = (csum & 0xFFFF) + (csum >> 16)
        ip = ip[:10] + struct.pack(">H", ~((csum & 0xFFFF) + (csum >> 16)) & 0xFFFF) + ip[12:]
        packet = ip + udp
        out.append(struct.pack("<IIII", 1_700_000_000 + k, 0, len(packet), len(packet)) + packet)
    return b"".join(out)


@pytest.mark.skipif(shutil.which("tshark") is None, reason="tshark not installed (tools/_setup.sh)")
def test_tshark_decodes_what_went_over_a_real_socket(tmp_path: Path) -> None:
    receiver = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    receiver.bind(("127.0.0.1", 0))
    receiver.settimeout(2.0)
    port = receiver.getsockname()[1]
    clock = Clock()
    out = AsterixOutput(AsterixConfig(enabled=True, start_of_update=True, cat034=True),
                        tracks=MulticastUdpSender("127.0.0.1", port), clock=clock, site=(34.6, 135.0, 40.0))
    sent = []
    for k in range(12):  # 40 tracks: two blocks a step; one ends half way (TRE)
        clock.s = 0.25 * k
        sent += out.publish([fix(t, clock.s) for t in range(1, 41) if t != 7 or k < 6], T0_NS)
    out.close()
    got = []
    try:
        while True:  # until the sent blocks and the close's TRE blocks are all in
            payload, (_, sport) = receiver.recvfrom(65535)
            got.append((payload, sport, port))
            receiver.settimeout(0.5)
    except TimeoutError:
        pass
    receiver.close()
    assert [g[0] for g in got[:len(sent)]] == sent and len(got) == len(sent) + 2  # 39 TREs: two blocks
    assert all(len(g[0]) <= MAX_BLOCK_BYTES for g in got)
    capture = tmp_path / "asterix.pcap"
    capture.write_bytes(_pcap(got))
    run = subprocess.run(["tshark", "-r", str(capture), "-d", f"udp.port=={port},asterix", "-T", "fields",
                          "-e", "_ws.malformed", "-e", "_ws.expert", "-e", "asterix.category",
                          "-e", "asterix.010_161_TRK", "-e", "asterix.010_170_TRE"],
                         capture_output=True, text=True, timeout=60, check=True)
    lines = run.stdout.splitlines()
    assert len(lines) == len(got) and "Malformed" not in run.stdout + run.stderr
    assert all(not line.split("\t")[0] for line in lines)  # no _ws.malformed in any packet
    numbers = {int(n) for line in lines for n in line.split("\t")[3].split(",") if n}
    assert len(numbers) == 40
    assert sum(line.split("\t")[4].split(",").count("1") for line in lines) == 40  # one TRE per track
