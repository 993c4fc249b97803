"""`tools/asterix-check RECORDING...`: replay recordings with ASTERIX on and check what a VTS would
decode against the NMEA the same replay sends (its acceptance figures).

Each recording is replayed once (`edge.replay.replay`) writing NMEA and the raw ASTERIX data
blocks; the blocks are decoded by `asterix-decoder` (CroatiaControl, GPL: a test extra, never
imported by the daemon) and every TLL is matched to the CAT 010 target report of the same
exposure (time of day within 1/128 s, the nearest position). Checks, per recording:

- positions: the decoded I010/041 within `MAX_POSITION_M` (1 m) of the TLL position;
- speed and course: decoded I010/200 against TTM's, within TTM's rounding (0.05 kn, 0.05 deg) plus
  half the ASTERIX LSB (2^-14 NM/s = 0.22 kn, 360/2^16 deg); decoded I010/202 (vx east, vy north)
  against TTM's speed and course resolved on east and north, each within half its LSB (0.125 m/s)
  plus what TTM's rounding moves it; I010/200 and /202 absent where TTM has no course (a TTM with
  a speed and no course is counted apart: I010/200 cannot carry a speed alone);
- track numbers: one I010/161 number per track id (the TLL name is TRK + id) for its whole life,
  and no number shared by two tracks (4,095 numbers lent least-recently-used first);
- TRE: each track number's last report has I010/170 TRE set (the replay ends every track at the end),
  and no report before it does (a track ends once, at its drop from the tracker).

Prints one table row per recording and exits 1 if any check fails. `--bench N` also prints
the output's CPU cost per pair with N tracks (the median of 7 runs of 200 pairs). `--live MINUTES`
runs the daemon for that long with ASTERIX to a receiver on loopback and has tshark decode
every datagram (`lab.asterix_live`; `--recording DIR` instead of the demo's, `--out DIR`).
"""

from __future__ import annotations

import argparse
import io
import math
import sys
from collections import defaultdict
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

MAX_POSITION_M = 1.0
SPEED_TOL_KN = 0.05 + 0.5 * 3600.0 / 2**14
COURSE_TOL_DEG = 0.05 + 0.5 * 360.0 / 2**16
TOD_TOL_S = 1 / 128
VELOCITY_LSB_MPS = 0.25  # I010/202, as the specification (and asterix-decoder) read it
KN_PER_MPS = 3600.0 / 1852.0


@dataclass(frozen=True, slots=True)
class Report:
    """One decoded CAT 010 target report."""

    tod_s: float
    number: int
    lat_deg: float
    lon_deg: float
    tre: bool
    cnf: int
    sog_kn: float | None
    cog_deg: float | None
    vx_mps: float | None = None  # I010/202
    vy_mps: float | None = None
    coasting: bool = False  # I010/170 CST not 0


@dataclass(frozen=True, slots=True)
class NmeaUpdate:
    """One TTM + TLL pair of the same track and time."""

    track_id: int
    tod_s: float
    lat_deg: float
    lon_deg: float
    sog_kn: float | None
    cog_deg: float | None


@dataclass
class Check:
    recording: str
    blocks: int = 0
    reports: int = 0
    status_messages: int = 0
    updates: int = 0  # TLLs compared
    unmatched: int = 0  # TLLs without a report of the same time
    max_position_m: float = 0.0
    speed_checked: int = 0
    speed_bad: int = 0
    course_bad: int = 0
    velocity_bad: int = 0  # I010/202 components off TTM's by more than their tolerance
    max_speed_kn: float = 0.0  # largest |I010/200 speed - TTM's|
    max_course_deg: float = 0.0
    max_velocity_mps: float = 0.0  # largest I010/202 component error beyond TTM's own rounding
    speed_only: int = 0  # TTMs with a speed and no course (nothing to compare: I010/200 needs both)
    i200_bad: int = 0  # updates whose I010/200 speed or course is off
    velocity_missing: int = 0  # TTM has speed and course, ASTERIX no I010/200
    velocity_extra: int = 0  # ASTERIX has I010/200, TTM has no course
    tracks: int = 0
    number_changes: int = 0  # track ids seen under more than one number
    shared_numbers: int = 0  # numbers used by two live tracks at once
    numbers_ended: int = 0
    tre_missing: int = 0  # numbers whose last report has no TRE
    tre_midway: int = 0  # TRE reports followed by more reports of the same number
    coasting_midway: int = 0  # coasting reports (CST) followed by more reports of the same number
    largest_block: int = 0
    problems: list[str] = field(default_factory=list)

    @property
    def passed(self) -> bool:
        return (self.unmatched == 0 and self.max_position_m <= MAX_POSITION_M and self.speed_bad == 0
                and self.course_bad == 0 and self.velocity_bad == 0 and self.velocity_missing == 0
                and self.velocity_extra == 0 and self.number_changes == 0 and self.shared_numbers == 0
                and self.tre_missing == 0 and self.tre_midway == 0 and self.largest_block <= 1472)


