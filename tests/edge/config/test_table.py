"""The README's configuration reference is the table generated from the schema, never hand-edited."""

from __future__ import annotations

import re
from pathlib import Path

from edge.config.app import schema_markdown

ROOT = Path(__file__).resolve().parents[3]


def test_readme_config_table_is_the_generated_one() -> None:
    readme = (ROOT / "README.md").read_text()
    m = re.search(r"<!-- config:begin -->\n(.*?)<!-- config:end -->", readme, re.S)
    assert m, "README.md lacks the <!-- config:begin/end --> markers"
    assert m[1] == schema_markdown(), "README configuration table is stale: run tools/config-table"
