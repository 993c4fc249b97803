"""Alerts through the appliance's fan-out (edge.outputs.fanout) as configured: the serial port's
ALF and the Modbus alert block read by mbpoll from a real Modbus TCP server."""

from __future__ import annotations

import re
import subprocess
import time

from helpers import free_port

from edge.alerts.manager import AlertManager
from edge.appliance.health import HealthMonitor, Status, standard_stages
from edge.config.alerts import AlertsConfig
from edge.config.app import ModbusConfig, ModbusTcp, NmeaPort, OutputsConfig
from edge.fix import ShipFix, TrackStatus
from edge.outputs.fanout import Outputs, output_stages
from edge.outputs.nmea_serial import NmeaSerialOutput

T0_NS = 1_790_000_000_000_000_000
COV = (25.0, 0, 0, 0, 0, 25.0, 0, 0, 0, 0, 0.01, 0, 0, 0, 0, 0.01)
CLOSING = {4: (0.0, 0.0, 0.0, 3.0), 9: (100.0, 1800.0, 0.0, -3.0)}


def fix(track_id: int, t_s: float) -> ShipFix:
    e, n, ve, vn = CLOSING[track_id]
    return ShipFix(
        T0_NS + round(t_s * 1e9),
        track_id,
        TrackStatus.TRACKING,
        0.0,
        0.0,
        1000.0,
        1000.0,
        10.0,
        34.6,
        135.0,
        5.8,
        0.0,
        10.0,
        5.0,
        length_m=80.0,
        en_state=(e + ve * t_s, n + vn * t_s, ve, vn),
        en_cov=COV,
    )


def mbpoll(port: int, start: int, count: int) -> dict[int, int]:
    out = subprocess.run(
        [
            "mbpoll",
            "-1",
            "-0",
            "-o",
            "0.5",
            "-m",
            "tcp",
            "-p",
            str(port),
            "-t",
            "3",
            "-r",
            str(start),
            "-c",
            str(count),
            "127.0.0.1",
        ],
        capture_output=True,
        text=True,
        timeout=20,
    )
    assert out.returncode == 0, out.stdout + out.stderr
    return {int(a): int(v) for a, v in re.findall(r"^\[(\d+)\]:\s+(-?\d+)", out.stdout, re.M)}


def test_alert_reaches_nmea_and_modbus() -> None:
    port = free_port()
    cfg = OutputsConfig(
        nmea=(NmeaPort(url="loop://"),),
        modbus=ModbusConfig(tcp=ModbusTcp(enabled=True, host="127.0.0.1", port=port)),
    )
    health = HealthMonitor(standard_stages(output_stages(cfg)))
    health.set_flags(Status.CALIBRATION_VALID)  # as the daemon does once the calibration loaded
    manager = AlertManager(AlertsConfig(enabled=True), 32)  # the chain steps it; the outputs render it
    outputs = Outputs.from_config(cfg, health, max_tracks=32, alerts=manager)
    outputs.start()
    serial = next(o for o in outputs.outputs if isinstance(o, NmeaSerialOutput))
    opened = time.monotonic() + 5.0  # a port not yet open is a health fault: HBT would say V
    while not serial.port.stats().connected and time.monotonic() < opened:
        time.sleep(0.01)
    try:
        for t in range(12):
            for stage in ("camera_left", "camera_right", "processing"):  # as the daemon's threads do
                health.beat(stage, frames=1)
            fixes = [fix(4, t), fix(9, t)]
            manager.step(fixes, T0_NS + t * 10**9, health.snapshot())  # as Chain.step does
            outputs.publish(fixes, T0_NS + t * 10**9)
        header = mbpoll(port, 60, 5)
        block = mbpoll(port, 900, 4)
        slots = mbpoll(port, 910, 16 * 4)
    finally:
        outputs.close()
    assert header[60] == 3 and header[63] == 2 and header[64] == 900  # 2 new targets + close quarters
    assert block == {900: 3, 901: 16, 902: 910, 903: 16}
    first = {k - 910: v for k, v in slots.items() if k < 926}  # the most urgent: the alarm
    assert first[0] == 191 and first[2] == 102 and first[3] == 1 and first[4] == 1
    assert (first[6], first[7], first[9], first[11]) == (1, 2, 4, 9)  # numbers, track ids (low words)
    assert first[12] == 100 and 270 <= first[13] <= 295  # CPA 100 m, TCPA 300 - t
    serial_counts = {s.name: s.counters for s in health.snapshot().stages}["nmea"]
    assert (
        serial_counts["alf_sent"] >= 3 and serial_counts["alc_sent"] == 1 and serial_counts["hbt_sent"] == 1
    )
    serial = next(o for o in outputs.outputs if isinstance(o, NmeaSerialOutput))
    assert serial.scheduler.alert_groups_sent >= 5


def test_camera_lost_alert_and_hbt_v_while_no_pair_comes() -> None:
    """Chain.idle + publish_health (the daemon's calls while no pair arrives) raise camera lost after
    confirm_s and keeps HBT going, with V, on the serial line."""
    from drivers.serial_port import VirtualSerialPort
    from edge.alerts.manager import AlertManager
    from edge.alerts.port import PortAlerts

    now = [0.0]
    health = HealthMonitor(standard_stages([("nmea", Status.NMEA_ACTIVE)]), clock=lambda: now[0])
    health.set_flags(Status.CALIBRATION_VALID)
    cfg = AlertsConfig(enabled=True, heartbeat_s=1)
    manager = AlertManager(cfg, 32)
    port = VirtualSerialPort()
    serial = NmeaSerialOutput("virtual", port=port, clock=lambda: now[0])
    serial.scheduler.alerts = PortAlerts(manager, cfg)
    outputs = Outputs([serial], health, manager)
    outputs.start()
    try:
        for k in range(80):  # 8 s at 0.1 s: the right camera beats, the left is gone
            now[0] = k / 10
            health.beat("camera_right", frames=1)
            health.beat("processing")
            manager.health_step(T0_NS + k * 10**8, health.snapshot())  # as Chain.idle does
            outputs.publish_health([], T0_NS + k * 10**8)
        deadline = now[0]
        assert deadline == 7.9
        data = b""
        for _ in range(100):
            data = port.data()
            if b",10002,1," in data:
                break
            time.sleep(0.02)
    finally:
        outputs.close()
    lines = data.decode().splitlines()
    assert any(",B,W,V,XXX,10002,1,1,0,CAMERA LEFT LOST" in line for line in lines)
    hbt = [line for line in lines if line.startswith("$RAHBT")]
    assert len(hbt) >= 7 and all(",V," in line for line in hbt)