def split_blocks(data: bytes) -> list[bytes]:
    """Back-to-back data blocks as written by `replay --asterix`."""
    blocks, at = [], 0
    while at < len(data):
        length = int.from_bytes(data[at + 1:at + 3], "big")
        if length < 3 or at + length > len(data):
            raise ValueError(f"bad data block length {length} at byte {at}")
        blocks.append(data[at:at + length])
        at += length
    return blocks


def decode(blocks: Iterable[bytes]) -> tuple[list[Report], list[dict[str, Any]]]:
    """(target reports, other records) as `asterix-decoder` reads them."""
    import asterix  # asterix-decoder: test extra (GPL), imported only here

    reports: list[Report] = []
    others: list[dict[str, Any]] = []
    for block in blocks:
        for rec in asterix.parse(block, verbose=False):
            if rec["category"] == 10 and rec["I000"]["MsgTyp"]["val"] == 1:
                vel, cart = rec.get("I200"), rec.get("I202")
                reports.append(Report(
                    rec["I140"]["ToD"]["val"], rec["I161"]["TrkNb"]["val"], rec["I041"]["Lat"]["val"],
                    rec["I041"]["Lon"]["val"], bool(rec["I170"]["TRE"]["val"]), rec["I170"]["CNF"]["val"],
                    None if vel is None else vel["GS"]["val"] * 3600.0,
                    None if vel is None else vel["TA"]["val"],
                    None if cart is None else cart["Vx"]["val"], None if cart is None else cart["Vy"]["val"],
                    bool(rec["I170"]["CST"]["val"])))
            else:
                others.append(rec)
    return reports, others


def velocity_error_mps(report: Report, sog_kn: float, cog_deg: float) -> float | None:
    """The larger I010/202 component error against TTM's speed and course resolved on east and
    north, less what TTM's own rounding (0.05 kn, 0.05 deg) can move a component; None without
    I010/202. Within half the LSB (0.125 m/s) is a pass."""
    if report.vx_mps is None or report.vy_mps is None:
        return None
    v, c = sog_kn / KN_PER_MPS, math.radians(cog_deg)
    rounding = 0.05 / KN_PER_MPS + v * math.radians(0.05)
    err = max(abs(report.vx_mps - v * math.sin(c)), abs(report.vy_mps - v * math.cos(c)))
    return max(0.0, err - rounding)


def _hms_s(text: str) -> float:
    return int(text[0:2]) * 3600 + int(text[2:4]) * 60 + float(text[4:])


def _latlon(value: str, hemi: str, deg_digits: int) -> float:
    deg = int(value[:deg_digits]) + float(value[deg_digits:]) / 60.0
    return -deg if hemi in "SW" else deg


def nmea_updates(text: str) -> list[NmeaUpdate]:
    """TTM/TLL pairs (matched by target number and time) as updates; track id from the name TRK<id>."""
    ttm: dict[tuple[str, str], tuple[float | None, float | None]] = {}
    out = []
    for line in text.splitlines():
        body = line.strip().split("*")[0]
        f = body.split(",")
        if f[0].endswith("TTM"):
            ttm[(f[1], f[14])] = (float(f[5]) if f[5] else None, float(f[6]) if f[6] else None)
        elif f[0].endswith("TLL") and f[6].startswith("TRK"):
            sog, cog = ttm.get((f[1], f[7]), (None, None))
            out.append(NmeaUpdate(int(f[6][3:]), _hms_s(f[7]), _latlon(f[2], f[3], 2),
                                  _latlon(f[4], f[5], 3), sog, cog))
    return out


