"""A port's alert sentences (edge.alerts.port) through the real scheduler: ALF on change, ALC every
30 s, repeats at most 60 s apart, HBT from health, ACN, and alerts first at 4800 baud with a full
track budget."""

from __future__ import annotations

from pynmeagps import NMEAReader

from edge.alerts.manager import AlertManager
from edge.alerts.port import PortAlerts
from edge.config.alerts import AlertsConfig
from edge.encode.nmea import checksum
from edge.fix import ShipFix, TrackStatus
from edge.outputs.nmea_serial import serial_bytes_per_s
from edge.outputs.schedule import NmeaSchedule, NmeaScheduler

T0_NS = 1_790_000_000_000_000_000
COV = (25.0, 0, 0, 0, 0, 25.0, 0, 0, 0, 0, 0.01, 0, 0, 0, 0, 0.01)


def fix(track_id: int, t_s: float, state: tuple[float, float, float, float] | None = None) -> ShipFix:
    en = None if state is None else (state[0] + state[2] * t_s, state[1] + state[3] * t_s, state[2], state[3])
    return ShipFix(T0_NS + round(t_s * 1e9), track_id, TrackStatus.TRACKING, 0.0, 0.0, 1000.0 + track_id,
                   1000.0, 10.0 + track_id, 34.6, 135.0, 5.0, 0.0, 10.0, 5.0, length_m=80.0, en_state=en,
                   en_cov=None if state is None else COV)


CLOSING = {1: (0.0, 0.0, 0.0, 3.0), 2: (100.0, 1800.0, 0.0, -3.0)}


class Rig:
    """Manager + one port's scheduler on a hand-stepped clock."""

    def __init__(self, bytes_per_s: float | None = None, mode: str = "alf", n_other: int = 0) -> None:
        self.now = 0.0
        self.cfg = AlertsConfig(enabled=True, event_hold_s=600.0)
        self.manager = AlertManager(self.cfg, 99)
        self.scheduler = NmeaScheduler(NmeaSchedule(), bytes_per_s, clock=lambda: self.now)
        self.port = PortAlerts(self.manager, self.cfg, mode=mode)  # type: ignore[arg-type]
        self.scheduler.alerts = self.port
        self.n_other = n_other
        self.lines: list[tuple[float, str]] = []

    def step(self, t_s: float, alerts_on: bool = True) -> list[tuple[str, ...]]:
        self.now = t_s
        fixes = [fix(i, t_s, CLOSING[i] if alerts_on else None) for i in CLOSING]
        fixes += [fix(10 + k, t_s) for k in range(self.n_other)]
        self.manager.step(fixes, T0_NS + round(t_s * 1e9))
        groups = self.scheduler.step(fixes)
        self.lines += [(t_s, line) for g in groups for line in g]
        return groups


def kinds(lines: list[tuple[float, str]], kind: str) -> list[tuple[float, str]]:
    return [(t, line) for t, line in lines if line[3:6] == kind]


def test_alf_on_raise_alc_every_30_s_repeats_and_clear() -> None:
    rig = Rig()
    for t in range(0, 400):
        rig.step(float(t))
    for _, line in rig.lines:
        msg = NMEAReader.parse(line.encode(), validate=1)
        assert msg.msgID in ("ALF", "ALC", "HBT", "TTM", "TLL") and len(line) <= 82
    cq = [(t, line) for t, line in kinds(rig.lines, "ALF") if ",191," in line]
    states = [line.split(",")[7] for _, line in cq]
    assert cq[0][0] == 5.0 and states[0] == "V"  # raised at t = 5 (confirmed)
    assert states[-1] == "N" and cq[-1][0] == 316.0  # cleared once passed
    active_times = [t for (t, _), s in zip(cq, states, strict=True) if s == "V"]
    gaps = [b - a for a, b in zip(active_times, active_times[1:], strict=False)]
    assert gaps and max(gaps) <= 60.0  # repeated at most 60 s apart (30 s configured)
    alc_times = [t for t, _ in kinds(rig.lines, "ALC")]
    assert alc_times[0] == 0.0  # new-target alerts are active from the first step
    assert all(b - a == 30.0 for a, b in zip(alc_times, alc_times[1:], strict=False))
    # the instance is the pair of target numbers: tracks 1 and 2 got numbers 1 and 2 -> 102
    assert cq[0][1].split(",")[10] == "102"
    hbt = kinds(rig.lines, "HBT")
    assert [t for t, _ in hbt][:3] == [0.0, 60.0, 120.0] and all(",A," in line for _, line in hbt)


