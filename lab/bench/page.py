"""What the maintenance page costs the daemon: pairs per second with the page open, start-up and memory.

    tools/bench-page RECORDING [--seconds 20] [--rounds 2] [--screenshot PNG]

Each run is a real `mast-stereo run` replaying RECORDING as fast as it can (`pace: false`: the
pair rate is the processing rate, the number a page could lower), for --seconds, in three set-ups
alternated --rounds times so drift on a shared machine hits all alike: the page off; the page on
with nobody looking; the page on with a viewer that does what the page's script does (state.json
every 0.5 s, both pictures at each new number, /metrics every 5 s like a scraper). The pair rate is
the daemon's own count at exit over the run's length; beside it the daemon's own CPU time per
pair (user + system, from wait4), which other jobs on the machine do not disturb. Start-up is
the time from exec to READY=1 (sd_notify, on a socket this tool listens on), memory the peak
RSS (VmHWM) at exit; both for the page off and on. --screenshot instead opens the page in
headless Chromium and writes a small PNG of it (docs/page.png).
"""

from __future__ import annotations

import argparse
import json
import os
import re
import statistics
import subprocess
import sys
import tempfile
import threading
import time
import urllib.request
from collections.abc import Sequence
from pathlib import Path

import yaml

from lab.faults._rig import NotifyListener, free_port

SETUPS = ("page off", "page on, nobody looking", "page on, viewer")


def write_config(workdir: Path, recording: Path, port: int, page: bool, pace: bool,
                 modbus_port: int | None = None) -> Path:
    modbus = {"enabled": modbus_port is not None, "port": modbus_port or 1502}
    cfg = {"cameras": {"kind": "replay", "path": str(recording), "pace": pace, "loop": True},
           "outputs": {"modbus": {"tcp": modbus}},
           "health": {"require_clock_sync": False, "min_fps": 0.0, "leds": {"kind": "none"},
                      "state_dir": str(workdir / "state"), "stale_s": 10.0},
           "page": {"enabled": page, "port": port, "docs_dir": None}}
    path = workdir / f"bench-{port}.yaml"
    path.write_text(yaml.safe_dump(cfg))
    return path


def viewer(port: int, stop: threading.Event) -> None:
    """Polls as the page's script does (and a scraper), until `stop`."""
    base = f"http://127.0.0.1:{port}"
    seen, last_metrics = 0, 0.0
    while not stop.is_set():
        try:
            with urllib.request.urlopen(f"{base}/state.json", timeout=5) as r:
                seq = int(json.loads(r.read())["pictures"].get("left", 0))
            if seq != seen:
                seen = seq
                for side in ("left", "right"):
                    with urllib.request.urlopen(f"{base}/{side}.jpg?n={seq}", timeout=5) as r:
                        r.read()
            if time.monotonic() - last_metrics > 5:
                last_metrics = time.monotonic()
                with urllib.request.urlopen(f"{base}/metrics", timeout=5) as r:
                    r.read()
        except OSError:
            pass
        stop.wait(0.5)


def run_once(workdir: Path, recording: Path, setup: str, seconds: float, pace: bool = False
             ) -> dict[str, float]:
    """One daemon run: pairs/s, seconds to READY=1, peak RSS MiB."""
    port = free_port()
    config = write_config(workdir, recording, port, page=setup != "page off", pace=pace)
    notify = NotifyListener(workdir / f"notify-{port}.sock")  # read all along: a full queue blocks the daemon
    t0 = time.monotonic()
    proc = subprocess.Popen([sys.executable, "-m", "edge.cli", "run", "--config", str(config), "--seconds",
                             str(seconds)], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                            env={**os.environ, "NOTIFY_SOCKET": notify.path})
    ready = notify.wait_for("READY=1", t0)
    ready_s = float("nan") if ready is None else ready - t0
    stop = threading.Event()
    watcher = threading.Thread(target=viewer, args=(port, stop), daemon=True)
    if setup == "page on, viewer":
        watcher.start()
    errors: list[str] = []
    reader = threading.Thread(target=lambda: errors.append(proc.stderr.read() if proc.stderr else ""))
    reader.start()
    peak_kib = 0
    while True:
        try:
            status = Path(f"/proc/{proc.pid}/status").read_text()
            peak_kib = max(peak_kib, int(re.search(r"VmHWM:\s+(\d+)", status).group(1)))  # type: ignore[union-attr]
        except (OSError, AttributeError):
            pass
        pid, _, usage = os.wait4(proc.pid, os.WNOHANG)  # the daemon's own CPU time, whatever else runs
        if pid:
            break
        time.sleep(0.2)
    proc.returncode = 0
    stop.set()
    notify.close()
    reader.join()
    err = errors[0] if errors else ""
    found = re.search(r"stopped: (\d+) pairs processed", err)
    if found is None:
        raise RuntimeError(f"the daemon did not report its pairs: {err[-500:]}")
    pairs = int(found.group(1))
    return {"pairs_hz": pairs / seconds, "ready_s": ready_s, "rss_mib": peak_kib / 1024,
            "cpu_ms_per_pair": 1000 * (usage.ru_utime + usage.ru_stime) / max(1, pairs)}


