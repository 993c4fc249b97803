"""The `recording-damage` case of `lab.faults.inputs`: damaged recordings through `mast-stereo replay`.

A short recording is simulated (akashi-crossing, one ship; rendering is the slow part, so the
pytest runner passes the one the replay tests render) and replayed clean; a copy gets every
kind of damage in the first half, rows apart (docs/recordings.md's format: frames.csv rows,
left/ and right/ PNGs): truncated PNGs, missing PNG files, rows missing from frames.csv (a
sequence gap), timestamps going back and one stamp far ahead of its sequence number. A real
`mast-stereo replay` subprocess plays it: exit 0, no traceback, the summary on stderr counts
each damage (skipped / dropped / time going back, as the recording contract and edge.replay
say), and every fix after the damage has settled matches the clean replay's fix at the same
time within the fixes' own sigma (nothing after the damage is silently wrong). A recording
whose frames.csv is garbage is not a recording: exit 78 with one line naming the file.
"""

from __future__ import annotations

import csv
import io
import shutil
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

from edge.errors import EX_CONFIG
from edge.replay import replay
from edge.sim.render_recording import write_recording
from edge.sim.scenario import load_scenario
from edge.sim.simulator import Simulation
from lab.faults.matrix import Row

FRAMES = 30  # the recording tests/edge/test_replay.py renders too (the pytest runner shares it)
SETTLE = 22  # every damage is in pairs < 15; fixes from pair 22 on must match the clean replay


def render_clean(out: Path) -> Path:
    """The undamaged recording (slow: ~1 s a frame on a loaded machine; the tests pass theirs)."""
    write_recording(Simulation(load_scenario("akashi-crossing"), seed=0), out, frames=FRAMES, jobs=1)
    return out


def _replay(rec: Path) -> tuple[int, str, dict[tuple[int, int], dict[str, str]]]:
    """(exit status, stderr, fixes keyed by (t_ns, track_id)) of `mast-stereo replay`."""
    tracks = rec.parent / f"{rec.name}.csv"
    args = ["replay", str(rec), "--nmea", str(rec.parent / "n"), "--tracks", str(tracks)]
    out = subprocess.run([sys.executable, "-m", "edge.cli", *args], capture_output=True, text=True,
                         timeout=300)
    fixes = {}
    if tracks.is_file():
        for row in csv.DictReader(io.StringIO(tracks.read_text())):
            fixes[(int(row["t_ns"]), int(row["track_id"]))] = row
    return out.returncode, out.stderr, fixes


def _rows(rec: Path) -> list[list[str]]:
    return list(csv.reader(io.StringIO((rec / "frames.csv").read_text())))


def _write_rows(rec: Path, rows: list[list[str]]) -> None:
    (rec / "frames.csv").write_text("\n".join(",".join(r) for r in rows) + "\n")


def _truncate_and_remove(rec: Path) -> None:
    for side, index in (("left", 2), ("right", 4)):
        png = rec / side / f"{index:06d}.png"
        png.write_bytes(png.read_bytes()[: png.stat().st_size // 3])
    (rec / "right" / "000005.png").unlink()
    (rec / "left" / "000007.png").unlink()


def _gap(rec: Path) -> None:
    rows = _rows(rec)
    _write_rows(rec, [r for r in rows if r[0] not in {"9", "10", "11", "12"}])  # 4 pairs lost


def _backwards(rec: Path) -> None:
    rows = _rows(rec)
    by_index = {r[0]: r for r in rows}
    for index in ("3", "6"):  # stamped a second early
        by_index[index][1] = str(int(by_index[index][1]) - 10**9)
    by_index["14"][1] = str(int(by_index["14"][1]) + 3600 * 10**9)  # an hour ahead
    _write_rows(rec, rows)


DAMAGES: list[tuple[str, Callable[[Path], None], str]] = [
    ("2 truncated PNGs + 2 files missing", _truncate_and_remove, "skipped (unreadable) 4"),
    ("4 rows missing (sequence gap)", _gap, "dropped (sequence gaps) 4"),
    ("3 timestamps back / far ahead", _backwards, "skipped (time going back) 3"),
]


def _compare(clean: dict, damaged: dict, t_settle_ns: int) -> tuple[int, int, float]:
    """(fixes after settling, of them off by more than 3 sigma, worst |d range| / sigma)."""
    after = [k for k in damaged if k[0] >= t_settle_ns]
    bad, worst = 0, 0.0
    for key in after:
        ref = clean.get(key)
        if ref is None:
            bad += 1
            continue
        sigma = max(float(ref["sigma_m"]), float(damaged[key]["sigma_m"]), 1e-6)
        ratio = abs(float(damaged[key]["range_m"]) - float(ref["range_m"])) / sigma
        worst = max(worst, ratio)
        bad += ratio > 3.0
    return len(after), bad, worst


def recording_damage(workdir: Path, clean: Path | None = None) -> list[Row]:
    """All four damages in one copy of the recording (rows apart), replayed by the real CLI."""
    clean = clean if clean is not None else render_clean(workdir / "clean")
    nmea, tracks = io.StringIO(), io.StringIO()
    replay(clean, nmea=nmea, tracks=tracks)
    clean_fixes = {(int(r["t_ns"]), int(r["track_id"])): r
                   for r in csv.DictReader(io.StringIO(tracks.getvalue()))}
    t_settle_ns = int(_rows(clean)[1 + SETTLE][1])
    rec = workdir / "damaged"
    shutil.copytree(clean, rec)
    for _, damage, _ in DAMAGES:
        damage(rec)
    rc, err, fixes = _replay(rec)
    after, off, worst = _compare(clean_fixes, fixes, t_settle_ns)
    summary = next((line for line in err.splitlines() if "pairs in recording" in line), err.strip()[-120:])
    clean_run = rc == 0 and "Traceback" not in err
    rows = [Row(name, f"counted: '{counted}'", summary.removeprefix("mast-stereo replay: ")
                if k == 0 else f"'{counted}' in the summary", clean_run and counted in err)
            for k, (name, _, counted) in enumerate(DAMAGES)]
    rows.append(Row("after the damage", "exit 0, later fixes = clean replay within 3 sigma",
                    f"exit {rc}; {after} fixes from pair {SETTLE} on, {off} off by > 3 sigma "
                    f"(worst {worst:.2f} sigma)", clean_run and after > 0 and off == 0))
    broken = workdir / "broken"
    shutil.copytree(clean, broken)
    (broken / "frames.csv").write_bytes(b"index,t_ns\n\x00\xff garbage\n")
    rc, err, _ = _replay(broken)
    lines = err.strip().splitlines()
    shown = lines[-1][:120] if lines else "(nothing)"
    rows.append(Row("frames.csv garbage", "exit 78, one line naming the file", f"exit {rc}: {shown}",
                    rc == EX_CONFIG and len(lines) == 1 and "frames.csv" in lines[0]))
    return rows
