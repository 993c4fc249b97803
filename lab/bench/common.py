"""Plain-text table formatting shared by the tools/bench-* scripts."""

from __future__ import annotations


def table(headers: list[str], rows: list[list[str]]) -> str:
    """Left-aligned first columns, right-aligned numbers, one header rule."""
    cols = list(zip(headers, *rows, strict=True))
    widths = [max(len(str(c)) for c in col) for col in cols]

    def fmt(cells: list[str]) -> str:
        out = []
        for i, (cell, w) in enumerate(zip(cells, widths, strict=True)):
            text = str(cell)
            numeric = text.replace(".", "", 1).replace("-", "", 1).replace("%", "").replace("+", "").isdigit()
            out.append(text.rjust(w) if numeric and i > 0 else text.ljust(w))
        return "  ".join(out).rstrip()

    lines = [fmt(headers), "  ".join("-" * w for w in widths)]
    lines += [fmt(r) for r in rows]
    return "\n".join(lines)
