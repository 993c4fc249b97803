"""`tools/soak --pairs N`: the daemon at full speed for N pairs, and the bounds it must hold.

The daemon (`lab.faults.soak_child`: the real `Appliance` in a process of its own) replays a
generated lap of traffic (`lab.faults.soak_scene`) in a loop without pacing, writing NMEA to a
pty that this process reads (an independent reader: pynmea2 checks every sentence) and serving
Modbus TCP that this process polls once a second on one kept connection. The child prints a
sample every `--sample-every` pairs (RSS, fds, threads, per-pair latency) and its counters at
the end; the bounds after the warm-up (the first `--warmup` pairs: caches, allocator arenas,
the first laps' tracks):

- RSS growth under 5 MB (the largest sample after the warm-up minus the one at its end);
- thread and fd counts flat (every sample after the warm-up equal);
- every computed fix emitted or counted as dropped, per output: NMEA serial
  (in = sent + dropped + pending, `edge.outputs.schedule`; groups submitted = written + dropped
  + queued; bytes read on the pty = bytes written), Modbus (in = on an image + unslotted +
  unserved, `edge.outputs.modbus`), ASTERIX (in = reported + dropped, blocks = sent + dropped:
  `edge.outputs.asterix`), and pipeline fixes = each output's fixes in;
- no pair lost at the input (the lossless hand-off of an unpaced source), none failed;
- no track id seen again once retired, and no NMEA target number lent to a new track within
  `quarantine_s` of its last L sentence.

Prints the table of bounds (bound, measured, PASS/FAIL), writes soak.json, samples.jsonl and
soak.png (RSS, fds, threads and latency against pairs) to `--out`; exit status = FAIL rows.
`CASES` holds the short soak of the fault matrix (a few thousand pairs of the tests' small lap:
the accounting and id properties, not the RSS bound, which needs a long run).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import threading
import time
import tty
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import yaml

from lab.faults._rig import free_port
from lab.faults.matrix import Case, Row
from lab.faults.soak_scene import SOAK_LAP, TEST_LAP, Lap, lap_recording

RSS_BOUND_MB = 5.0
ROOT = Path(__file__).resolve().parents[2]


@dataclass(frozen=True)
class Bound:
    name: str
    bound: str
    measured: str
    passed: bool


class PtyReader:
    """The NMEA receiver: reads the pty's master side, counts bytes and checks each sentence."""

    def __init__(self, keep_ttm: bool = False) -> None:
        self.keep_ttm = keep_ttm
        self.master, self.slave = os.openpty()
        tty.setraw(self.slave)  # no echo, no CR/LF translation: the bytes as written
        self.path = os.ttyname(self.slave)
        self.bytes = 0
        self.sentences = 0
        self.bad = 0
        self.ttm: list[tuple[float, int, str]] = []  # (monotonic s, target number, status) per TTM
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        import select

        import pynmea2

        buf = b""
        keep_ttm = self.keep_ttm
        while not self._stop.is_set():
            ready, _, _ = select.select([self.master], [], [], 0.2)
            if not ready:
                continue
            try:
                data = os.read(self.master, 65536)
            except OSError:
                continue
            self.bytes += len(data)
            buf += data
            *lines, buf = buf.split(b"\r\n")
            for line in lines:
                try:
                    msg = pynmea2.parse(line.decode("ascii"), check=True)
                    self.sentences += 1
                    if msg.sentence_type == "TTM" and keep_ttm:
                        self.ttm.append((time.monotonic(), int(msg.data[0]), msg.data[11]))
                except (pynmea2.ParseError, UnicodeDecodeError, ValueError):
                    self.bad += 1

    def close(self, settle_s: float = 0.5) -> None:
        time.sleep(settle_s)
        self._stop.set()
        self._thread.join()
        os.close(self.master)
        os.close(self.slave)


class ModbusPoller:
    """A VTS client: reads the health block once a second on one connection; counts answers."""

    def __init__(self, port: int, period_s: float = 1.0) -> None:
        self.port, self.period_s = port, period_s
        self.answered = self.failed = 0
        self.first_answer_s: float | None = None  # CLOCK_MONOTONIC of the first answer
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        import logging

        from pymodbus.client import ModbusTcpClient

        logging.getLogger("pymodbus").setLevel(logging.CRITICAL)  # refused before the daemon listens
        client = ModbusTcpClient("127.0.0.1", port=self.port, timeout=2)
        while not self._stop.wait(self.period_s):
            try:
                if not client.connected:
                    client.connect()
                rr = client.read_holding_registers(16, count=12)
                ok = not rr.isError()
            except Exception:  # noqa: BLE001 - the daemon not up yet, or gone: counted
                ok = False
            if ok and self.first_answer_s is None:
                self.first_answer_s = time.monotonic()
            self.answered += ok
            self.failed += not ok and self.answered > 0  # failures once it has answered
        client.close()

    def close(self) -> None:
        self._stop.set()
        self._thread.join()


