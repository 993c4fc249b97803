"""Render a schema dataclass (edge.config.schema) as a markdown key table (docs/configuration.md).

One row per key path (``outputs.nmea[].baud``): what it accepts (the same
words the loader uses in its error messages), its default and its ``doc``.
Generated from the dataclasses, so the documentation cannot drift from the loader.
"""

from __future__ import annotations

import dataclasses
from typing import Any, get_args, get_origin, get_type_hints

import yaml

from edge.config.schema import NONE_TYPE, child_key, describe, join_repr, tag_field, union_members


def _default_text(f: dataclasses.Field) -> str:
    if f.default is not dataclasses.MISSING:
        value = f.default
    elif f.default_factory is not dataclasses.MISSING:
        value = f.default_factory()
        if dataclasses.is_dataclass(value):
            return ""
    else:
        return "**required**"
    text = yaml.safe_dump(_plain(value), default_flow_style=True).strip().removesuffix("...").strip()
    return f"`{text}`"


def _plain(value: Any) -> Any:
    if isinstance(value, tuple | list):
        return [_plain(v) for v in value]
    return value


def schema_rows(cls: Any, prefix: str = "") -> list[tuple[str, str, str, str]]:
    """(key path, accepted values, default, description) for every field, nested ones included."""
    rows = []
    hints = get_type_hints(cls)
    for f in dataclasses.fields(cls):
        if not f.init:
            continue
        key, tp = child_key(prefix, f.name), hints[f.name]
        members = [m for m in (union_members(tp) or (tp,)) if m is not NONE_TYPE]
        if get_origin(tp) in (tuple, list) and dataclasses.is_dataclass(get_args(tp)[0]):
            rows.append((key, "a list of mappings", _default_text(f), f.metadata.get("doc", "")))
            rows.extend(schema_rows(get_args(tp)[0], key + "[]"))
        elif "load" not in f.metadata and all(dataclasses.is_dataclass(m) for m in members):
            rows.append((key, "a mapping", _default_text(f), f.metadata.get("doc", "")))
            tag = tag_field(tuple(members))
            if tag is None:
                rows.extend(schema_rows(members[0], key))
                continue
            tags = [get_args(get_type_hints(m)[tag])[0] for m in members]
            chosen = f.default_factory() if f.default_factory is not dataclasses.MISSING else f.default
            default = f"`{getattr(chosen, tag)}`" if dataclasses.is_dataclass(chosen) else ""
            rows.append((child_key(key, tag), f"one of {join_repr(tags)}", default, "picks a variant below"))
            for member, value in zip(members, tags, strict=True):
                rows.extend(
                    (k, a, d, f"*{tag} {value}:* {doc}")
                    for k, a, d, doc in schema_rows(member, key)
                    if k != child_key(key, tag)
                )
        else:
            rows.append((key, describe(tp, f.metadata), _default_text(f), f.metadata.get("doc", "")))
    return rows


def markdown_table(cls: Any) -> str:
    """The schema of `cls` as a markdown table (key, accepted values, default, meaning)."""
    lines = ["| key | accepted values | default | meaning |", "|---|---|---|---|"]
    for key, accepted, default, doc in schema_rows(cls):
        lines.append(f"| `{key}` | {accepted.replace('|', '/')} | {default} | {doc} |")
    return "\n".join(lines)