def _metres(lat1: float, lon1: float, lat2: float, lon2: float) -> float:
    """Small distances on the sphere of mean radius (enough at 1 m against rounding of 0.2 m)."""
    r = 6_371_008.8
    dn = math.radians(lat2 - lat1) * r
    de = math.radians(lon2 - lon1) * r * math.cos(math.radians(0.5 * (lat1 + lat2)))
    return math.hypot(dn, de)


def compare(name: str, blocks: Sequence[bytes], nmea: str) -> Check:
    """All the checks of the module docstring for one replay's blocks and NMEA."""
    check = Check(name, blocks=len(blocks), largest_block=max((len(b) for b in blocks), default=0))
    reports, others = decode(blocks)
    check.reports, check.status_messages = len(reports), len(others)
    by_tod: dict[int, list[Report]] = defaultdict(list)
    for r in reports:
        by_tod[round(r.tod_s * 128)].append(r)
    numbers_of: dict[int, set[int]] = defaultdict(set)
    for u in nmea_updates(nmea):
        check.updates += 1
        key = round(u.tod_s * 128)
        near = [r for k in (key - 1, key, key + 1) for r in by_tod.get(k, [])
                if abs(r.tod_s - u.tod_s) <= TOD_TOL_S]
        if not near:
            check.unmatched += 1
            continue
        best = min(near, key=lambda r: _metres(r.lat_deg, r.lon_deg, u.lat_deg, u.lon_deg))
        d_m = _metres(best.lat_deg, best.lon_deg, u.lat_deg, u.lon_deg)
        check.max_position_m = max(check.max_position_m, d_m)
        numbers_of[u.track_id].add(best.number)
        if u.sog_kn is not None and u.cog_deg is not None:
            if best.sog_kn is None or best.cog_deg is None:
                check.velocity_missing += 1
                continue
            check.speed_checked += 1
            ds = abs(best.sog_kn - u.sog_kn)
            dc = abs((best.cog_deg - u.cog_deg + 180.0) % 360.0 - 180.0)
            check.speed_bad += ds > SPEED_TOL_KN
            check.course_bad += dc > COURSE_TOL_DEG
            check.i200_bad += ds > SPEED_TOL_KN or dc > COURSE_TOL_DEG
            check.max_speed_kn = max(check.max_speed_kn, ds)
            check.max_course_deg = max(check.max_course_deg, dc)
            dv = velocity_error_mps(best, u.sog_kn, u.cog_deg)
            check.velocity_bad += dv is None or dv > VELOCITY_LSB_MPS / 2
            check.max_velocity_mps = max(check.max_velocity_mps, math.inf if dv is None else dv)
        elif u.cog_deg is None and (best.cog_deg is not None or best.vx_mps is not None):
            check.velocity_extra += 1
        if u.sog_kn is not None and u.cog_deg is None:
            check.speed_only += 1
    check.tracks = len(numbers_of)
    check.number_changes = sum(len(n) > 1 for n in numbers_of.values())
    owners: dict[int, set[int]] = defaultdict(set)
    for tid, nums in numbers_of.items():
        for n in nums:
            owners[n].add(tid)
    # 4,095 numbers lent least-recently-used first: within a recording no number serves two tracks
    check.shared_numbers = sum(len(t) > 1 for t in owners.values())
    by_number: dict[int, list[Report]] = defaultdict(list)
    for r in reports:
        by_number[r.number].append(r)
    check.numbers_ended = len(by_number)
    for rs in by_number.values():
        check.tre_missing += not rs[-1].tre
        check.tre_midway += sum(r.tre for r in rs[:-1])
        check.coasting_midway += sum(r.coasting for r in rs[:-1])
    return check


def check_recording(root: Path, config: Path | None = None) -> Check:
    from edge.replay import replay

    nmea, blocks = io.StringIO(), io.BytesIO()
    replay(root, config_path=config, nmea=nmea, asterix=blocks)
    return compare(root.name, split_blocks(blocks.getvalue()), nmea.getvalue())