def write_config(out: Path, recording: Path, pty_path: str, modbus_port: int, min_ship_px: int) -> Path:
    asterix = {"enabled": True, "tracks": {"address": "127.0.0.1", "port": free_port()}, "cat034": True}
    cfg = {"cameras": {"kind": "replay", "path": str(recording), "pace": False, "loop": True},
           "pipeline": {"min_ship_px": min_ship_px},
           "outputs": {"nmea": [{"url": pty_path, "baud": 115200}],
                       "modbus": {"tcp": {"enabled": True, "host": "127.0.0.1", "port": modbus_port}},
                       "asterix": asterix},
           "health": {"stale_s": 30.0, "min_fps": 0.0, "leds": {"kind": "none"}},
           "logging": {"level": "WARNING"}}
    path = out / "soak.yaml"
    path.write_text(yaml.safe_dump(cfg))
    return path


def run_soak(out: Path, pairs: int, lap: Lap, *, warmup: int, sample_every: int,
             cache: Path | None = None, jobs: int = 1, log: bool = True,
             recording: Path | None = None) -> tuple[list[Bound], dict, list[dict]]:
    """Render (or reuse) the lap, or take `recording`, run the child for `pairs` pairs;
    (bounds, final counters, samples)."""
    out = out.resolve()
    out.mkdir(parents=True, exist_ok=True)
    recording = recording or lap_recording((cache or out / "cache").resolve(), lap, jobs=jobs)
    reader = PtyReader()
    port = free_port()
    config = write_config(out, recording, reader.path, port, min_ship_px=10 if lap.scale < 0.5 else 20)
    poller = ModbusPoller(port)
    samples: list[dict] = []
    final: dict = {}
    t0 = time.monotonic()
    with open(out / "samples.jsonl", "w", encoding="utf-8") as keep, \
            subprocess.Popen([sys.executable, "-m", "lab.faults.soak_child", "--config", str(config),
                              "--pairs", str(pairs), "--sample-every", str(sample_every)],
                             cwd=ROOT, stdout=subprocess.PIPE, text=True) as child:
        assert child.stdout is not None
        for line in child.stdout:
            rec = json.loads(line)
            keep.write(line)
            if rec.get("final"):
                final = rec
                continue
            samples.append(rec)
            if log and rec["pairs"] % (sample_every * 20) == 0:
                print(f"soak: {rec['pairs']} pairs, {time.monotonic() - t0:.0f} s, "
                      f"RSS {rec['rss_kb'] / 1024:.1f} MB, {rec['threads']} threads, {rec['fds']} fds",
                      file=sys.stderr)
    poller.close()
    reader.close()
    final["wall_s"] = time.monotonic() - t0
    final["exit_status"] = child.returncode
    final["reader"] = {"bytes": reader.bytes, "sentences": reader.sentences, "bad": reader.bad}
    final["modbus_client"] = {"answered": poller.answered, "failed": poller.failed}
    # the warm-up also lasts until the client is connected (its socket is one of the daemon's fds)
    first_s = poller.first_answer_s
    connected = [s["pairs"] for s in samples if first_s is not None and s["mono_s"] > first_s]
    warmup = max(warmup, connected[0] if connected else 0)
    final["warmup"] = warmup
    return evaluate(samples, final, warmup, pairs), final, samples


