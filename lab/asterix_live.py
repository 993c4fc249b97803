"""`tools/asterix-check --live MINUTES`: the daemon on the demo scenario for N minutes with ASTERIX to
a receiver on loopback, and tshark's verdict on every datagram it received (issue 26's live run).

The daemon runs as systemd runs it, a process of its own (`mast-stereo run --config FILE --seconds
N`), on the demo's recording (akashi-crossing, rendered into out/demo/ once as tools/demo does; or
`--recording DIR`) replayed at its recorded pace and looped, with ASTERIX target reports, start of
update, periodic and event status and CAT 034 all to one unicast port on 127.0.0.1 where a UDP
receiver (`lab.asterix_capture.UdpReceiver`, what a VTS is) keeps each datagram. Afterwards the
datagrams are written as a pcap (OUT/asterix-live.pcap) and tshark dissects it. It prints what
the daemon says it sent (its stop line), what arrived and what tshark made of it, and exits 1
unless every datagram sent arrived, tshark decoded every one and none is Malformed.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import time
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

import yaml

from lab.asterix_capture import TsharkVerdict, UdpReceiver, pcap, tshark_verdict

ROOT = Path(__file__).resolve().parents[1]
DEMO_RECORDING = ROOT / "out" / "demo" / "akashi-crossing"
SENT = re.compile(r"ASTERIX: (\d+) records in (\d+) data blocks, (\d+) datagrams sent, (\d+) dropped, "
                  r"(\d+) send errors")
STOPPED = re.compile(r"stopped: (\d+) pairs processed")


@dataclass
class LiveRun:
    """What one live run sent, received and tshark decoded."""

    seconds: float
    recording: str
    exit_code: int | None = None
    pairs: int = 0
    records_sent: int = 0
    datagrams_sent: int = 0
    send_dropped: int = 0
    send_errors: int = 0
    received: int = 0
    bytes_received: int = 0
    largest: int = 0
    categories: Counter[int] = field(default_factory=Counter)  # received blocks by CAT octet
    tshark: TsharkVerdict = field(default_factory=TsharkVerdict)
    pcap_path: str = ""

    @property
    def passed(self) -> bool:
        t = self.tshark
        return (self.exit_code == 0 and self.datagrams_sent > 0 and self.received == self.datagrams_sent
                and self.send_dropped == 0 and self.send_errors == 0 and not t.error
                and t.packets == self.received and t.malformed == 0)

    def lines(self) -> list[str]:
        t = self.tshark
        kinds = ", ".join(f"type {k}: {n}" for k, n in sorted(t.message_types.items()))
        return [
            f"live run: {self.seconds / 60:g} min of `mast-stereo run` on {self.recording} (paced, looped), "
            f"exit {self.exit_code}, {self.pairs} pairs processed",
            f"daemon sent: {self.records_sent} records in {self.datagrams_sent} datagrams, "
            f"{self.send_dropped} dropped, {self.send_errors} send errors",
            f"received: {self.received} datagrams, {self.bytes_received} bytes, largest {self.largest} B; "
            f"CAT 010 {self.categories[10]}, CAT 034 {self.categories[34]}",
            f"tshark: {t.packets} packets dissected, Malformed {t.malformed}; CAT 010 records {kinds}; "
            f"{len(t.numbers)} track numbers, {t.tre} TRE" + (f"; {t.error}" if t.error else ""),
            f"pcap: {self.pcap_path}; {'PASS' if self.passed else 'FAIL'}",
        ]


def demo_recording(path: Path = DEMO_RECORDING) -> Path:
    """The demo's recording, rendered once if it is not there (as tools/demo does)."""
    if not (path / "frames.csv").is_file():
        subprocess.run([sys.executable, "-m", "edge.cli", "simulate", "akashi-crossing", "--out", str(path),
                        "--force"], check=True, cwd=ROOT)
    return path


def live_run(seconds: float, recording: Path, out_dir: Path) -> LiveRun:
    """Run the daemon for `seconds` with ASTERIX to a receiver; see the module docstring."""
    out_dir.mkdir(parents=True, exist_ok=True)
    result = LiveRun(seconds, recording.name)
    rx = UdpReceiver()
    try:
        cfg = {"cameras": {"kind": "replay", "path": str(recording.resolve()), "pace": True, "loop": True},
               "outputs": {"modbus": {"tcp": {"enabled": False}},
                           "asterix": {"enabled": True, "start_of_update": True, "cat034": True,
                                       "tracks": {"address": "127.0.0.1", "port": rx.port}}},
               "health": {"require_clock_sync": False, "leds": {"kind": "none"}},
               "logging": {"level": "INFO"}}
        config = out_dir / "asterix-live.yaml"
        config.write_text(yaml.safe_dump(cfg))
        os.chmod(config, 0o644)  # the daemon refuses a file others can write
        log = out_dir / "asterix-live.log"
        with open(log, "w") as err:
            proc = subprocess.run([sys.executable, "-m", "edge.cli", "run", "--config", str(config),
                                   "--seconds", f"{seconds:g}"], cwd=ROOT, stdout=subprocess.DEVNULL,
                                  stderr=err, timeout=seconds + 120, env={**os.environ, "NOTIFY_SOCKET": ""})
        result.exit_code = proc.returncode
    finally:
        rx.close(settle_s=0.5)
    text = log.read_text(errors="replace")
    if (m := SENT.search(text)) is not None:
        result.records_sent, _, result.datagrams_sent, result.send_dropped, result.send_errors = \
            (int(g) for g in m.groups())
    if (m := STOPPED.search(text)) is not None:
        result.pairs = int(m.group(1))
    result.received = len(rx.datagrams)
    result.bytes_received = sum(len(d) for _, d, _ in rx.datagrams)
    result.largest = max((len(d) for _, d, _ in rx.datagrams), default=0)
    result.categories = Counter(d[0] for _, d, _ in rx.datagrams if d)
    capture = out_dir / "asterix-live.pcap"
    capture.write_bytes(pcap(rx.datagrams, rx.port))
    result.pcap_path = str(capture)
    result.tshark = tshark_verdict(capture, rx.port)
    return result


def main(minutes: float, recording: Path | None, out_dir: Path) -> int:
    t0 = time.monotonic()
    result = live_run(minutes * 60.0, recording or demo_recording(), out_dir)
    for line in result.lines():
        print(line)
    print(f"({time.monotonic() - t0:.0f} s in all)")
    return 0 if result.passed else 1
