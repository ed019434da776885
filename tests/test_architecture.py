"""The layout of the code is checked like its physics: the layering contract (import-linter, in
``pyproject.toml``), no import cycle between any two modules, every import declared (deptry),
rooms of one sitting (no file over 500 lines) and facts kept in their registry (no comparison
with an integrator's name outside ``sim/integrators/registry.py``).  ``docs/architecture.md`` explains the
layout these tests hold."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import grimp
import pytest

REPO = Path(__file__).resolve().parent.parent
PACKAGES = ("app", "sim")
LONGEST_MODULE = 500
"""Most lines of one Python file in ``app/`` or ``sim/``."""


def _python_files():
    for package in PACKAGES:
        yield from sorted((REPO / package).rglob("*.py"))


def test_the_layering_contract_holds(monkeypatch, capsys):
    from importlinter.cli import lint_imports

    monkeypatch.chdir(REPO)
    monkeypatch.syspath_prepend(str(REPO))
    result = lint_imports(no_cache=True)
    captured = capsys.readouterr()
    report = captured.out + captured.err
    assert result == 0, report


def _cycles(graph: grimp.ImportGraph) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan), each sorted."""
    modules = sorted(graph.modules)
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(root: str) -> None:
        work = [(root, iter(sorted(graph.find_modules_directly_imported_by(root))))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            module, children = work[-1]
            for child in children:
                if child not in index:
                    index[child] = low[child] = len(index)
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph.find_modules_directly_imported_by(child)))))
                    break
                if child in on_stack:
                    low[module] = min(low[module], index[child])
            else:
                work.pop()
                if work:
                    parent = work[-1][0]
                    low[parent] = min(low[parent], low[module])
                if low[module] == index[module]:
                    component = []
                    while True:
                        member = stack.pop()
                        on_stack.discard(member)
                        component.append(member)
                        if member == module:
                            break
                    if len(component) > 1:
                        found.append(sorted(component))

    for module in modules:
        if module not in index:
            visit(module)
    return found


def test_no_module_imports_back_from_a_module_that_uses_it(monkeypatch):
    """Any cycle at all, a package's ``__init__`` and its submodules included, lazy imports
    inside functions included."""
    monkeypatch.syspath_prepend(str(REPO))
    graph = grimp.build_graph(*PACKAGES, cache_dir=None)
    cycles = _cycles(graph)
    assert not cycles, "import cycles: " + "; ".join(" <-> ".join(c) for c in cycles)


def test_the_cycle_finder_finds_a_planted_cycle():
    graph = grimp.ImportGraph()
    for module in ("p", "p.a", "p.b", "p.c"):
        graph.add_module(module)
    graph.add_import(importer="p.a", imported="p.b")
    graph.add_import(importer="p.b", imported="p.c")
    graph.add_import(importer="p.c", imported="p.a")
    graph.add_import(importer="p", imported="p.a")
    assert _cycles(graph) == [["p.a", "p.b", "p.c"]]


@pytest.mark.skipif(sys.platform == "win32", reason="deptry's runner is checked on Linux")
def test_every_import_is_declared_and_every_dependency_used():
    result = subprocess.run(
        [sys.executable, "-m", "deptry", "."], cwd=REPO, capture_output=True, text=True,
        timeout=300,
    )
    assert result.returncode == 0, result.stdout + result.stderr


def test_every_module_fits_in_one_sitting():
    long = {
        str(path.relative_to(REPO)): count
        for path in _python_files()
        if (count := len(path.read_text(encoding="utf-8").splitlines())) > LONGEST_MODULE
    }
    assert long == {}, f"over {LONGEST_MODULE} lines: {long}"


def test_every_module_says_what_it_is_for():
    silent = [
        str(path.relative_to(REPO)) for path in _python_files()
        if path.stat().st_size and ast.get_docstring(ast.parse(path.read_text(encoding="utf-8"))) is None
    ]
    assert silent == []


REGISTRY_MODULES = {"sim/integrators/registry.py", "sim/theory/exact.py", "sim/integrators/reference.py"}
"""Where integrator names may be written: the registry, the integrator that registers itself
and the independent numpy re-implementation the tests compare against."""


def _name_comparisons(source: str, names: set[str]) -> list[int]:
    """Line numbers of branches and tables on integrator names: ``x == "name"``, ``x != "name"``,
    ``x in ("name", ...)``, a dict keyed by names, a tuple, list or set of two names or more."""

    def is_name(node: ast.AST | None) -> bool:
        return isinstance(node, ast.Constant) and node.value in names

    lines = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Compare):
            for operand in (node.left, *node.comparators):
                members = operand.elts if isinstance(operand, (ast.Tuple, ast.List, ast.Set)) else [operand]
                if any(is_name(member) for member in members):
                    lines.add(node.lineno)
        elif isinstance(node, ast.Dict) and any(is_name(key) for key in node.keys):
            lines.add(node.lineno)
        elif isinstance(node, (ast.Tuple, ast.List, ast.Set)) and sum(map(is_name, node.elts)) >= 2:
            lines.add(node.lineno)
    return sorted(lines)


def test_no_branch_on_an_integrators_name_outside_the_registry():
    import sim

    names = set(sim.integrators.ALL_INTEGRATORS)
    branches = {
        f"{path.relative_to(REPO)}:{line}"
        for path in _python_files()
        if str(path.relative_to(REPO)) not in REGISTRY_MODULES
        for line in _name_comparisons(path.read_text(encoding="utf-8"), names)
    }
    assert not branches, "compare integrator names (use a registry field): " + ", ".join(sorted(branches))


def test_the_name_check_finds_a_branch():
    source = (
        'if integrator == "verlet":\n    pass\n'
        'if name in ("rk4", "heun"):\n    pass\n'
        'COSTS = {"rk4": 4}\n'
        'for preferred in ["verlet", "rk4"]:\n    pass\n'
        'label = "verlet is symplectic"\n'
    )
    assert _name_comparisons(source, {"verlet", "rk4"}) == [1, 3, 5, 6]