def evaluate(samples: list[dict], final: dict, warmup: int, pairs: int, *, rss: bool = True) -> list[Bound]:
    """The bounds of the module docstring against what the run measured."""
    if not final.get("outputs"):
        return [Bound("the soak ran", "a final report", f"exit status {final.get('exit_status')}", False)]
    after = [s for s in samples if s["pairs"] >= warmup]
    bounds: list[Bound] = []
    if rss and after:
        base = after[0]["rss_kb"]
        growth_mb = (max(s["rss_kb"] for s in after) - base) / 1024
        bounds.append(Bound(f"RSS growth after {warmup} pairs", f"< {RSS_BOUND_MB:g} MB",
                            f"{growth_mb:+.2f} MB ({base / 1024:.1f} -> {after[-1]['rss_kb'] / 1024:.1f} MB)",
                            growth_mb < RSS_BOUND_MB))
    for key in ("threads", "fds"):
        values = sorted({s[key] for s in after})
        bounds.append(Bound(f"{key} after warm-up", "flat", ", ".join(map(str, values)) or "no samples",
                            len(values) == 1))
    p, outs = final["pipeline"], final["outputs"]
    bounds.append(Bound("pairs processed", f">= {pairs}, none failed, none lost at input",
                        f"{p['processed']} processed, {p['failed']} failed, "
                        f"{final['input_dropped_pairs']} lost",
                        p["processed"] >= pairs and p["failed"] == 0 and final["input_dropped_pairs"] == 0))
    ser, mb = outs["nmea_serial_groups"], outs["modbus_images"]
    fixes = p["fixes"] + final["lost_at_stop"]
    bounds.append(Bound("fixes computed (+ L at stop) = each output's fixes in", "equal",
                        f"{p['fixes']} + {final['lost_at_stop']} computed, NMEA {ser['nmea_fixes_in']}, "
                        f"Modbus {mb['modbus_fixes_in']}",
                        fixes == ser["nmea_fixes_in"] == mb["modbus_fixes_in"]))
    bounds.append(Bound("NMEA serial: in = sent + dropped + pending", "equal",
                        f"{ser['nmea_fixes_in']} = {ser['nmea_fixes_sent']} + {ser['nmea_fixes_dropped']}"
                        f" + {ser['nmea_fixes_pending']}",
                        ser["nmea_fixes_in"] == ser["nmea_fixes_sent"] + ser["nmea_fixes_dropped"]
                        + ser["nmea_fixes_pending"]))
    ast = outs.get("asterix_blocks")
    if ast is not None:  # every fix reported or counted, every block sent or counted
        bounds.append(Bound("ASTERIX: fixes computed = in = reported + dropped; blocks = sent + dropped",
                            "equal",
                            f"{fixes} computed, {ast['asterix_fixes_in']} in = "
                            f"{ast['asterix_fixes_reported']} + {ast['asterix_fixes_dropped']}; "
                            f"{ast['asterix_blocks_out']} blocks = "
                            f"{ast['asterix_udp_datagrams']} + {ast['asterix_udp_dropped']}",
                            fixes == ast["asterix_fixes_in"] == ast["asterix_fixes_reported"]
                            + ast["asterix_fixes_dropped"] and ast["asterix_blocks_out"]
                            == ast["asterix_udp_datagrams"] + ast["asterix_udp_dropped"]))
    queued = ser["serial_submitted"] - ser["serial_written"] - ser["serial_dropped"]
    bounds.append(Bound("NMEA serial: groups = written + dropped + queued", "queued >= 0, groups = submitted",
                        f"{ser['nmea_groups']} groups, {ser['serial_written']} written, "
                        f"{ser['serial_dropped']} dropped, {queued} queued at close",
                        ser["nmea_groups"] == ser["serial_submitted"] and queued >= 0))
    rd = final["reader"]
    bounds.append(Bound("NMEA bytes read on the pty = written", "equal, every sentence parses",
                        f"{rd['bytes']} read, {ser['serial_bytes']} written, {rd['sentences']} sentences,"
                        f" {rd['bad']} bad", rd["bytes"] == ser["serial_bytes"] and rd["bad"] == 0))
    on_image = mb["modbus_fixes_in"] - mb["modbus_fixes_unslotted"] - mb["modbus_fixes_unserved"]
    client = final["modbus_client"]
    bounds.append(Bound("Modbus: in = on image + unslotted + unserved", "each >= 0; client answered",
                        f"{mb['modbus_fixes_in']} = {on_image} + {mb['modbus_fixes_unslotted']} + "
                        f"{mb['modbus_fixes_unserved']}; {client['answered']} reads ok, "
                        f"{client['failed']} failed",
                        on_image >= 0 and client["answered"] > 0))
    bounds.append(Bound("track ids never reused", "no violation",
                        f"max id {final['max_track_id']}; " + ("; ".join(final["id_violations"]) or "none"),
                        not final["id_violations"] and final["max_track_id"] > 0))
    gap = final["number_min_gap_s"]
    shortest = "none" if gap is None else f"{gap:.1f} s"
    violations = "; ".join(final["number_violations"]) or "no violation"
    bounds.append(Bound("NMEA numbers not reused within quarantine", ">= 60 s after the last L",
                        f"{final['number_lendings']} lendings, shortest reuse {shortest}; {violations}",
                        not final["number_violations"] and final["number_lendings"] > 0))
    return bounds