def measure(recording: Path, seconds: float, rounds: int) -> dict[str, list[dict[str, float]]]:
    results: dict[str, list[dict[str, float]]] = {s: [] for s in SETUPS}
    with tempfile.TemporaryDirectory(prefix="bench-page-") as tmp:
        for _ in range(rounds):
            for setup in SETUPS:
                results[setup].append(run_once(Path(tmp), recording, setup, seconds))
    return results


def format_table(results: dict[str, list[dict[str, float]]]) -> str:
    lines = [f"{'set-up':<26} {'pairs/s (each run)':<22} {'mean':>7} {'vs off':>7} {'CPU ms/pair':>12} "
             f"{'READY s':>8} {'peak RSS MiB':>13}"]
    base = statistics.mean(r["pairs_hz"] for r in results["page off"])
    for setup, runs in results.items():
        rates = [r["pairs_hz"] for r in runs]
        mean = statistics.mean(rates)
        lines.append(f"{setup:<26} {' '.join(f'{x:.1f}' for x in rates):<22} {mean:>7.1f} "
                     f"{100 * (mean - base) / base:>+6.1f}% "
                     f"{statistics.mean(r['cpu_ms_per_pair'] for r in runs):>12.2f} "
                     f"{statistics.mean(r['ready_s'] for r in runs):>8.2f} "
                     f"{statistics.mean(r['rss_mib'] for r in runs):>13.0f}")
    return "\n".join(lines)


def screenshot(recording: Path, out: Path, width_px: int = 900) -> None:
    """The page of a paced replay in headless Chromium, saved small (a palette PNG, `width_px` wide)."""
    from PIL import Image

    from lab.page_browser import open_page

    with tempfile.TemporaryDirectory(prefix="page-shot-") as tmp:
        port = free_port()
        config = write_config(Path(tmp), recording, port, page=True, pace=True, modbus_port=free_port())
        proc = subprocess.Popen([sys.executable, "-m", "edge.cli", "run", "--config", str(config)],
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        try:
            time.sleep(8)  # a few seconds of tracking first
            raw = Path(tmp) / "raw.png"
            open_page(f"http://127.0.0.1:{port}/", raw, min_loads=3, timeout_s=30, window=(1200, 1100))
        finally:
            proc.terminate()
            proc.wait(timeout=20)
        image = Image.open(raw).convert("RGB")
        size = (width_px, round(image.height * width_px / image.width))
        image = image.resize(size, Image.Resampling.LANCZOS)
        image.quantize(colors=64, method=Image.Quantize.MEDIANCUT).save(out, optimize=True)


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="bench-page", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("recording", type=Path, help="a recording directory (mast-stereo simulate/record)")
    ap.add_argument("--seconds", type=float, default=20.0, help="length of each run (default 20)")
    ap.add_argument("--rounds", type=int, default=2, help="runs of each set-up (default 2)")
    ap.add_argument("--screenshot", type=Path, metavar="PNG", help="only write a screenshot of the page")
    args = ap.parse_args(argv)
    if args.screenshot is not None:
        screenshot(args.recording, args.screenshot)
        print(f"{args.screenshot}: {args.screenshot.stat().st_size // 1024} KiB")
        return 0
    print(format_table(measure(args.recording, args.seconds, args.rounds)))
    return 0
