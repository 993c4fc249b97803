"""ACN in through a real pty (socat): an operator's acknowledgement reaches the alert, garbage is
counted (edge.outputs.nmea_serial with accept_acn, drivers.serial_port read_lines)."""

from __future__ import annotations

import os
import time
from pathlib import Path

import socat_pty

from edge.alerts.manager import AlertManager, AlertState
from edge.alerts.port import PortAlerts
from edge.config.alerts import AlertsConfig
from edge.encode.nmea import checksum
from edge.fix import ShipFix, TrackStatus
from edge.outputs.nmea_serial import NmeaSerialOutput

T0_NS = 1_790_000_000_000_000_000


def _fix(track_id: int) -> ShipFix:
    return ShipFix(T0_NS, track_id, TrackStatus.TRACKING, 0.0, 0.0, 1000.0, 1000.0, 10.0, 34.6, 135.0,
                   5.0, 0.0, 10.0, 5.0)


def test_acn_over_a_pty_acknowledges_the_alert(tmp_path: Path) -> None:
    with socat_pty.SocatPair(tmp_path) as pair:
        now = [0.0]
        cfg = AlertsConfig(enabled=True)
        manager = AlertManager(cfg, 32)
        out = NmeaSerialOutput(str(pair.a), baud=38400, read_lines=True, clock=lambda: now[0])
        out.scheduler.alerts = PortAlerts(manager, cfg)
        out.start()
        try:
            opened = time.monotonic() + 5.0  # input sent before the port is open may be lost
            while not out.port.stats().connected and time.monotonic() < opened:
                time.sleep(0.01)
            manager.step([_fix(1)], T0_NS)
            out.publish([_fix(1)])  # the new-target alert 192 for target 01
            body = "IIACN,000000.00,,192,1,A,C"
            fd = os.open(pair.b, os.O_RDWR | os.O_NOCTTY)
            try:
                os.write(fd, b"$GPXXX,noise*00\r\n" + f"${body}*{checksum(body)}\r\n".encode())
                deadline = time.monotonic() + 5.0
                while time.monotonic() < deadline and out.scheduler.alerts.counts["acn_applied"] == 0:
                    time.sleep(0.05)
                    now[0] += 0.05
                    out.publish([_fix(1)])
            finally:
                os.close(fd)
        finally:
            out.close()
        counts = out.scheduler.alerts.counts
        assert counts["acn_applied"] == 1 and counts["received_ignored"] == 1
        assert not [a for a in manager.active() if a.state is AlertState.ACTIVE_UNACK]
        _, counters = out.health()
        assert counters["serial_received"] == 2