def test_legacy_alr_port() -> None:
    rig = Rig(mode="alr")
    for t in range(0, 20):
        rig.step(float(t))
    assert not kinds(rig.lines, "ALF") and not kinds(rig.lines, "ALC")
    alr = [line for _, line in kinds(rig.lines, "ALR")]
    assert any(",191,A,V,CPA 01 02" in line for line in alr)


def _acn(alert_id: int, instance: int, command: str) -> str:
    body = f"IIACN,000000.00,,{alert_id},{instance},{command},C"
    return f"${body}*{checksum(body)}\r\n"


def test_acn_acknowledges_and_other_input_is_counted() -> None:
    rig = Rig()
    for t in range(0, 10):
        rig.step(float(t))
    assert rig.port.receive(_acn(191, 102, "A"))
    assert not rig.port.receive("$GPGGA,hello*00\r\n")
    assert not rig.port.receive(_acn(191, 999, "A"))
    rig.step(10.0)
    last = [line for _, line in kinds(rig.lines, "ALF") if ",191," in line][-1]
    assert last.split(",")[7] == "A" and last.split(",")[11] == "2"  # acknowledged, revision 2
    assert (rig.port.counts["acn_applied"], rig.port.counts["received_ignored"],
            rig.port.counts["acn_unknown"]) == (1, 1, 1)


def test_4800_baud_full_track_budget_alerts_go_first() -> None:
    """30 T tracks at 4800 baud (432 B/s, ~3.4 TTM+TLL updates/s against the 30 a second they
    ask for) keep the bucket empty. The two closing ships get their motion at t = 70 s (the new
    target alerts of the start have ended); the close-quarters ALF raised at t = 75 s is the
    first group of that step, and no step ever sends more than the bucket allows."""
    budget = 0.9 * serial_bytes_per_s(4800)
    rig = Rig(bytes_per_s=budget, n_other=28)
    rig.cfg = AlertsConfig(enabled=True)  # event alerts held 60 s
    rig.manager.cfg = rig.port.cfg = rig.cfg
    sent_bytes, tracks_before = 0, 0
    raised_at, first = None, ""
    for k in range(0, 900):  # 10 steps a second
        t = k / 10
        groups = rig.step(t, alerts_on=t >= 70.0)
        sent_bytes += sum(len(line) for g in groups for line in g)
        assert sent_bytes <= budget * t + rig.scheduler.capacity + 1e-9
        if t == 74.0:
            tracks_before = rig.scheduler.stats().groups_sent
        if any(",191," in line for g in groups for line in g):
            raised_at, first = t, groups[0][0]
            break
    assert raised_at is not None and 75.0 <= raised_at <= 75.2
    assert first[3:6] == "ALF" and ",191," in first and ",A,A,V," in first
    assert tracks_before > 0.9 * 74 * budget / 127 / 2  # the tracks had the line before (TTM+TLL ~127 B)
    assert rig.scheduler.stats().waiting == 0


def test_an_alert_fault_is_counted_and_tracks_go_on() -> None:
    rig = Rig()

    def broken(now_s: float, number_of: object) -> list:
        raise RuntimeError("boom")

    rig.port.offers = broken  # type: ignore[method-assign]
    groups = rig.step(0.0)
    assert groups and all(g[0][3:6] == "TTM" for g in groups)
    rig.step(1.0)
    assert rig.scheduler.alert_errors == 2
