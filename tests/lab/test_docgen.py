"""The generated documentation (configuration and Modbus tables, command-line reference, tools list)
is what the code generates now: a stale page fails here, and `tools/gen-docs` fixes it."""

from __future__ import annotations

import argparse

from lab import docgen


def test_committed_pages_are_the_generated_ones() -> None:
    assert docgen.stale_pages() == [], "generated docs are stale: run tools/gen-docs and commit the pages"


def test_cli_reference_names_every_subcommand_and_option() -> None:
    # an independent walk of the real parsers: every option string appears in the page
    from edge.cli import SUBCOMMANDS, build_parser

    page = (docgen.DOCS / "cli.md").read_text()
    for name in SUBCOMMANDS:
        assert f"## `{name}`" in page
        parser = build_parser(name)
        sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
        for action in sub.choices[name]._actions:
            for option in action.option_strings:
                if option not in ("-h", "--help"):
                    assert f"`{option}`" in page, f"{name} {option} missing from docs/cli.md"


def test_tools_reference_lists_every_tool() -> None:
    page = (docgen.DOCS / "tools.md").read_text()
    tools = [p.name for p in (docgen.ROOT / "tools").iterdir()
             if p.is_file() and not p.name.startswith(("_", ".")) and not p.suffix]
    assert tools
    for name in tools:
        assert f"`tools/{name}`" in page


def test_a_changed_section_is_reported_and_rewritten(tmp_path, monkeypatch) -> None:
    page = tmp_path / "page.md"
    page.write_text("intro\n<!-- demo:begin -->\nold\n<!-- demo:end -->\nafter\n")
    section = docgen.Section("page.md", "demo", lambda: "new\n")
    monkeypatch.setattr(docgen, "DOCS", tmp_path)
    monkeypatch.setattr(docgen, "ROOT", tmp_path)
    monkeypatch.setattr(docgen, "SECTIONS", (section,))
    assert docgen.stale_pages() == ["page.md"]
    assert docgen.main([]) == 0
    assert page.read_text() == "intro\n<!-- demo:begin -->\nnew\n<!-- demo:end -->\nafter\n"
    assert docgen.stale_pages() == [] and docgen.main(["--check"]) == 0
