"""House rules that keep the architecture honest (docs/house-rules.md).

- no import cycle anywhere in `edge/` and `drivers/`, `TYPE_CHECKING` imports counted;
- `edge/core` is pure computation (no I/O, threads, drivers or config parsing) and imports
  nothing of `edge` outside itself;
- `edge/measure` never imports outputs, encodings, the daemon or the replay runner;
- `edge/outputs` and `edge/encode` never import the runners or the commands;
- `drivers` never import `edge`;
- `edge` and `drivers` never import `lab` (evaluation, benchmarks, fault injection, fake devices);
- `tools/` are thin executables over the installed package: no sys.path edits, no helper modules
  but `_venv.py`, which re-runs a tool under the project venv;
- every module has a docstring and is one idea (a long one too); at most 12 modules directly
  under `edge/`; the wheel carries edge and drivers only.
"""

from __future__ import annotations

import ast
import shutil
import subprocess
import sys
import zipfile
from collections.abc import Iterator
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
CORE_FORBIDDEN = {
    "os", "sys", "io", "pathlib", "threading", "multiprocessing", "subprocess", "socket",
    "asyncio", "serial", "pymodbus", "yaml", "drivers", "logging", "time", "shutil", "tempfile",
}
LAYER_RULES = {  # package prefix: module prefixes it must not import
    "edge.core": ("edge.measure", "edge.encode", "edge.outputs", "edge.config", "edge.sim", "lab",
                  "edge.commands", "edge.appliance", "edge.recording", "edge.replay", "edge.pipeline",
                  "edge.chain", "edge.fix", "edge.errors", "edge.cli", "edge.ais", "edge.alerts"),
    "edge.measure": ("edge.outputs", "edge.encode", "edge.appliance.daemon", "edge.replay", "edge.commands"),
    "edge.outputs": ("edge.replay", "edge.appliance.daemon", "edge.commands"),
    "edge.encode": ("edge.replay", "edge.appliance.daemon", "edge.commands", "edge.outputs"),
    "drivers": ("edge", "lab"),
    "edge": ("lab",),  # the wheel carries edge and drivers only: the appliance never needs the lab
}
LONG_MODULE_LINES = 350  # past this a module must show it is one idea (test_module_is_one_idea)
IDEA_SHARE = 0.75  # ... its largest group of related definitions holds this share of its code


def _modules(package: str) -> list[Path]:
    return sorted((ROOT / package).rglob("*.py"))


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _import_nodes(tree: ast.AST) -> Iterator[ast.Import | ast.ImportFrom]:
    """Every import statement, wherever it sits: module level, functions, `if TYPE_CHECKING:`."""
    for node in ast.walk(tree):
        if isinstance(node, ast.Import | ast.ImportFrom):
            yield node


def _imports(path: Path) -> set[str]:
    """Absolute module names this file imports; `from pkg import mod` also names `pkg.mod`."""
    tree = ast.parse(path.read_text(), filename=str(path))
    names: set[str] = set()
    for node in _import_nodes(tree):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif node.module and node.level == 0:
            names.add(node.module)
            names.update(f"{node.module}.{alias.name}" for alias in node.names)
    return names


def _graph() -> dict[str, set[str]]:
    """Module -> the project modules it imports. `from pkg import mod` is an edge to `pkg.mod` only
    (the package's __init__ runs first whatever is imported, so it is not an edge of its own);
    `from pkg import name` of a non-module name is an edge to the package's __init__."""
    files = {_module_name(p): p for p in _modules("edge") + _modules("drivers")}
    graph: dict[str, set[str]] = {}
    for name, path in files.items():
        targets: set[str] = set()
        for node in _import_nodes(ast.parse(path.read_text(), filename=str(path))):
            if isinstance(node, ast.Import):
                targets.update(alias.name for alias in node.names)
            elif node.module and node.level == 0:
                for alias in node.names:
                    sub = f"{node.module}.{alias.name}"
                    targets.add(sub if sub in files else node.module)
        graph[name] = {t for t in targets if t in files and t != name}
    return graph


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def test_cycle_finder_finds_a_type_checking_cycle() -> None:
    """The checker itself: a cycle closed only under TYPE_CHECKING is still a cycle."""
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}
    assert _cycles(graph) == [["a", "b", "c"]]
    source = "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from edge.measure.point import X\n"
    assert "edge.measure.point" in {n.module for n in _import_nodes(ast.parse(source))
                                    if isinstance(n, ast.ImportFrom)}


