"""Typed YAML -> frozen dataclass loader: every mistake becomes a `ConfigError` naming file and key.

The dataclass *is* the schema. `load_dataclass(cls, data, file)` walks the
type hints of `cls` and builds an instance from a parsed YAML mapping,
checking as it goes:

- ``int`` (a YAML integer; ``true`` is not an integer), ``float`` (an integer
  or a real, always finite: ``.inf``/``.nan`` are refused), ``str``, ``bool``;
- ``Literal[...]`` (with a "did you mean" hint), ``X | None`` (YAML ``null``);
- ``tuple[X, ...]``, ``tuple[X, Y, Z]``, ``list[X]`` from YAML sequences,
  ``dict[str, X]`` from mappings, ``Any`` passed through;
- nested dataclasses from mappings: unknown keys are errors (a typo must not
  be silently ignored; the closest known key is suggested), missing keys
  without a default are errors;
- a union of dataclasses that each pin the same field to a one-value
  ``Literal`` (e.g. ``kind: Literal["v4l2"]``) is a tagged union: that key
  picks the member.

Per-field constraints come from ``setting(default, doc=..., min=..., ...)``
(a `dataclasses.field` with metadata): ``min``/``max``/``positive`` (numbers,
element-wise for sequences), ``choices``, ``pattern`` (full match, strings),
``min_items``/``max_items`` (sequences), ``check`` (a function of the built
value returning None or the expectation it failed) and ``load`` (a function
``(data, file, key) -> value`` that replaces the typed build for that field).
``doc`` and ``accepts`` (overrides the generated description) feed
`edge.config.table`, which renders a schema as the key table of docs/configuration.md.

Key paths look like ``outputs.nmea[0].baud``. `load_yaml` reads a file with
a loader that also refuses duplicate keys (PyYAML would keep the last one).
"""

from __future__ import annotations

import dataclasses
import difflib
import math
import re
import types
from collections.abc import Mapping
from pathlib import Path
from typing import Any, Literal, TypeVar, Union, get_args, get_origin, get_type_hints

import yaml

from edge.errors import ConfigError

T = TypeVar("T")
CONSTRAINTS = frozenset(  # metadata keys `setting` accepts
    "doc accepts min max positive choices pattern min_items max_items check load".split()
)
NONE_TYPE = type(None)


def setting(
    default: Any = dataclasses.MISSING,
    *,
    default_factory: Any = dataclasses.MISSING,
    doc: str = "",
    **constraints: Any,
) -> Any:
    """A dataclass field with documentation and constraints (see the module docstring)."""
    unknown = set(constraints) - CONSTRAINTS
    if unknown:
        raise TypeError(f"unknown constraint(s) {sorted(unknown)}; known: {sorted(CONSTRAINTS)}")
    return dataclasses.field(
        default=default, default_factory=default_factory, metadata={"doc": doc, **constraints}
    )


# ---------------------------------------------------------------- reading YAML


class _StrictLoader(yaml.SafeLoader):
    """SafeLoader that refuses duplicate keys in a mapping."""


def _construct_mapping(loader: _StrictLoader, node: yaml.MappingNode, deep: bool = False) -> Any:
    seen: set[Any] = set()
    for key_node, _ in node.value:
        if key_node.tag == "tag:yaml.org,2002:merge":
            continue
        key = loader.construct_object(key_node, deep=True)
        try:
            duplicate = key in seen
            seen.add(key)
        except TypeError:  # unhashable key: let PyYAML report it
            continue
        if duplicate:
            raise yaml.constructor.ConstructorError(
                "while reading a mapping", node.start_mark, f"duplicate key {key!r}", key_node.start_mark
            )
    return loader.construct_mapping(node, deep=deep)


_StrictLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _construct_mapping)


