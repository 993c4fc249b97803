"""ASTERIX network faults: the real output and sockets in a private network namespace.

`unshare -rn` gives this case a network namespace of its own (only `lo`, nothing of the machine's
touched), where it may take `lo` down and up and change routes. The child process
(`python -m lab.faults.asterix --child`) runs the real `AsterixOutput` (`drivers.udp` sockets)
sending CAT 010 blocks every 0.1 s to a multicast group that a receiver on `lo` has joined:

- asterix-interface: outgoing interface `lo` taken down for `DOWN_S`, then up. Expected: every
  publish returns at once (no call over `MAX_PUBLISH_MS`), the fault shows in the output's health
  and the errors are counted while down, datagrams arrive again within `BACK_WITHIN_S` of the
  interface's return and the fault clears.
- asterix-no-route: no interface configured and no route to 224.0.0.0/4 (sends fail: network
  unreachable), then the route is added: the same expectations.

Skipped where unprivileged user namespaces are not allowed (`unshare -rn` fails).
"""

from __future__ import annotations

import json
import shutil
import socket
import struct
import subprocess
import sys
import threading
import time
from pathlib import Path

from lab.faults.matrix import Case, Row

GROUP, PORT = "239.255.10.1", 8600
DOWN_S = 2.0
BACK_WITHIN_S = 5.0
MAX_PUBLISH_MS = 20.0
STEP_S = 0.1


def _ip(*args: str) -> None:
    subprocess.run(["ip", *args], check=True, capture_output=True)


def _phase(interface: str | None, fail: list[str], heal: list[str]) -> dict:
    """Send for 1 s, break the network (`fail`) for DOWN_S, heal it; what the output did."""
    from edge.config.asterix import AsterixConfig, AsterixDestination
    from edge.fix import ShipFix, TrackStatus
    from edge.outputs.asterix import AsterixOutput

    received: list[float] = []
    rx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    rx.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    rx.bind(("", PORT))
    rx.setsockopt(socket.IPPROTO_IP, socket.IP_ADD_MEMBERSHIP,
                  struct.pack("4s4s", socket.inet_aton(GROUP), socket.inet_aton("127.0.0.1")))
    rx.settimeout(0.05)
    stop = threading.Event()

    def receive() -> None:
        while not stop.is_set():
            try:
                rx.recv(65535)
                received.append(time.monotonic())
            except OSError:
                continue

    reader = threading.Thread(target=receive, daemon=True)
    reader.start()
    cfg = AsterixConfig(enabled=True, tracks=AsterixDestination(GROUP, PORT, 1, interface))
    out = AsterixOutput.from_config(cfg)
    worst_ms, faults_seen, t_fail, t_heal, t_clear = 0.0, 0, 0.0, 0.0, None
    t0 = time.monotonic()
    k = 0
    while True:
        now = time.monotonic() - t0
        if now >= 1.0 and not t_fail:
            for cmd in fail:
                _ip(*cmd.split())
            t_fail = time.monotonic()
        if t_fail and not t_heal and time.monotonic() - t_fail >= DOWN_S:
            for cmd in heal:
                _ip(*cmd.split())
            t_heal = time.monotonic()
        fix = ShipFix(time.time_ns(), 1, TrackStatus.TRACKING, 0.0, 0.0, 0.0, 1500.0, 90.0, 34.6, 135.0,
                      5.0, 90.0, 8.0, 20.0)
        start = time.perf_counter()
        out.publish([fix], time.time_ns())
        worst_ms = max(worst_ms, (time.perf_counter() - start) * 1e3)
        fault, counters = out.health()
        faults_seen += fault is not None
        if t_heal and fault is None and t_clear is None:
            t_clear = time.monotonic()
        if t_heal and (time.monotonic() - t_heal > BACK_WITHIN_S or (t_clear and any(
                t > t_heal for t in received) and time.monotonic() - t_heal > 0.5)):
            break
        k += 1
        time.sleep(STEP_S)
    stop.set()
    reader.join()
    out.close()
    rx.close()
    back = next((t for t in received if t > t_heal), None)
    return {"before": sum(t < t_fail for t in received),
            "during": sum(t_fail + 0.2 < t < t_heal for t in received),
            "back_s": None if back is None else back - t_heal,
            "clear_s": None if t_clear is None else t_clear - t_heal, "faults_seen": faults_seen,
            "errors": counters["asterix_udp_errors"], "dropped": counters["asterix_udp_dropped"],
            "worst_publish_ms": worst_ms}


def child() -> int:
    _ip("link", "set", "lo", "up")
    results = {
        "interface": _phase("lo", ["link set lo down"], ["link set lo up"]),
        "route": _phase(None, [], ["route add 224.0.0.0/4 dev lo"]),  # broken from the start
    }
    print(json.dumps(results))
    return 0


def _row(name: str, fault: str, r: dict | None, skipped: str = "", broken_from_start: bool = False) -> Row:
    expected = (f"publish never blocks (< {MAX_PUBLISH_MS:g} ms), fault shown and errors counted, "
                f"datagrams back within {BACK_WITHIN_S:g} s")
    if r is None:
        return Row(fault, expected, "", False, skipped=skipped)
    back = None if r["back_s"] is None else round(r["back_s"], 2)
    observed = (f"{r['before']} datagrams before, {r['during']} during, errors {r['errors']}, dropped "
                f"{r['dropped']}, fault on {r['faults_seen']} steps, worst publish "
                f"{r['worst_publish_ms']:.2f} ms, back after {back} s")
    passed = ((r["before"] > 0 or broken_from_start) and r["during"] == 0 and r["errors"] > 0
              and r["faults_seen"] > 0 and r["back_s"] is not None and r["back_s"] <= BACK_WITHIN_S
              and r["clear_s"] is not None and r["worst_publish_ms"] < MAX_PUBLISH_MS)
    return Row(fault, expected, observed, passed, None if r["back_s"] is None else round(r["back_s"], 2))


def network(_workdir: Path) -> list[Row]:
    names = ("outgoing interface down 2 s, then up", "no route to the multicast group, then a route added")
    if shutil.which("unshare") is None or shutil.which("ip") is None:
        return [_row("", n, None, "unshare or ip not installed") for n in names]
    run = subprocess.run(["unshare", "-rn", sys.executable, "-m", "lab.faults.asterix", "--child"],
                         capture_output=True, text=True, timeout=60, cwd=Path(__file__).resolve().parents[2])
    if run.returncode != 0 or not run.stdout.strip():
        return [_row("", n, None, f"no private network namespace here: {run.stderr.strip()[-120:]}")
                for n in names]
    r = json.loads(run.stdout.strip().splitlines()[-1])
    return [_row("asterix-interface", names[0], r["interface"]),
            _row("asterix-no-route", names[1], r["route"], broken_from_start=True)]


CASES = [Case("asterix-network", "outputs", network)]

if __name__ == "__main__" and sys.argv[1:] == ["--child"]:
    sys.exit(child())