HEADER = ("recording", "blocks", "reports", "TLLs", "max d m", "I200 ok", "max dSOG kn", "max dCOG deg",
          "I202 ok", "SOG only", "tracks", "nr changes", "TRE last", "TRE mid", "max block B", "result")


def row(c: Check) -> tuple[str, ...]:
    n = c.speed_checked
    extra = (f" (miss {c.velocity_missing}, extra {c.velocity_extra})"
             if c.velocity_missing or c.velocity_extra else "")
    return (c.recording, str(c.blocks), str(c.reports), f"{c.updates - c.unmatched}/{c.updates}",
            f"{c.max_position_m:.3f}", f"{n - c.i200_bad}/{n}{extra}",
            f"{c.max_speed_kn:.3f}" if n else "-", f"{c.max_course_deg:.4f}" if n else "-",
            f"{n - c.velocity_bad}/{n}", str(c.speed_only),
            str(c.tracks), str(c.number_changes), f"{c.numbers_ended - c.tre_missing}/{c.numbers_ended}",
            str(c.tre_midway), str(c.largest_block), "PASS" if c.passed else "FAIL")


def bench_publish(tracks: int = 32, steps: int = 200, repeats: int = 7) -> tuple[float, float]:
    """(median CPU ms per `AsterixOutput.publish` of `tracks` fixes with speed, course and length,
    median CPU us per target report): the cost the output adds to each pair."""
    import time

    from edge.config.asterix import AsterixConfig
    from edge.encode.asterix import cat010
    from edge.fix import ShipFix, TrackStatus
    from edge.outputs.asterix import AsterixOutput

    t0 = 1_700_000_000 * 10**9
    now = [0.0]
    out = AsterixOutput(AsterixConfig(enabled=True), clock=lambda: now[0])
    frames = [[ShipFix(t0 + k * 100_000_000, t, TrackStatus.TRACKING, 0.0, 0.0, 0.0, 1000.0 + 50 * t, 3.0 * t,
                       34.6 + 1e-3 * t, 135.0, 12.0, 45.0, 8.0, 20.0, length_m=80.0, sigma_across_m=0.5)
               for t in range(1, tracks + 1)] for k in range(steps)]
    per_step, per_record = [], []
    for _ in range(repeats):
        start = time.process_time()
        for fixes in frames:
            now[0] += 0.1
            out.publish(fixes, t0)
        per_step.append((time.process_time() - start) / steps * 1e3)
        start = time.process_time()
        for fix in frames[0]:
            cat010.target_report(fix, 1, out.source)
        per_record.append((time.process_time() - start) / tracks * 1e6)
    return sorted(per_step)[repeats // 2], sorted(per_record)[repeats // 2]


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("recordings", nargs="*", type=Path, metavar="RECORDING")
    parser.add_argument("--config", type=Path, help="configuration (outputs.asterix, pipeline settings)")
    parser.add_argument("--bench", type=int, metavar="TRACKS",
                        help="also print the output's CPU cost per pair with this many tracks")
    parser.add_argument("--live", type=float, metavar="MINUTES",
                        help="run the daemon this long with ASTERIX to loopback; tshark decodes what arrived")
    parser.add_argument("--recording", type=Path, help="--live: the recording the daemon replays "
                        "(default: the demo's, out/demo/akashi-crossing, rendered if missing)")
    parser.add_argument("--out", type=Path,
                        help="--live: where the config, log and pcap go (out/asterix-live)")
    args = parser.parse_args(argv)
    if args.live:
        from lab import asterix_live

        out = args.out or asterix_live.ROOT / "out" / "asterix-live"
        return asterix_live.main(args.live, args.recording, out)
    if args.bench:
        step_ms, record_us = bench_publish(args.bench)
        print(f"ASTERIX publish, {args.bench} tracks: {step_ms:.3f} ms CPU per pair, "
              f"{record_us:.1f} us a report")
    checks = [check_recording(r, args.config) for r in args.recordings]
    rows = [HEADER] + [row(c) for c in checks]
    widths = [max(len(r[k]) for r in rows) for k in range(len(HEADER))]
    for r in rows:
        print("  ".join(v.ljust(w) for v, w in zip(r, widths, strict=True)))
    return 0 if all(c.passed for c in checks) else 1


if __name__ == "__main__":
    sys.exit(main())