def load_yaml(path: str | Path) -> Any:
    """Parse a YAML file; unreadable, undecodable or malformed files raise `ConfigError` (key "")."""
    try:
        text = Path(path).read_text(encoding="utf-8")
    except OSError as exc:
        raise ConfigError(path, "", "a readable file", exc.strerror or str(exc)) from None
    except UnicodeDecodeError as exc:
        raise ConfigError(path, "", "UTF-8 text", f"undecodable byte at offset {exc.start}") from None
    try:
        return yaml.load(text, Loader=_StrictLoader)  # a SafeLoader subclass
    except RecursionError:  # PyYAML's composer recurses once per nesting level
        raise ConfigError(path, "", "a YAML document", "nesting deeper than the recursion limit") from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
        problem = getattr(exc, "problem", None) or str(exc)
        raise ConfigError(path, "", "a YAML document", f"{problem}{where}") from None


# ---------------------------------------------------------------- building dataclasses


def load_dataclass(cls: type[T], data: Any, file: str | Path | None, key_prefix: str = "") -> T:
    """Build `cls` (a dataclass) from parsed YAML `data`; errors name `file` and the key path."""
    if not isinstance(data, Mapping):
        found = "an empty document" if data is None else _kind(data)
        raise ConfigError(file, key_prefix or "<top>", "a mapping (key: value lines)", found)
    return _build(cls, data, file, key_prefix, {})


def child_key(prefix: str, name: str) -> str:
    """Key path of a mapping entry: ``outputs`` + ``nmea`` -> ``outputs.nmea``; a name that would
    not read as a key (empty, spaces, a dot) is quoted: ``outputs.''``."""
    if not name or name != name.strip() or "." in name or any(not c.isprintable() for c in name):
        name = repr(name)
    return f"{prefix}.{name}" if prefix else name


def _kind(value: Any) -> str:
    """What a YAML value is, for 'found ...' when its repr would not help."""
    if isinstance(value, Mapping):
        return "a mapping"
    if isinstance(value, list | tuple):
        return "a list"
    return value


def _hint(word: Any, candidates: list[str]) -> str:
    if not isinstance(word, str):
        return ""
    close = difflib.get_close_matches(word, candidates, n=1, cutoff=0.6)
    return f" (did you mean {close[0]!r}?)" if close else ""


def union_members(tp: Any) -> tuple[Any, ...] | None:
    """The members of ``X | Y`` / ``Optional[X]``, or None for a non-union type."""
    return get_args(tp) if get_origin(tp) in (Union, types.UnionType) else None


def tag_field(members: tuple[Any, ...]) -> str | None:
    """The field that every member dataclass pins to one distinct Literal value, if any."""
    if not members or not all(dataclasses.is_dataclass(m) for m in members):
        return None
    common: set[str] | None = None
    for member in members:
        hints = get_type_hints(member)
        pinned = {n for n, h in hints.items() if get_origin(h) is Literal and len(get_args(h)) == 1}
        common = pinned if common is None else common & pinned
    for name in sorted(common or ()):
        tags = [get_args(get_type_hints(m)[name])[0] for m in members]
        if len(set(tags)) == len(tags):
            return name
    return None


def _build(tp: Any, value: Any, file: Any, key: str, meta: Mapping[str, Any]) -> Any:
    if "load" in meta:
        return meta["load"](value, file, key)
    built = _build_typed(tp, value, file, key, meta)
    check = meta.get("check")
    if check is not None and built is not None:
        problem = check(built)
        if problem:
            raise ConfigError(file, key, problem, value)
    return built


def _build_typed(tp: Any, value: Any, file: Any, key: str, meta: Mapping[str, Any]) -> Any:
    members = union_members(tp)
    if members is not None:
        return _build_union(members, value, file, key, meta)
    origin = get_origin(tp)
    if tp is Any or tp is object:
        return value
    if origin is Literal:
        choices = get_args(tp)
        if not any(type(value) is type(c) and value == c for c in choices):
            raise ConfigError(
                file, key, f"one of {join_repr(choices)}{_hint(value, [str(c) for c in choices])}", value
            )
        return value
    if dataclasses.is_dataclass(tp):
        if not isinstance(value, Mapping):
            raise ConfigError(file, key or "<top>", "a mapping (key: value lines)", _kind(value))
        return _build_dataclass(tp, value, file, key)
    if origin in (tuple, list):
        return _build_sequence(tp, value, file, key, meta)
    if origin is dict:
        if not isinstance(value, Mapping):
            raise ConfigError(file, key, "a mapping", _kind(value))
        _, value_tp = get_args(tp)
        out = {}
        for k, v in value.items():
            if not isinstance(k, str):
                raise ConfigError(file, key, "string keys", k)
            out[k] = _build(value_tp, v, file, child_key(key, k), meta)
        return out
    if tp in (int, float, str, bool):
        return _scalar(tp, value, file, key, meta)
    raise TypeError(f"schema type {tp!r} at {key!r} is not supported by edge.config.schema")


