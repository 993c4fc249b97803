"""The fault matrix: what a case is, how cases are found, and the table `tools/faults` prints.

A `Case` injects one fault (or one family: left, right, both) into a running daemon or a
command and returns one `Row` per observation: what was expected, what was seen, PASS or
FAIL, and how long recovery took. Cases live in the other modules of `lab.faults`, each
exporting `CASES: list[Case]`; `all_cases` finds them, so adding a group touches no
registry. A case that needs what this machine lacks (the appliance VM, socat) returns
rows with `skipped` set to the reason instead of failing.
"""

from __future__ import annotations

import argparse
import importlib
import json
import pkgutil
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path


@dataclass(frozen=True)
class Row:
    """One observation of one fault."""

    fault: str  # what was done, e.g. "left camera unplugged 2 s"
    expected: str  # what the unit must do
    observed: str  # what it did, with the figures behind the verdict
    passed: bool
    recovery_s: float | None = None  # time from the fault's end to normal again, where that applies
    skipped: str = ""  # why the case could not run here (then `passed` is not a verdict)

    @property
    def verdict(self) -> str:
        return "SKIP" if self.skipped else ("PASS" if self.passed else "FAIL")


@dataclass(frozen=True)
class Case:
    """A named fault family; `run(workdir)` injects it and returns its rows."""

    name: str  # slug for --only and pytest ids, e.g. "camera-unplug"
    group: str  # module-level grouping shown in the table, e.g. "cameras"
    run: Callable[[Path], list[Row]]
    slow: bool = False  # needs the appliance VM or many seconds; `tools/faults --quick` leaves it out


def all_cases() -> list[Case]:
    """Every module of this package's `CASES`, in module then list order."""
    import lab.faults as pkg

    cases: list[Case] = []
    for info in sorted(pkgutil.iter_modules(pkg.__path__), key=lambda i: i.name):
        if info.name == "matrix" or info.name.startswith("_"):
            continue
        module = importlib.import_module(f"lab.faults.{info.name}")
        cases.extend(getattr(module, "CASES", []))
    return cases


def run_case(case: Case, workdir: Path) -> list[Row]:
    """Run one case; an exception inside it is a FAIL row naming it, never a crash of the matrix."""
    try:
        rows = case.run(workdir)
    except Exception as exc:  # noqa: BLE001 - the matrix reports every failure as a row
        rows = [Row(case.name, "case runs", f"{type(exc).__name__}: {exc}", False)]
    return rows or [Row(case.name, "case reports", "no rows", False)]


def failures(rows: Sequence[Row]) -> list[str]:
    """One line per FAIL row (a skipped row is not a verdict): what was expected and what was seen."""
    return [f"{r.fault}: expected {r.expected}; observed {r.observed}"
            for r in rows if not r.passed and not r.skipped]


def format_table(results: Sequence[tuple[Case, list[Row]]]) -> str:
    """The matrix as a fixed-width text table, one line per row."""
    lines = [f"{'group':<10} {'fault':<40} {'expected':<44} {'observed':<52} {'result':<6} recovery"]
    for case, rows in results:
        for r in rows:
            rec = "" if r.recovery_s is None else f"{r.recovery_s:.2f} s"
            obs = r.skipped if r.skipped else r.observed
            lines.append(f"{case.group:<10} {r.fault:<40} {r.expected:<44} {obs:<52} {r.verdict:<6} {rec}")
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> int:
    """`tools/faults`: run the matrix, print it; exit status = number of FAIL rows (0 = all pass)."""
    ap = argparse.ArgumentParser(prog="faults", description=__doc__)
    ap.add_argument("--only", nargs="*", default=None, help="case names to run (default: all)")
    ap.add_argument("--quick", action="store_true", help="leave out the slow cases (VM, long runs)")
    ap.add_argument("--list", action="store_true", help="list the cases and exit")
    ap.add_argument("--json", action="store_true", help="print the rows as JSON instead of a table")
    args = ap.parse_args(argv)
    cases = [c for c in all_cases()
             if (args.only is None or c.name in args.only) and not (args.quick and c.slow)]
    if args.list:
        for c in cases:
            print(f"{c.group:<10} {c.name}{'  (slow)' if c.slow else ''}")
        return 0
    if args.only and len(cases) != len(set(args.only)):
        unknown = sorted(set(args.only) - {c.name for c in cases})
        print(f"faults: unknown case(s): {', '.join(unknown)}", file=sys.stderr)
        return 2
    results: list[tuple[Case, list[Row]]] = []
    for case in cases:
        t0 = time.monotonic()
        with tempfile.TemporaryDirectory(prefix=f"faults-{case.name}-") as tmp:
            rows = run_case(case, Path(tmp))
        results.append((case, rows))
        if not args.json:
            print(f"[{case.name}: {time.monotonic() - t0:.1f} s]", file=sys.stderr)
    if args.json:
        print(json.dumps([{"group": c.group, "case": c.name, **asdict(r), "verdict": r.verdict}
                          for c, rows in results for r in rows], indent=1))
    else:
        print(format_table(results))
    return sum(len(failures(rows)) for _, rows in results)
