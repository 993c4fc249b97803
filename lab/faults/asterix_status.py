"""ASTERIX status against the running daemon: a camera unplugged sets I010/550 NOGO in the next
status message and a replug clears it; an unsynchronised clock sets TSV.

The daemon runs on fake V4L2 cameras (`lab.faults._rig.Bench`) with its ASTERIX output sending to
a UDP receiver on loopback (`lab.asterix_capture.UdpReceiver`: what a VTS is); every status
record it received is decoded by asterix-decoder. The health change is read from the appliance
(polled every 20 ms), so "the next status message" is the first one after that change.

- asterix-nogo: the left camera unplugged for `UNPLUG_S`, replugged; then both for `BOTH_S`
  (longer than `health.stale_s`). Expected: a status message with NOGO set arrives within
  `NOGO_AFTER_HEALTH_S` of the health leaving OK (the output checks at every pair and every
  0.2 s without pairs) and within 1 s of the unplug; every status message from it until the
  replug has NOGO set; NOGO 0 again within `NOGO_AFTER_HEALTH_S` of the health's return to OK
  and within 5 s of the replug; the last message before the unplug has it 0. A camera gone leaves
  its stage beating with a fault, so the health is DEGRADED (NOGO 1, "degraded"), not STALLED
  (NOGO 2, a stage silent), however long it stays out.
- asterix-tsv: the daemon's clock (`drivers.clock.VirtualClock`) turns unsynchronised, then
  synchronised again. The daemon reads it every `clock_check_s` (10 s in service, `CHECK_S` on
  this bench) into the TIME_SYNC health bit; expected: TSV set in a status message within
  `CHECK_S` + 1 s (the status tick) + `NOGO_AFTER_HEALTH_S` of the change, set in every message
  until the clock is back, cleared as fast.
"""

from __future__ import annotations

import time
from pathlib import Path

from drivers.clock import VirtualClock
from edge.appliance.health import HealthState
from lab.asterix_capture import StatusMessage, UdpReceiver, status_messages
from lab.faults._rig import Bench
from lab.faults.matrix import Case, Row

UNPLUG_S, BOTH_S = 1.0, 3.0
NOGO_AFTER_HEALTH_S = 0.5  # the output's status check: every pair (0.1 s) or 0.2 s without pairs
NOGO_WITHIN_S, CLEAR_WITHIN_S = 1.0, 5.0  # the camera-unplug case's DEGRADED and OK bounds
CHECK_S = 1.0  # the bench daemon's clock check (10 s in service)
TSV_WITHIN_S = CHECK_S + 1.0 + NOGO_AFTER_HEALTH_S


class _Status:
    """The status messages received so far, decoded once each."""

    def __init__(self, rx: UdpReceiver) -> None:
        self.rx, self.decoded = rx, 0
        self.messages: list[StatusMessage] = []

    def __call__(self) -> list[StatusMessage]:
        new = self.rx.datagrams[self.decoded:]
        self.messages += status_messages(new)
        self.decoded += len(new)
        return self.messages


def _first(messages: list[StatusMessage], after_s: float, predicate) -> StatusMessage | None:
    return next((m for m in messages if m.t_s >= after_s and predicate(m)), None)


def _s(t: float | None) -> str:
    return "never" if t is None else f"{t:.2f} s"


