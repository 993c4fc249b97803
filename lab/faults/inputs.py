"""Fault cases for the inputs: hostile configuration and calibration files, damaged recordings.

- `config-fuzz`: thousands of mutated configurations and calibrations (`lab.faults._fuzz`:
  wrong types, missing and extra keys, numbers out of range, nesting) and files that are not
  YAML at all, through the daemon's own validating functions in-process; then real
  `mast-stereo run` and `check-config` subprocesses on a few of them. Every outcome must be
  acceptance or exit 78 with one line naming the file (and the key, for a mapping), never a
  traceback.
- `recording-damage`: a short simulated recording with truncated PNGs, missing frames, a row
  whose files are gone and timestamps that go backwards, replayed by `mast-stereo replay`:
  each damage is reported (counted and skipped, per the recording contract), the exit status is
  0, and the fixes after the damage match those of the undamaged replay.
"""

from __future__ import annotations

import random
import shutil
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from edge.appliance.sources import plan_source
from edge.config.app import config_from_dict, load_config
from edge.config.calibration import calibration_from_dict, load_calibration
from edge.errors import EX_CONFIG
from lab.faults import _fuzz as fuzz
from lab.faults._recording import recording_damage
from lab.faults.matrix import Case, Row

ROOT = Path(__file__).resolve().parents[2]
CONFIG_DIR = ROOT / "config"


@dataclass(frozen=True)
class FuzzBase:
    """One kind of validated file: a valid example, its validating function on a parsed mapping
    (what the hypothesis test and the mutations call) and on a file, and the files an error may
    name (the calibration a configuration names, besides the configuration)."""

    name: str
    path: Path  # where mutated files are written
    valid: dict[str, Any]
    from_dict: Callable[[Any, Path], object]
    from_file: Callable[[Path], object]
    files: tuple[Path, ...]


def _plan(config: Any, path: Path) -> object:
    return plan_source(config, path)  # for virtual cameras: loads the scenario; no device


def fuzz_bases(workdir: Path) -> list[FuzzBase]:
    """The demo configuration (virtual cameras, with the scenario loaded as `run` does), the
    installed unit's example (v4l2: checked without opening a device) and a calibration."""
    cal = workdir / "calibration.yaml"
    shutil.copy(CONFIG_DIR / "calibration/akashi-pinhole.yaml", cal)
    demo, mast, calib = workdir / "demo.yaml", workdir / "mast.yaml", workdir / "calib.yaml"

    def valid(source: str) -> dict[str, Any]:
        return yaml.safe_load((CONFIG_DIR / source).read_text())

    return [
        FuzzBase("demo config", demo, valid("demo.yaml"), lambda d, p: _plan(config_from_dict(d, p), p),
                 lambda p: _plan(load_config(p), p), (demo, cal)),
        FuzzBase("mast config", mast, valid("mast.example.yaml"), config_from_dict, load_config, (mast, cal)),
        FuzzBase("calibration", calib, valid("calibration/akashi-pinhole.yaml"), calibration_from_dict,
                 load_calibration, (calib,)),
    ]


def check_mapping(base: FuzzBase, data: dict[str, Any]) -> fuzz.Verdict:
    return fuzz.verdict(lambda: base.from_dict(data, base.path), base.files, need_key=True)


def check_bytes(base: FuzzBase, raw: bytes) -> fuzz.Verdict:
    base.path.write_bytes(raw)
    return fuzz.verdict(lambda: base.from_file(base.path), base.files, need_key=False)


def _in_process(workdir: Path, mutations: int, blobs: int, seed: int) -> list[Row]:
    rows = []
    for base in fuzz_bases(workdir):
        rng = random.Random(seed)
        valid_bytes = yaml.safe_dump(base.valid).encode()
        bugs: list[str] = []
        accepted = refused = 0
        t0 = time.monotonic()
        for k in range(mutations + blobs):
            if k < mutations:
                data, what = fuzz.mutate(base.valid, rng)
                v = check_mapping(base, data)
            else:
                what, v = "bytes", check_bytes(base, fuzz.hostile_bytes(rng, valid_bytes))
            accepted, refused = accepted + v.accepted, refused + (v.ok and not v.accepted)
            if not v.ok and len(bugs) < 3:
                bugs.append(f"{what}: {v.text}")
        rows.append(Row(f"{base.name}: {mutations} mutations + {blobs} files",
                        "accepted, or one line naming file and key",
                        f"{accepted} accepted, {refused} refused cleanly in {time.monotonic() - t0:.1f} s"
                        + (f"; BUG {bugs[0]}" if bugs else ""), not bugs))
    return rows


def _subprocess_rows(workdir: Path) -> list[Row]:
    """A few real runs: exit status 78 and exactly one line on stderr, naming the file."""
    demo = fuzz_bases(workdir)[0].path
    cal_path = workdir / "calibration.yaml"
    shutil.copy(CONFIG_DIR / "scenarios/akashi-crossing.yaml", workdir / "akashi-crossing.yaml")
    bad_cal = yaml.safe_load(cal_path.read_text())
    bad_cal["cameras"]["left"]["fx"] = "fast"
    cases = [
        ("random bytes", "run", demo, random.Random(3).randbytes(200), demo),
        ("wrong type", "run", demo, b"version: 1\npipeline: {window: [15]}\n", demo),
        ("deep nesting", "check-config", demo, b"[" * 5000, demo),
        ("bad calibration key", "run", demo,
         b"version: 1\ncameras: {kind: virtual, scenario: akashi-crossing.yaml}\n"
         b"calibration: calibration.yaml\n",
         cal_path),
    ]
    rows = []
    for what, command, path, content, named in cases:
        path.write_bytes(content)
        if what == "bad calibration key":
            cal_path.write_text(yaml.safe_dump(bad_cal))
        args = [sys.executable, "-m", "edge.cli", command, "--config", str(path)]
        if command == "run":
            args += ["--seconds", "0.5"]
        out = subprocess.run(args, capture_output=True, text=True, timeout=120, cwd=workdir)
        lines = out.stderr.strip().splitlines()
        ok = out.returncode == EX_CONFIG and len(lines) == 1 and str(named) in lines[0] \
            and "Traceback" not in out.stderr
        rows.append(Row(f"mast-stereo {command}: {what}", "exit 78, one line naming the file",
                        f"exit {out.returncode}: {lines[-1] if lines else '(nothing)'}"[:200], ok))
    return rows


def config_fuzz(workdir: Path, mutations: int = 300, blobs: int = 60) -> list[Row]:
    return _in_process(workdir, mutations, blobs, seed=15) + _subprocess_rows(workdir)


CASES = [
    Case("config-fuzz", "inputs", config_fuzz),
    Case("recording-damage", "inputs", recording_damage),
]
