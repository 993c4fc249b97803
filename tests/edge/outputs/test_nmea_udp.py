"""edge.outputs.nmea_udp: IEC 61162-450 datagrams received by a real multicast socket and decoded here.

The tag block is checked with an XOR written in this test, not with
edge.encode.nmea, and the sentence inside with pynmea2.
"""

from __future__ import annotations

import functools
import math
import operator
import re
import socket
import struct

import pynmea2
import pytest

from drivers.udp import VirtualUdpSender
from edge.encode.nmea import tll, ttm
from edge.fix import ShipFix, TrackStatus
from edge.outputs.nmea_udp import NmeaUdpOutput
from edge.outputs.schedule import NmeaSchedule

GROUP = "239.192.0.2"
TAG_BLOCK = re.compile(rb"UdPbC\x00\\(?P<body>[^*\\]*)\*(?P<cs>[0-9A-F]{2})\\(?P<sentence>\$[^\r\n]*\r\n)")


def fix(track_id: int, t_s: float = 0.0) -> ShipFix:
    bearing = 30.0 * track_id
    lat, lon = 53.54 + 0.018 * math.cos(math.radians(bearing)), 9.96 + 0.03 * math.sin(math.radians(bearing))
    return ShipFix(
        t_ns=1_780_000_000 * 10**9 + int(t_s * 1e9), track_id=track_id, status=TrackStatus.TRACKING,
        x_m=0.0, y_m=0.0, z_m=0.0, range_m=2000.0, bearing_deg=bearing,
        lat_deg=lat, lon_deg=lon,
        sog_kn=7.0, cog_deg=90.0, sigma_m=5.0, disparity_px=2.0,
    )  # fmt: skip


def decode(datagram: bytes) -> tuple[dict[str, str], str]:
    match = TAG_BLOCK.fullmatch(datagram)
    assert match, datagram
    body = match["body"]
    assert f"{functools.reduce(operator.xor, body, 0):02X}".encode() == match["cs"]
    fields = dict(item.split(":", 1) for item in body.decode().split(","))
    return fields, match["sentence"].decode()


def test_a_multicast_receiver_gets_tagged_sentences() -> None:
    receiver = socket.socket(socket.AF_INET, socket.SOCK_DGRAM, socket.IPPROTO_UDP)
    receiver.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    receiver.bind((GROUP, 0))
    membership = struct.pack("4s4si", socket.inet_aton(GROUP), bytes(4), socket.if_nametoindex("lo"))
    receiver.setsockopt(socket.IPPROTO_IP, socket.IP_ADD_MEMBERSHIP, membership)
    receiver.settimeout(2.0)
    out = NmeaUdpOutput(group=GROUP, port=receiver.getsockname()[1], interface="lo", ttl=0, source="RA0042")
    try:
        sent = out.publish([fix(1), fix(2)])
        received = [receiver.recv(2048) for _ in sent]
    finally:
        out.close()
        receiver.close()
    assert received == sent and len(sent) == 4
    decoded = [decode(d) for d in received]
    assert [tags for tags, _ in decoded] == [{"s": "RA0042", "n": str(n)} for n in (1, 2, 3, 4)]
    assert [s for _, s in decoded] == [ttm(fix(1), 1), tll(fix(1), 1), ttm(fix(2), 2), tll(fix(2), 2)]
    assert all(pynmea2.parse(s, check=True) for _, s in decoded)
    assert out.health() == (None, {"udp_datagrams": 4, "udp_dropped": 0, "udp_errors": 0, "nmea_refused": 0,
                                   "nmea_fixes_in": 2, "nmea_fixes_sent": 2, "nmea_fixes_dropped": 0,
                                   "nmea_fixes_pending": 0})


def test_line_counter_wraps_from_999_to_1_and_every_track_is_refreshed_once_per_interval() -> None:
    clock = [0.0]
    sender = VirtualUdpSender()
    out = NmeaUdpOutput(NmeaSchedule(min_refresh_s=1.0), sender=sender, clock=lambda: clock[0])
    for step in range(170 * 3):  # 170 s at 3 steps/s, 3 tracks x 2 sentences per second
        clock[0] = step / 3
        out.publish([fix(i, step / 3) for i in (1, 2, 3)])
    counts = [int(decode(d)[0]["n"]) for d in sender.datagrams]
    assert len(counts) == 170 * 6
    assert counts[:999] == list(range(1, 1000)) and counts[999:] == list(range(1, 1020 - 999 + 1))


def test_from_config_and_bad_source() -> None:
    config = pytest.importorskip("edge.config.app")
    out = NmeaUdpOutput.from_config(
        config.UdpConfig(source="II0007", sentences=("TLL",)), sender=VirtualUdpSender()
    )
    [datagram] = out.publish([fix(3)])
    tags, sentence = decode(datagram)
    assert tags["s"] == "II0007" and sentence.startswith("$IITLL,01,")
    with pytest.raises(ValueError):
        NmeaUdpOutput(source="RA1", sender=VirtualUdpSender())