def _nogo_row(bench: Bench, status: _Status, sides: tuple[str, ...], hold_s: float) -> Row:
    name = " and ".join(sides)
    health = bench.app.health
    t_out = time.monotonic()
    for side in sides:
        bench.unplug(side)
    t_bad = bench.wait(lambda: health.snapshot().state is not HealthState.OK, 3.0)
    bench.wait(lambda: _first(status(), t_out, lambda m: m.nogo) is not None, 3.0)
    time.sleep(max(0.0, hold_s - (time.monotonic() - t_out)))
    states = {health.snapshot().state.value}
    t_in = time.monotonic()
    for side in sides:
        bench.replug(side)
    t_good = bench.wait(lambda: health.snapshot().state is HealthState.OK, 8.0)
    bench.wait(lambda: _first(status(), t_in, lambda m: not m.nogo) is not None, 3.0)
    messages = status()
    before = [m for m in messages if m.t_s < t_out]
    first = _first(messages, t_out, lambda m: m.nogo)
    during = [m for m in messages if first is not None and first.t_s <= m.t_s < t_in]
    cleared = _first(messages, t_in, lambda m: not m.nogo)
    nogo_s = None if first is None else first.t_s - t_out
    clear_s = None if cleared is None else cleared.t_s - t_in
    after_bad = None if first is None or t_bad is None else first.t_s - t_bad
    after_good = None if cleared is None or t_good is None else cleared.t_s - t_good
    values = sorted({m.nogo for m in during})
    passed = (first is not None and cleared is not None and t_bad is not None and t_good is not None
              and nogo_s is not None and nogo_s <= NOGO_WITHIN_S and after_bad is not None
              and after_bad <= NOGO_AFTER_HEALTH_S and all(m.nogo for m in during)
              and clear_s is not None and clear_s <= CLEAR_WITHIN_S and after_good is not None
              and after_good <= NOGO_AFTER_HEALTH_S and bool(before) and before[-1].nogo == 0)
    return Row(f"{name} camera unplugged {hold_s:g} s: ASTERIX status",
               f"NOGO <= {NOGO_AFTER_HEALTH_S:g} s after the health, <= {NOGO_WITHIN_S:g} s; "
               "0 again on replug",
               f"NOGO {values} (health {'/'.join(sorted(states))}) {_s(nogo_s)} after unplug, "
               f"{_s(after_bad)} after health; {len(during)} msgs all set; 0 {_s(clear_s)} after replug",
               passed, clear_s)


def nogo(workdir: Path) -> list[Row]:
    rx = UdpReceiver()
    try:
        with Bench(workdir, asterix_port=rx.port, clock=VirtualClock(True)) as bench:
            if not bench.ready():
                return [Row("daemon on fake cameras", "READY=1 and OK", "never ready", False)]
            status = _Status(rx)
            rows = [_nogo_row(bench, status, ("left",), UNPLUG_S)]
            time.sleep(0.5)
            rows.append(_nogo_row(bench, status, ("left", "right"), BOTH_S))
            return rows
    finally:
        rx.close(settle_s=0.0)


def _tsv_row(bench: Bench, status: _Status, clock: VirtualClock, synchronised: bool) -> Row:
    t0 = time.monotonic()
    clock.is_synchronised = synchronised
    wanted = int(not synchronised)
    bench.wait(lambda: _first(status(), t0, lambda m: m.time_invalid == wanted) is not None, TSV_WITHIN_S + 2)
    time.sleep(1.5)  # a periodic message or more after it
    messages = status()
    first = _first(messages, t0, lambda m: m.time_invalid == wanted)
    after = [m for m in messages if first is not None and m.t_s >= first.t_s]
    delay = None if first is None else first.t_s - t0
    kinds = sorted({m.kind for m in after})
    passed = delay is not None and delay <= TSV_WITHIN_S and all(m.time_invalid == wanted for m in after)
    what = "unsynchronised" if not synchronised else "synchronised again"
    return Row(f"clock {what}: ASTERIX status",
               f"TSV {wanted} <= {TSV_WITHIN_S:g} s (clock check {CHECK_S:g} s)",
               f"TSV {wanted} after {_s(delay)}, then in all {len(after)} msgs (types {kinds})", passed,
               delay)


def tsv(workdir: Path) -> list[Row]:
    rx, clock = UdpReceiver(), VirtualClock(True)
    try:
        with Bench(workdir, asterix_port=rx.port, clock=clock, clock_check_s=CHECK_S) as bench:
            if not bench.ready():
                return [Row("daemon on fake cameras", "READY=1 and OK", "never ready", False)]
            status = _Status(rx)
            before = [m.time_invalid for m in status()]
            rows = [_tsv_row(bench, status, clock, False), _tsv_row(bench, status, clock, True)]
            if any(before):
                rows.append(Row("clock synchronised at start", "TSV 0", f"TSV set in {sum(before)} msgs",
                                False))
            return rows
    finally:
        rx.close(settle_s=0.0)


CASES = [
    Case("asterix-nogo", "cameras", nogo),
    Case("asterix-tsv", "outputs", tsv),
]
