"""sd_notify driver: message format, the watchdog interval systemd asks for, and a real socket."""

from __future__ import annotations

import socket
from pathlib import Path

import pytest

from drivers.notify import Notifier, SystemdNotifier, VirtualNotifier


def test_messages_are_sd_notify_lines() -> None:
    n = VirtualNotifier()
    n.ready("running:\n two lines")
    n.watchdog()
    n.stopping()
    assert n.messages == ["READY=1\nSTATUS=running: two lines", "WATCHDOG=1", "STOPPING=1"]


@pytest.mark.parametrize("usec, pid, expected", [
    ("4000000", None, 2.0), ("4000000", "self", 2.0), ("4000000", "1", None), (None, None, None),
    ("0", None, None), ("junk", None, None),
])
def test_watchdog_interval_is_half_of_watchdogsec_for_us_only(monkeypatch, usec, pid, expected) -> None:
    import os

    monkeypatch.delenv("WATCHDOG_USEC", raising=False)
    monkeypatch.delenv("WATCHDOG_PID", raising=False)
    if usec is not None:
        monkeypatch.setenv("WATCHDOG_USEC", usec)
    if pid is not None:
        monkeypatch.setenv("WATCHDOG_PID", str(os.getpid()) if pid == "self" else pid)
    assert Notifier.watchdog_interval_s() == expected


def test_systemd_notifier_delivers_to_a_real_datagram_socket(tmp_path: Path, monkeypatch) -> None:
    path = str(tmp_path / "notify")
    with socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM) as sock:
        sock.bind(path)
        sock.settimeout(5.0)
        monkeypatch.setenv("NOTIFY_SOCKET", path)
        n = SystemdNotifier()
        assert n.ready("up")
        assert sock.recv(1024) == b"READY=1\nSTATUS=up"
        monkeypatch.delenv("NOTIFY_SOCKET")
        assert not n.watchdog()  # outside systemd: nothing sent, and it says so