def _build_union(members: tuple[Any, ...], value: Any, file: Any, key: str, meta: Mapping[str, Any]) -> Any:
    if value is None and NONE_TYPE in members:
        return None
    members = tuple(m for m in members if m is not NONE_TYPE)
    if len(members) == 1:
        return _build(members[0], value, file, key, meta)
    tag = tag_field(members)
    if tag is not None:
        tags = {get_args(get_type_hints(m)[tag])[0]: m for m in members}
        if not isinstance(value, Mapping):
            raise ConfigError(file, key, f"a mapping with {tag}: {join_repr(tags, ' | ')}", _kind(value))
        if tag not in value:
            raise ConfigError(
                file, child_key(key, tag), f"one of {join_repr(tags)} (required key is missing)"
            )
        chosen = next((m for t, m in tags.items() if type(t) is type(value[tag]) and t == value[tag]), None)
        if chosen is None:
            raise ConfigError(
                file,
                child_key(key, tag),
                f"one of {join_repr(tags)}{_hint(value[tag], list(map(str, tags)))}",
                value[tag],
            )
        return _build_dataclass(chosen, value, file, key)
    for member in members:  # untagged: first member that accepts the value
        try:
            return _build(member, value, file, key, meta)
        except ConfigError:
            continue
    raise ConfigError(file, key, " or ".join(describe(m, meta) for m in members), _kind(value))


def _build_dataclass(cls: Any, value: Mapping[str, Any], file: Any, key: str) -> Any:
    hints = get_type_hints(cls)
    fields = {f.name: f for f in dataclasses.fields(cls) if f.init}
    for name in value:
        if name not in fields:
            if not isinstance(name, str):
                raise ConfigError(file, key or "<top>", "string keys", name)
            known = sorted(fields)
            hint = _hint(name, known) or f" (known keys: {', '.join(known)})"
            raise ConfigError(file, child_key(key, name), f"a known key{hint}")
    kwargs = {}
    for name, f in fields.items():
        child = child_key(key, name)
        if name in value:
            kwargs[name] = _build(hints[name], value[name], file, child, f.metadata)
        elif f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING:
            raise ConfigError(file, child, f"{describe(hints[name], f.metadata)} (required key is missing)")
    try:
        return cls(**kwargs)
    except (ValueError, TypeError) as exc:
        raise ConfigError(file, key or "<top>", str(exc)) from None


def _build_sequence(tp: Any, value: Any, file: Any, key: str, meta: Mapping[str, Any]) -> Any:
    if not isinstance(value, list | tuple):
        raise ConfigError(file, key, describe(tp, meta), _kind(value))
    args = get_args(tp)
    if get_origin(tp) is tuple and not (len(args) == 2 and args[1] is Ellipsis):
        if len(value) != len(args):
            raise ConfigError(file, key, describe(tp, meta), value)
        item_types = list(args)
    else:
        lo, hi = meta.get("min_items", 0), meta.get("max_items")
        if len(value) < lo or (hi is not None and len(value) > hi):
            raise ConfigError(file, key, describe(tp, meta), value)
        item_types = [args[0]] * len(value)
    item_meta = {k: v for k, v in meta.items() if k not in ("check", "load", "min_items", "max_items")}
    items = [
        _build(t, v, file, f"{key}[{i}]", item_meta)
        for i, (t, v) in enumerate(zip(item_types, value, strict=True))
    ]
    return tuple(items) if get_origin(tp) is tuple else items


