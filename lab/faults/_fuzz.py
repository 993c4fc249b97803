"""Configuration and calibration fuzzing for the `config-fuzz` fault case and its hypothesis test.

`mutate(data, rng)` changes one thing in a valid YAML mapping: a value of the wrong type, a
missing key, an extra key, a number out of range (or not finite, or huge), a value nested in a
list or mapping, a null, a non-string key. `hostile_bytes(rng)` makes files that are not
configurations at all: random bytes, NULs, a BOM, undecodable UTF-8, deep nesting, alias bombs,
Python tags. `verdict(load, files, need_key)` runs the validating function the daemon uses and says
whether it behaved: accepted, or one `ConfigError` whose message is a single line naming a file
(the configuration or the calibration it names) and, for a well-formed mapping, a key; anything
else (another exception, a multi-line message) is a bug. The rng is a `random.Random`, so the
fault case is reproducible from a seed and hypothesis (`st.randoms()`) can drive and shrink it.
"""

from __future__ import annotations

import copy
import random
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from edge.errors import ConfigError

WRONG_VALUES: tuple[Any, ...] = (
    0, -1, 1.5, -1e-300, 1e308, float("nan"), float("inf"), -float("inf"), True, False, "", "x" * 300,
    "0x10", "1e3", [], {}, [1, 2, 3], {"a": 1}, None, 2**70, -(2**70), "ñ\u202e\x07", [[[]]],
)
EXTRA_KEYS: tuple[Any, ...] = ("extra", "Version", "", "cameras ", "kind", 1, 3.5, True, None, "a" * 200)
SCALES = (-1.0, 0.0, 1e-9, 1e6, 1e300, -1e300)


def node_paths(data: Any, prefix: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    """Every key path below `data` (mapping keys and list indices), parents before children."""
    out: list[tuple[Any, ...]] = []
    items = data.items() if isinstance(data, dict) else enumerate(data) if isinstance(data, list) else ()
    for key, value in items:
        out.append((*prefix, key))
        out += node_paths(value, (*prefix, key))
    return out


def _at(data: Any, path: tuple[Any, ...]) -> Any:
    for key in path:
        data = data[key]
    return data


def mutate(data: dict[str, Any], rng: random.Random) -> tuple[dict[str, Any], str]:
    """One mutation of a deep copy of `data`; returns it and what was done."""
    out = copy.deepcopy(data)
    paths = node_paths(out)
    path = rng.choice(paths)
    parent, key = _at(out, path[:-1]), path[-1]
    where = ".".join(map(str, path))
    kind = rng.choice(("type", "type", "delete", "extra", "range", "nest", "null", "swap"))
    if kind == "delete":
        del parent[key]
    elif kind == "extra":
        target = rng.choice([p for p in [(), *paths] if isinstance(_at(out, p), dict)])
        extra = rng.choice(EXTRA_KEYS)
        _at(out, target)[extra] = rng.choice(WRONG_VALUES)
        where = ".".join(map(str, target)) + f" + {extra!r}"
    elif kind == "range" and isinstance(parent[key], int | float) and not isinstance(parent[key], bool):
        parent[key] = parent[key] * rng.choice(SCALES) + rng.choice((0, 1, -1))
    elif kind == "nest":
        parent[key] = rng.choice(([parent[key]], {"value": parent[key]}))
    elif kind == "null":
        parent[key] = None
    elif kind == "swap":  # another node's value here (right shape, wrong place)
        parent[key] = copy.deepcopy(_at(out, rng.choice(paths))) if paths else None
    else:
        parent[key] = copy.deepcopy(rng.choice(WRONG_VALUES))
    return out, f"{kind} at {where}"


def hostile_bytes(rng: random.Random, valid: bytes) -> bytes:
    """A file that is not a configuration (see the module docstring)."""
    depth = rng.randrange(200, 3000)  # some within Python's recursion limit (1000), most past it
    bomb = ["version: 1", "cameras: {kind: virtual, scenario: &a [1, 1, 1, 1, 1, 1, 1, 1, 1]}"]
    for prev, cur in zip("abcdefg", "bcdefgh", strict=True):  # 9^8 elements if anything expanded them
        bomb.append(f"x{cur}: &{cur} [{', '.join(['*' + prev] * 9)}]")
    choices: list[Callable[[], bytes]] = [
        lambda: rng.randbytes(rng.randrange(0, 400)),
        lambda: valid[: rng.randrange(len(valid))] + rng.randbytes(rng.randrange(1, 40)),
        lambda: b"\xef\xbb\xbf" + valid,
        lambda: valid.replace(b":", b"\x00", 1),
        lambda: b"[" * depth,
        lambda: b"a: " + b"{b: " * depth + b"1" + b"}" * depth,
        lambda: b"- " * depth + b"1",
        lambda: "\n".join(bomb).encode(),
        lambda: b"version: !!python/object/apply:os.system [\"true\"]\n",
        lambda: b"\xff\xfe" + valid,
        lambda: bytes([rng.randrange(0x80, 0x100)]) + valid,
        lambda: valid + b"\n---\nversion: 1\n",
        lambda: b"",
    ]
    return rng.choice(choices)()


@dataclass(frozen=True)
class Verdict:
    ok: bool  # behaved: accepted, or one clean ConfigError
    accepted: bool
    text: str  # the error line, or what went wrong


def verdict(load: Callable[[], object], files: tuple[Path, ...], need_key: bool) -> Verdict:
    """Run `load()`; judge the outcome as the module docstring says."""
    try:
        load()
    except ConfigError as exc:
        line = exc.message
        named = any(line.startswith(str(f)) for f in files)
        if "\n" in line or "\r" in line or not named:
            return Verdict(False, False, f"bad message: {line!r}")
        if need_key and not exc.key:
            return Verdict(False, False, f"no key named: {line!r}")
        return Verdict(True, False, line)
    except Exception as exc:  # noqa: BLE001 - this is what the fuzzing looks for
        return Verdict(False, False, f"{type(exc).__name__}: {exc}"[:300])
    return Verdict(True, True, "accepted")
