"""drivers.udp: datagrams reach a real multicast receiver on loopback; failures are counted, logged once."""

from __future__ import annotations

import logging
import socket
import struct

import pytest

from drivers.udp import MulticastUdpSender, VirtualUdpSender

GROUP = "239.192.0.2"
LOGGER = "drivers.udp"


def multicast_receiver(group: str = GROUP) -> tuple[socket.socket, int]:
    """A socket joined to `group` on the loopback interface, bound to a free port."""
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM, socket.IPPROTO_UDP)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    sock.bind((group, 0))
    membership = struct.pack("4s4si", socket.inet_aton(group), bytes(4), socket.if_nametoindex("lo"))
    sock.setsockopt(socket.IPPROTO_IP, socket.IP_ADD_MEMBERSHIP, membership)
    sock.settimeout(2.0)
    return sock, sock.getsockname()[1]


@pytest.mark.parametrize("interface", ["lo", "127.0.0.1"])
def test_multicast_datagrams_reach_a_receiver_on_loopback(interface: str) -> None:
    receiver, port = multicast_receiver()
    sender = MulticastUdpSender(GROUP, port, interface=interface, ttl=0)
    try:
        payloads = [b"UdPbC\x00one", b"UdPbC\x00two"]
        assert all(sender.send(p) for p in payloads)
        assert [receiver.recv(2048) for _ in payloads] == payloads
    finally:
        sender.close()
        receiver.close()
    stats = sender.stats()
    assert (stats.sent_datagrams, stats.sent_bytes, stats.errors, stats.fault) == (2, 18, 0, False)


def test_unicast_destination_works_too() -> None:
    receiver = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    receiver.bind(("127.0.0.1", 0))
    receiver.settimeout(2.0)
    sender = MulticastUdpSender("127.0.0.1", receiver.getsockname()[1])
    assert sender.send(b"UdPbC\x00x") and receiver.recv(100) == b"UdPbC\x00x"
    assert not sender.multicast
    sender.close()
    receiver.close()


def test_missing_interface_is_counted_logged_once_and_never_raises(caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.INFO, logger=LOGGER)
    now = [0.0]
    sender = MulticastUdpSender(
        GROUP, 60002, interface="nosuchif0", retry_initial_s=1.0, clock=lambda: now[0]
    )
    results = []
    for step in range(40):  # 4 s at 10 Hz
        now[0] = step / 10
        results.append(sender.send(b"x"))
    stats = sender.stats()
    assert not any(results) and stats.dropped == 40 and stats.fault and not sender.healthy
    assert stats.errors == 3  # tried at 0 s, 1 s (after 1 s backoff) and 3 s (after 2 s), not 40 times
    assert [r.levelname for r in caplog.records if r.name == LOGGER] == ["WARNING"]
    with pytest.raises(ValueError):
        MulticastUdpSender("not-an-address", 1)


def test_virtual_sender_recovers_after_the_backoff(caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.INFO, logger=LOGGER)
    now = [0.0]
    sender = VirtualUdpSender(retry_initial_s=0.5, clock=lambda: now[0])
    assert sender.send(b"a")
    sender.set_present(False)
    assert not sender.send(b"b") and not sender.send(b"c")  # c: inside the backoff, not even tried
    sender.set_present(True)
    assert not sender.send(b"d")
    now[0] = 0.5
    assert sender.send(b"e")
    stats = sender.stats()
    assert sender.datagrams == [b"a", b"e"]
    assert (stats.errors, stats.dropped, stats.reconnects, stats.fault) == (1, 3, 1, False)
    assert [r.levelname for r in caplog.records if r.name == LOGGER] == ["WARNING", "INFO"]
