"""A VTS's end of the ASTERIX output, for lab tools: a UDP receiver on loopback keeping every
datagram with its arrival time, a pcap of what it received, tshark's verdict on that pcap, and the
status messages (I010/550) as asterix-decoder reads them.

Why a receiver and not a capture: capturing on an interface needs privileges (CAP_NET_RAW), a
socket does not, and it is what a VTS is. The pcap wraps each received payload in the IPv4 and
UDP headers it came with (LINKTYPE_RAW), so tshark dissects exactly the bytes that went over the
socket. asterix-decoder (CroatiaControl, GPL) is a test extra: imported only where decoded here,
never by the daemon.
"""

from __future__ import annotations

import shutil
import socket
import struct
import subprocess
import threading
import time
from collections import Counter
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

PCAP_LINKTYPE_RAW = 101  # each record is an IPv4 packet


class UdpReceiver:
    """Receives datagrams on `host:port` (0: a free port) in a thread: `datagrams` holds
    (CLOCK_MONOTONIC s, payload, source port) in arrival order."""

    def __init__(self, host: str = "127.0.0.1", port: int = 0) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4 << 20)
        self.sock.bind((host, port))
        self.sock.settimeout(0.1)
        self.host, self.port = host, int(self.sock.getsockname()[1])
        self.datagrams: list[tuple[float, bytes, int]] = []
        self._done = threading.Event()
        self._thread = threading.Thread(target=self._run, name="asterix-receiver", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._done.is_set():
            try:
                payload, (_, sport) = self.sock.recvfrom(65535)
            except TimeoutError:
                continue
            self.datagrams.append((time.monotonic(), payload, sport))

    def close(self, settle_s: float = 0.3) -> None:
        """Stop after `settle_s` more seconds (what is in flight arrives)."""
        time.sleep(settle_s)
        self._done.set()
        self._thread.join()
        self.sock.close()


def _ipv4_checksum(header: bytes) -> int:
    total = sum(struct.unpack(f">{len(header) // 2}H", header))
    while total >> 16:
        total = (total & 0xFFFF) + (total >> 16)
    return ~total & 0xFFFF


def pcap(datagrams: Iterable[tuple[float, bytes, int]], dport: int, address: str = "127.0.0.1") -> bytes:
    """A classic pcap (LINKTYPE_RAW) of (arrival s, payload, source port) as UDP packets to `dport`."""
    out = [struct.pack("<IHHiIII", 0xA1B2C3D4, 2, 4, 0, 0, 65535, PCAP_LINKTYPE_RAW)]
    ip_address = socket.inet_aton(address)
    for k, (t_s, payload, sport) in enumerate(datagrams):
        udp = struct.pack(">HHHH", sport, dport, 8 + len(payload), 0) + payload
        head = struct.pack(">BBHHHBBH4s4s", 0x45, 0, 20 + len(udp), k & 0xFFFF, 0, 64, 17, 0,
                           ip_address, ip_address)
        packet = head[:10] + struct.pack(">H", _ipv4_checksum(head)) + head[12:] + udp
        sec, usec = int(t_s), int((t_s % 1.0) * 1e6)
        out.append(struct.pack("<IIII", sec, usec, len(packet), len(packet)) + packet)
    return b"".join(out)


@dataclass
class TsharkVerdict:
    """What tshark made of a pcap: packets, Malformed ones, ASTERIX categories by block."""

    packets: int = 0
    malformed: int = 0
    categories: Counter[str] = field(default_factory=Counter)
    message_types: Counter[int] = field(default_factory=Counter)  # I010/000, records
    tre: int = 0  # I010/170 TRE set, records
    numbers: set[int] = field(default_factory=set)  # I010/161 track numbers seen
    error: str = ""  # why tshark could not run


def tshark_verdict(path: Path, port: int) -> TsharkVerdict:
    """Run tshark over `path` (UDP port `port` dissected as ASTERIX): a packet is Malformed when
    tshark flags it (`_ws.malformed`) or says so in its output."""
    if shutil.which("tshark") is None:
        return TsharkVerdict(error="tshark not installed")
    run = subprocess.run(["tshark", "-r", str(path), "-d", f"udp.port=={port},asterix", "-T", "fields",
                          "-e", "_ws.malformed", "-e", "asterix.category", "-e", "asterix.010_161_TRK",
                          "-e", "asterix.010_170_TRE", "-e", "asterix.010_000_VALUE"],
                         capture_output=True, text=True, timeout=600)
    if run.returncode != 0:
        return TsharkVerdict(error=f"tshark exit {run.returncode}: {run.stderr.strip()[-200:]}")
    verdict = TsharkVerdict()
    for line in run.stdout.splitlines():
        malformed, category, numbers, tre, kinds = (line.split("\t") + [""] * 5)[:5]
        verdict.packets += 1
        verdict.malformed += bool(malformed) or "Malformed" in line
        verdict.categories[category or "none"] += 1
        verdict.numbers.update(int(n) for n in numbers.split(",") if n)
        verdict.tre += tre.split(",").count("1")
        verdict.message_types.update(int(k) for k in kinds.split(",") if k)
    verdict.malformed += run.stderr.count("Malformed")
    return verdict


@dataclass(frozen=True)
class StatusMessage:
    """One CAT 010 status record (types 2-4 carry no target) with its I010/550 fields."""

    t_s: float  # arrival, CLOCK_MONOTONIC
    kind: int  # I010/000: 3 periodic, 4 event
    nogo: int
    overload: int
    time_invalid: int


def status_messages(datagrams: Sequence[tuple[float, bytes, int]]) -> list[StatusMessage]:
    """The CAT 010 status records (I010/550) in the datagrams, decoded by asterix-decoder."""
    import asterix  # asterix-decoder: test extra (GPL), imported only here

    out = []
    for t_s, payload, _ in datagrams:
        for rec in asterix.parse(payload, verbose=False):
            if rec.get("category") == 10 and "I550" in rec:
                s = rec["I550"]
                out.append(StatusMessage(t_s, rec["I000"]["MsgTyp"]["val"], s["NOGO"]["val"], s["OVL"]["val"],
                                         s["TSV"]["val"]))
    return out