def test_no_import_cycle_in_edge_or_drivers() -> None:
    assert _cycles(_graph()) == []


@pytest.mark.parametrize(
    "path", _modules("edge") + _modules("drivers"), ids=lambda p: str(p.relative_to(ROOT))
)
def test_layers_import_only_downwards(path: Path) -> None:
    module = _module_name(path)
    for package, forbidden in LAYER_RULES.items():
        if module == package or module.startswith(package + "."):
            for name in _imports(path):
                bad = [f for f in forbidden if name == f or name.startswith(f + ".")]
                assert not bad, f"{path}: {package} must not import {name}"


@pytest.mark.parametrize("path", _modules("edge/core"), ids=lambda p: p.name)
def test_core_is_pure(path: Path) -> None:
    for name in _imports(path):
        top = name.split(".")[0]
        assert top not in CORE_FORBIDDEN, f"{path}: edge/core must not import {name}"
        if top == "edge":
            assert name.startswith("edge.core"), f"{path}: edge/core imports {name} outside core"
    source = path.read_text()
    assert "open(" not in source.replace("reopen(", ""), f"{path}: edge/core must not do file I/O"


VENV_BOOTSTRAP = "_venv.py"  # the one helper module: re-runs a tool under the project venv


def _tools() -> list[Path]:
    return sorted(p for p in (ROOT / "tools").iterdir() if p.is_file() and p.name != VENV_BOOTSTRAP)


@pytest.mark.parametrize("path", _tools(), ids=lambda p: p.name)
def test_tools_are_thin_executables_over_the_installed_package(path: Path) -> None:
    source = path.read_text()
    assert path.suffix != ".py", f"{path}: tools/ holds executables, not helper modules"
    assert "sys.path" not in source and "PYTHONPATH" not in source, f"{path} edits the import path"
    assert "spec_from_file_location" not in source and "SourceFileLoader" not in source, path
    if source.startswith("#!") and "python" in source.splitlines()[0]:
        assert source.count("\n") <= 60, f"{path}: a tool parses arguments and calls the package"


def _definitions(tree: ast.Module) -> dict[str, ast.AST]:
    """The module's top-level functions and classes by name."""
    return {node.name: node for node in tree.body
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef)}


def idea_components(source: str) -> list[set[str]]:
    """The top-level functions and classes grouped by use: two definitions share a group when one
    names the other (directly, or through module constants that name it). A module that is one
    idea is one group, or one large group with a few free helpers beside it."""
    tree = ast.parse(source)
    defs = _definitions(tree)
    refs: dict[str, set[str]] = {name: set() for name in defs}
    for node in tree.body:  # constants and tables that name definitions tie those together
        if isinstance(node, ast.Assign | ast.AnnAssign):
            named = {n.id for n in ast.walk(node) if isinstance(n, ast.Name) and n.id in defs}
            for a in named:
                refs[a] |= named - {a}
    for name, node in defs.items():
        used = {n.id for n in ast.walk(node) if isinstance(n, ast.Name)}
        used |= {n.attr for n in ast.walk(node) if isinstance(n, ast.Attribute)}
        for other in used & defs.keys() - {name}:
            refs[name].add(other)
            refs[other].add(name)
    components: list[set[str]] = []
    seen: set[str] = set()
    for start in defs:
        if start in seen:
            continue
        group, todo = set(), [start]
        while todo:
            n = todo.pop()
            if n not in group:
                group.add(n)
                todo.extend(refs[n] - group)
        seen |= group
        components.append(group)
    return sorted(components, key=len, reverse=True)


def _lines_of(source: str, names: set[str]) -> int:
    defs = _definitions(ast.parse(source))
    return sum((defs[n].end_lineno or defs[n].lineno) - defs[n].lineno + 1 for n in names)


def test_idea_components_split_unrelated_code() -> None:
    one = "def a():\n    return b()\n\n\ndef b():\n    return 1\n\n\nTABLE = {1: a}\n"
    two = one + "\n\nclass C:\n    def m(self):\n        return D\n\n\nD = 3\n"
    assert idea_components(one) == [{"a", "b"}]
    assert [len(c) for c in idea_components(two)] == [2, 1]