def format_bounds(bounds: Sequence[Bound]) -> str:
    lines = ["| bound | limit | measured | result |", "|---|---|---|---|"]
    lines += [f"| {b.name} | {b.bound} | {b.measured} | {'PASS' if b.passed else 'FAIL'} |" for b in bounds]
    return "\n".join(lines)


def plot(samples: list[dict], path: Path, warmup: int) -> None:
    """RSS, fds, threads and per-pair latency against pairs processed."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    x = [s["pairs"] for s in samples]
    fig, axes = plt.subplots(4, 1, figsize=(9, 10), sharex=True)
    panels = [("RSS, MB", [s["rss_kb"] / 1024 for s in samples]), ("open fds", [s["fds"] for s in samples]),
              ("threads", [s["threads"] for s in samples])]
    for ax, (label, y) in zip(axes, panels, strict=False):
        ax.plot(x, y, lw=1)
        ax.set_ylabel(label)
    ax = axes[3]
    for key, label in (("lat_p50_ms", "p50"), ("lat_p99_ms", "p99"), ("lat_max_ms", "max")):
        ax.plot(x, [s[key] for s in samples], lw=0.8, label=label)
    ax.set_yscale("log")
    ax.set_ylabel("latency, ms\n(capture to outputs)")
    ax.legend(loc="upper right", fontsize=8)
    ax.set_xlabel("pairs processed")
    for a in axes:
        a.axvline(warmup, color="grey", ls=":", lw=1)
        a.grid(alpha=0.3)
    axes[0].set_title(f"soak: {x[-1] if x else 0} pairs at full speed (dotted: end of warm-up)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="soak", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--pairs", type=int, default=100_000, help="pairs to process (default 100000)")
    ap.add_argument("--warmup", type=int, default=None, help="warm-up pairs (default: 10%%, at least 2 laps)")
    ap.add_argument("--sample-every", type=int, default=500, help="pairs per sample")
    ap.add_argument("--out", type=Path, default=ROOT / "out" / "soak", help="where the report goes")
    ap.add_argument("--jobs", type=int, default=2, help="processes rendering the lap (once, cached)")
    ap.add_argument("--small", action="store_true", help="the tests' small lap (180x120, 14 s) instead")
    ap.add_argument("--cache", type=Path, default=None, help="rendered laps (default OUT/cache)")
    args = ap.parse_args(argv)
    lap = TEST_LAP if args.small else SOAK_LAP
    warmup = args.warmup if args.warmup is not None else max(2 * lap.pairs, args.pairs // 10)
    bounds, final, samples = run_soak(args.out, args.pairs, lap, warmup=warmup,
                                      sample_every=args.sample_every, cache=args.cache, jobs=args.jobs)
    warmup = final.get("warmup", warmup)
    (args.out / "soak.json").write_text(json.dumps({"bounds": [b.__dict__ for b in bounds], "final": final,
                                                    "warmup": warmup, "lap": lap.name}, indent=1))
    if samples:
        plot(samples, args.out / "soak.png", warmup)
    rate = final.get("steps", 0) / final["wall_s"] if final.get("wall_s") else 0.0
    print(f"soak: {final.get('steps', 0)} pairs in {final.get('wall_s', 0):.0f} s ({rate:.0f} pairs/s), "
          f"lap {lap.name}, warm-up {warmup} pairs; plot {args.out / 'soak.png'}")
    print(format_bounds(bounds))
    return sum(not b.passed for b in bounds)


def _short_soak(workdir: Path) -> list[Row]:
    """800 pairs of the small lap, or of $MAST_FAULTS_RECORDING (the tests' clip, looped)."""
    pairs = 800
    given = os.environ.get("MAST_FAULTS_RECORDING")
    bounds, _, _ = run_soak(workdir, pairs, TEST_LAP, warmup=pairs // 3, sample_every=250, log=False,
                            recording=Path(given) if given else None)
    return [Row(f"soak {pairs} pairs: {b.name}", b.bound, b.measured, b.passed)
            for b in bounds if not b.name.startswith("RSS")]


CASES = [Case("soak-short", "soak", _short_soak, slow=True)]  # renders a lap unless given one
