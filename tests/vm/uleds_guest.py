"""Runs inside the appliance VM (V4L2VM_KMODS=1, as root): real LED class devices made with uleds,
driven by a separate process through SysfsLedPanel, their brightness changes read back from /dev/uleds.

`python uleds_guest.py` creates the LEDs, forks the "daemon" (it shows OK, DEGRADED, STALLED, then OK
again from the moment it reports T0, ticking the panel at the deadlines tick() returns; forked rather
than started, since an interpreter start costs ~9 s under TCG), SIGSTOPs it for a while, SIGCONTs it,
SIGTERMs it, and prints one line `ULEDS-RESULT {json}` with every brightness change (monotonic ns)
and the signal times. The host test (test_leds_vm.py) makes the assertions.
"""

from __future__ import annotations

import json
import os
import select
import signal
import struct
import sys
import time

from drivers.leds.sysfs import SysfsLedPanel

LEDS = {"ok": "mast:green:ok", "fault": "mast:red:fault"}
MAX_BRIGHTNESS = 255
S = 1_000_000_000
PHASES = (("OK", 0), ("DEGRADED", 3 * S), ("STALLED", 6 * S), ("OK", 8 * S))  # (state, from t0 + ns)
STOP_AT, CONT_AT, TERM_AT = 10 * S, 13 * S, 15 * S


def drive(report_fd: int) -> None:
    panel = SysfsLedPanel(LEDS)
    stop = []
    signal.signal(signal.SIGTERM, lambda *_: stop.append(1))
    t0 = time.monotonic_ns()
    os.write(report_fd, f"{t0}\n".encode())
    state = None
    while not stop:
        now = time.monotonic_ns()
        due = [s for s, start in PHASES if now - t0 >= start][-1]
        if due != state:
            state = due
            panel.show_health(state)
        deadline = panel.tick(now)
        later = [t0 + start for _, start in PHASES if t0 + start > now]
        time.sleep(max(0, min([deadline, *later]) - time.monotonic_ns()) / 1e9)
    panel.close()


def main() -> None:
    fds = {}
    for role, name in LEDS.items():
        fd = os.open("/dev/uleds", os.O_RDWR)
        os.write(fd, struct.pack("64si", name.encode(), MAX_BRIGHTNESS))
        fds[fd] = role
    events: list[tuple[int, str, int]] = []
    poller = select.poll()
    for fd in fds:
        poller.register(fd, select.POLLIN)

    def read_events(timeout_ms: int) -> None:
        for fd, _ in poller.poll(timeout_ms):
            (value,) = struct.unpack("i", os.read(fd, 4))
            events.append((time.monotonic_ns(), fds[fd], value))

    read_end, write_end = os.pipe()
    pid = os.fork()
    if pid == 0:
        os.close(read_end)
        for fd in fds:
            os.close(fd)  # the LEDs belong to the parent
        drive(write_end)
        os._exit(0)
    os.close(write_end)
    with os.fdopen(read_end) as report:
        t0 = int(report.readline())
    marks = {}
    for name, at, sig in (("stop", STOP_AT, signal.SIGSTOP), ("cont", CONT_AT, signal.SIGCONT),
                          ("term", TERM_AT, signal.SIGTERM)):
        while time.monotonic_ns() < t0 + at:
            read_events(20)
        os.kill(pid, sig)
        marks[name] = time.monotonic_ns()
    _, status = os.waitpid(pid, 0)
    end = time.monotonic_ns() + S // 2
    while time.monotonic_ns() < end:
        read_events(20)
    print("ULEDS-RESULT " + json.dumps({"t0_ns": t0, "marks": marks, "events": events,
                                        "child_rc": os.waitstatus_to_exitcode(status),
                                        "leds": sorted(os.listdir("/sys/class/leds"))}), flush=True)


if __name__ == "__main__":
    sys.exit(main())
