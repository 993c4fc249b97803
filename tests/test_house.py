"""House rules that keep the architecture honest (DESIGN.md, "The house").

- `edge/core` is pure computation: no I/O, threads, drivers or config parsing.
- `drivers` never import `edge`.
- every module has a docstring and stays small.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
CORE_FORBIDDEN = {
    "os", "sys", "io", "pathlib", "threading", "multiprocessing", "subprocess", "socket",
    "asyncio", "serial", "pymodbus", "yaml", "drivers", "logging", "time", "shutil", "tempfile",
}
MAX_LINES = 450


def _modules(package: str) -> list[Path]:
    return sorted((ROOT / package).rglob("*.py"))


def _imports(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(), filename=str(path))
    names: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module)
    return names


@pytest.mark.parametrize("path", _modules("edge/core"), ids=lambda p: p.name)
def test_core_is_pure(path: Path) -> None:
    for name in _imports(path):
        top = name.split(".")[0]
        assert top not in CORE_FORBIDDEN, f"{path}: edge/core must not import {name}"
        if top == "edge":
            assert name.startswith("edge.core"), f"{path}: edge/core imports {name} outside core"
    source = path.read_text()
    assert "open(" not in source.replace("reopen(", ""), f"{path}: edge/core must not do file I/O"


@pytest.mark.parametrize("path", _modules("drivers"), ids=lambda p: str(p.relative_to(ROOT)))
def test_drivers_never_import_edge(path: Path) -> None:
    for name in _imports(path):
        assert name.split(".")[0] != "edge", f"{path} imports {name}"


@pytest.mark.parametrize(
    "path", _modules("edge") + _modules("drivers"), ids=lambda p: str(p.relative_to(ROOT))
)
def test_module_has_docstring_and_stays_small(path: Path) -> None:
    source = path.read_text()
    tree = ast.parse(source)
    assert ast.get_docstring(tree), f"{path} needs a docstring saying what it does and why"
    assert source.count("\n") <= MAX_LINES, f"{path} has {source.count(chr(10))} lines; split it"