@pytest.mark.parametrize(
    "path", _modules("edge") + _modules("drivers") + _modules("lab"), ids=lambda p: str(p.relative_to(ROOT))
)
def test_module_is_one_idea(path: Path) -> None:
    """Every module says what it does in a docstring. Length alone is no fault; a long module must
    be one idea: its largest group of related definitions (`idea_components`) holds most of its
    code, so two ideas sharing a file to save one show as two large groups."""
    source = path.read_text()
    assert ast.get_docstring(ast.parse(source)), f"{path} needs a docstring saying what it does and why"
    if source.count("\n") <= LONG_MODULE_LINES:
        return
    groups = idea_components(source)
    total = _lines_of(source, set().union(*groups)) if groups else 0
    main = _lines_of(source, groups[0]) if groups else 0
    assert main >= IDEA_SHARE * total, (
        f"{path}: its largest group of related definitions ({sorted(groups[0])[:6]}...) holds "
        f"{main} of {total} lines; the rest ({[sorted(g)[:3] for g in groups[1:4]]}) is another idea")


def test_at_most_twelve_modules_directly_under_edge() -> None:
    top = sorted(p.name for p in (ROOT / "edge").glob("*.py"))
    assert len(top) <= 12, f"edge/ holds {len(top)} modules directly ({top}): group them by purpose"


def test_wheel_carries_the_appliance_and_no_lab_code(tmp_path: Path) -> None:
    """The wheel that tools/bundle and tools/install put on a mast: edge and drivers, none of the
    lab (evaluation, benchmarks, fault injection, fake devices)."""
    src = tmp_path / "src"
    src.mkdir()
    for name in ("pyproject.toml", "README.md", "LICENSE"):
        shutil.copy(ROOT / name, src / name)
    for pkg in ("edge", "drivers", "lab"):  # lab copied too: the package list must leave it out
        shutil.copytree(ROOT / pkg, src / pkg, ignore=shutil.ignore_patterns("__pycache__"))
    proc = subprocess.run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "--no-build-isolation",
                           "--wheel-dir", str(tmp_path / "wheels"), str(src)],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    (wheel,) = (tmp_path / "wheels").glob("mast_stereo-*.whl")
    names = zipfile.ZipFile(wheel).namelist()
    packages = {n.split("/")[0] for n in names if not n.startswith("mast_stereo-")}
    assert packages == {"edge", "drivers"}, packages
    assert "edge/appliance/daemon.py" in names and "drivers/camera/v4l2.py" in names
    lab_words = ("evaluate", "bench", "faults", "fake", "soak")
    bad = [n for n in names if any(w in n.rsplit("/", 1)[-1] or f"/{w}" in n for w in lab_words)]
    assert not bad, f"lab code in the wheel: {bad}"


def test_package_ships_type_information() -> None:
    assert (ROOT / "edge" / "py.typed").exists() and (ROOT / "drivers" / "py.typed").exists()


SHELL_CALLS = {"os.system", "os.popen", "os.execl", "os.execlp", "os.spawnl", "os.spawnlp",
               "subprocess.getoutput", "subprocess.getstatusoutput", "asyncio.create_subprocess_shell"}


def _shell_uses(source: str) -> list[str]:
    """Calls that hand a string to a shell: os.system and kin, and any call with shell= not False."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if not isinstance(node, ast.Call):
            continue
        name = ast.unparse(node.func)
        if name in SHELL_CALLS or name in {"system", "popen"} or name.endswith("create_subprocess_shell"):
            found.append(f"line {node.lineno}: {name}()")
        for kw in node.keywords:
            if kw.arg == "shell" and not (isinstance(kw.value, ast.Constant) and kw.value.value is False):
                found.append(f"line {node.lineno}: {name}(shell={ast.unparse(kw.value)})")
    return found


def test_shell_finder_finds_what_it_must() -> None:
    assert _shell_uses("import os, subprocess\nos.system('ls')\nsubprocess.run(x, shell=True)\n"
                       "subprocess.run(['ls'], shell=False)\nos.popen('x')\nplatform.system()\n") == \
        ["line 2: os.system()", "line 3: subprocess.run(shell=True)", "line 5: os.popen()"]


@pytest.mark.parametrize(
    "path", _modules("edge") + _modules("drivers"), ids=lambda p: str(p.relative_to(ROOT))
)
def test_no_shell_is_ever_invoked(path: Path) -> None:
    """Data from config or the network never reaches a shell: commands are argument lists."""
    assert _shell_uses(path.read_text()) == [], f"{path} invokes a shell"