def _scalar(tp: type, value: Any, file: Any, key: str, meta: Mapping[str, Any]) -> Any:
    expected = describe(tp, meta)
    if tp is bool:
        ok = isinstance(value, bool)
    elif tp is str:
        ok = isinstance(value, str)
        if isinstance(value, bool):
            expected += " (quote it: YAML reads yes/no/on/off as true/false)"
    elif tp is int:
        ok = isinstance(value, int) and not isinstance(value, bool)
    else:
        ok = isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)
    if not ok:
        raise ConfigError(file, key, expected, _kind(value))
    if tp is float:
        value = float(value)
    if tp in (int, float):
        lo, hi = meta.get("min"), meta.get("max")
        if (
            (lo is not None and value < lo)
            or (hi is not None and value > hi)
            or (meta.get("positive") and value <= 0)
        ):
            raise ConfigError(file, key, expected, value)
    if "choices" in meta and value not in meta["choices"]:
        raise ConfigError(file, key, expected + _hint(value, [str(c) for c in meta["choices"]]), value)
    if "pattern" in meta and not re.fullmatch(meta["pattern"], value):
        raise ConfigError(file, key, expected, value)
    return value


# ---------------------------------------------------------------- describing the schema


def join_repr(values: Any, sep: str = ", ") -> str:
    """'a', 'b', 'c' for error messages and tables."""
    return sep.join(repr(v) for v in values)


def describe(tp: Any, meta: Mapping[str, Any] | None = None) -> str:
    """Human description of what a field accepts, e.g. 'an integer in [1, 247]'."""
    meta = meta or {}
    if "accepts" in meta:
        return meta["accepts"]
    members = union_members(tp)
    if members is not None:
        parts = [describe(m, meta) for m in members if m is not NONE_TYPE]
        return " or ".join(parts) + (" or null" if NONE_TYPE in members else "")
    origin = get_origin(tp)
    if origin is Literal:
        return f"one of {join_repr(get_args(tp))}"
    if dataclasses.is_dataclass(tp):
        return "a mapping"
    if origin in (tuple, list):
        args = get_args(tp)
        item_meta = {k: v for k, v in meta.items() if k not in ("min_items", "max_items")}
        if origin is tuple and not (len(args) == 2 and args[1] is Ellipsis):
            kinds = {_plural(describe(a, item_meta)) for a in args}
            return f"a list of {len(args)} {' / '.join(sorted(kinds))}"
        lo, hi = meta.get("min_items", 0), meta.get("max_items")
        if hi is None:
            count = f"at least {lo}" if lo else ""
        else:
            count = f"{lo}" if lo == hi else f"at most {hi}" if lo == 0 else f"{lo}..{hi}"
        return f"a list of {count + ' ' if count else ''}{_plural(describe(args[0], item_meta))}"
    if origin is dict:
        return "a mapping"
    if tp is Any or tp is object:
        return "any value"
    base = {int: "an integer", float: "a finite number", str: "a string", bool: "true or false"}[tp]
    lo, hi = meta.get("min"), meta.get("max")
    if meta.get("positive") and hi is not None:
        base += f" in (0, {hi}]"
    elif meta.get("positive"):
        base += " > 0"
    elif lo is not None and hi is not None:
        base += f" in [{lo}, {hi}]"
    elif lo is not None:
        base += f" >= {lo}"
    elif hi is not None:
        base += f" <= {hi}"
    if "choices" in meta:
        base += f", one of {join_repr(meta['choices'])}"
    if "pattern" in meta:
        base += f" matching {meta['pattern']}"
    return base


_PLURALS = {
    "one of": "values from",
    "an integer": "integers",
    "a finite number": "numbers",
    "a string": "strings",
    "a mapping": "mappings",
    "a list": "lists",
}


def _plural(text: str) -> str:
    for single, many in _PLURALS.items():
        if text.startswith(single):
            return many + text[len(single) :]
    return text
