"""Rules for the documentation site (docs/, mkdocs.yml) and the README.

- every equation the code cites (`eq. 4.5`, `eqs. 3.9/3.10`, `eq. K.8`, `eq. C.1`, `eq. 18.2-18.5`)
  is defined in docs/ (an `{#eq-N.N}` anchor, as docs/method.md writes them);
- every page under docs/ is in the site's navigation, and every nav entry exists (the strict build
  in tools/test checks the links; this keeps the two lists in step without building);
- the README stays short: at most 200 lines;
- user-facing text (the README and every page but docs/decisions.md, which keeps the history) names
  no issue or ruling numbers;
- nothing in the repository cites the background documents kept outside it (the method, design and
  outputs notes the project started from): code cites docs pages instead (`docs/method.md eq. 4.5`).
"""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
CODE_DIRS = ("edge", "drivers", "tools", "tests", "lab")
EQ_ID = r"(?:[A-Z]\.\d+|\d+\.\d+)"
EQ_REF = re.compile(r"\b(?:[Ee]qs?|[Ee]quations?)\.?\s*\(?("
                    + EQ_ID + r"(?:\s*(?:,|/|-|–|and|to)\s*" + EQ_ID + r")*)")
EQ_DEF = re.compile(r"\{#eq-(" + EQ_ID + r")\}")
MAX_README_LINES = 200
HISTORY_PAGE = "decisions.md"
TRACKER_NUMBERS = re.compile(r"\b(?:issues?|rulings?)\s+(?:#\s*)?\d+", re.I)
OUTSIDE_DOCS = re.compile(r"\b(?:" + "|".join(("SPEC", "DESIGN", "OUTPUTS")) + r")(?:\.md\b|'s\b|\s+eq\.)")


def _code_files() -> list[Path]:
    files = []
    for top in CODE_DIRS:
        for path in sorted((ROOT / top).rglob("*")):
            script = top == "tools" and not path.suffix
            if path.is_file() and (path.suffix in (".py", ".sh", ".yaml") or script):
                files.append(path)
    return files


def _expand(text: str) -> set[str]:
    """The equation ids one reference names; `18.2-18.5` is the range 18.2, 18.3, 18.4, 18.5."""
    ids: set[str] = set()
    for first, sep, last in re.findall(r"(" + EQ_ID + r")(?:\s*(-|–)\s*(" + EQ_ID + r"))?", text):
        ids.add(first)
        if sep:
            ids.add(last)
            a, b = first.split("."), last.split(".")
            if a[0] == b[0] and a[1].isdigit() and b[1].isdigit():
                ids.update(f"{a[0]}.{n}" for n in range(int(a[1]), int(b[1]) + 1))
    return ids


def cited_equations() -> dict[str, set[str]]:
    """Equation id -> the files that cite it."""
    cited: dict[str, set[str]] = {}
    for path in _code_files():
        for m in EQ_REF.finditer(path.read_text(errors="replace")):
            for eq in _expand(m[1]):
                cited.setdefault(eq, set()).add(str(path.relative_to(ROOT)))
    return cited


def defined_equations() -> set[str]:
    return {m for page in DOCS.rglob("*.md") for m in EQ_DEF.findall(page.read_text())}


def test_the_reference_parser_reads_the_forms_the_code_uses() -> None:
    text = "eq. 4.5, 4.6, 3.12; eqs. 3.9/3.10; (eq. K.8); eq. C.1/C.2; eq. 18.2-18.5; eq4.5"
    found = set().union(*(_expand(m[1]) for m in EQ_REF.finditer(text)))
    assert found == {"4.5", "4.6", "3.12", "3.9", "3.10", "K.8", "C.1", "C.2", "18.2", "18.3", "18.4", "18.5"}


def test_every_equation_the_code_cites_is_defined_in_the_docs() -> None:
    cited, defined = cited_equations(), defined_equations()
    assert len(cited) > 20, "the code cites equations: the reference parser found too few"
    missing = {eq: sorted(files)[:3] for eq, files in cited.items() if eq not in defined}
    assert not missing, f"equations cited in the code but not defined in docs/ ({{#eq-N.N}}): {missing}"


def _nav_pages(nav: object) -> list[str]:
    if isinstance(nav, str):
        return [nav] if nav.endswith(".md") else []
    if isinstance(nav, list):
        return [p for item in nav for p in _nav_pages(item)]
    if isinstance(nav, dict):
        return [p for value in nav.values() for p in _nav_pages(value)]
    return []


def test_every_page_is_in_the_navigation_and_every_entry_exists() -> None:
    config = yaml.safe_load((ROOT / "mkdocs.yml").read_text())
    nav = set(_nav_pages(config["nav"]))
    pages = {str(p.relative_to(DOCS)) for p in DOCS.rglob("*.md")}
    assert pages - nav == set(), "pages missing from mkdocs.yml's nav"
    # an entry may name a page another branch delivers; it must not name a page twice
    assert len(_nav_pages(config["nav"])) == len(nav)


@pytest.mark.parametrize("name", ["README.md"])
def test_readme_is_short(name: str) -> None:
    lines = (ROOT / name).read_text().count("\n")
    assert lines <= MAX_README_LINES, f"{name} has {lines} lines; the detail belongs in docs/"


def _user_facing() -> list[Path]:
    return [ROOT / "README.md"] + sorted(p for p in DOCS.rglob("*.md") if p.name != HISTORY_PAGE)


def test_the_tracker_pattern_reads_what_it_should() -> None:
    assert TRACKER_NUMBERS.findall("as issue 16 and rulings 1 and 4 said; Issue #18") == [
        "issue 16", "rulings 1", "Issue #18"]
    assert not TRACKER_NUMBERS.search("a known issue with 3 ships")


def test_user_facing_text_names_no_issue_or_ruling_numbers() -> None:
    found = {str(p.relative_to(ROOT)): TRACKER_NUMBERS.findall(p.read_text()) for p in _user_facing()}
    found = {page: hits for page, hits in found.items() if hits}
    assert not found, f"issue/ruling numbers in user-facing text (history: docs/{HISTORY_PAGE}): {found}"


def _tracked_text_files() -> list[Path]:
    try:
        out = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, check=True).stdout
        paths = [ROOT / name for name in out.decode().split("\0") if name]
    except (OSError, subprocess.CalledProcessError):  # not a git checkout: every file but the usual caches
        skip = {".git", ".venv", "out", "build", "__pycache__", ".mypy_cache", ".ruff_cache", ".pytest_cache"}
        paths = [p for p in ROOT.rglob("*") if not skip & set(p.relative_to(ROOT).parts)]
    return [p for p in paths if p.is_file() and p.suffix not in (".png", ".jpg")]


def test_nothing_cites_documents_outside_the_repository() -> None:
    hits = []
    for path in _tracked_text_files():
        for number, line in enumerate(path.read_text(errors="replace").splitlines(), 1):
            if OUTSIDE_DOCS.search(line):
                hits.append(f"{path.relative_to(ROOT)}:{number}: {line.strip()[:80]}")
    assert not hits, "cite docs pages (docs/method.md, docs/design.md, ...) instead:\n" + "\n".join(hits)
