"""The documented configuration reference (docs/configuration.md) is the table generated from the
schema, never hand-edited."""

from __future__ import annotations

import re
from pathlib import Path

from edge.config.app import schema_markdown

ROOT = Path(__file__).resolve().parents[3]


def test_documented_config_table_is_the_generated_one() -> None:
    page = (ROOT / "docs" / "configuration.md").read_text()
    m = re.search(r"<!-- config:begin -->\n(.*?)<!-- config:end -->", page, re.S)
    assert m, "docs/configuration.md lacks the <!-- config:begin/end --> markers"
    assert m[1] == schema_markdown() + "\n", "docs/configuration.md is stale: run tools/gen-docs"
