"""No import cycle among the modules of vdevd/devices/pmac: each module's module-level imports of
the same package (not those under `if TYPE_CHECKING:`) form a directed graph without a cycle."""

from __future__ import annotations

import ast
from pathlib import Path

import vdevd.devices.pmac

PACKAGE = "vdevd.devices.pmac"
ROOT = Path(vdevd.devices.pmac.__file__).resolve().parent


def _is_type_checking(test: ast.expr) -> bool:
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING")


def _imported(node: ast.stmt, modules: set[str]) -> set[str]:
    """The package's modules a module-level statement imports."""
    names: set[str] = set()
    if isinstance(node, ast.Import):
        for alias in node.names:
            if alias.name.startswith(PACKAGE + "."):
                names.add(alias.name[len(PACKAGE) + 1:].split(".")[0])
    elif isinstance(node, ast.ImportFrom):
        base = node.module or ""
        if node.level == 1:  # from . import x / from .x import y
            base = f"{PACKAGE}.{base}" if base else PACKAGE
        if base == PACKAGE:
            names.update(alias.name for alias in node.names if alias.name in modules)
        elif base.startswith(PACKAGE + "."):
            names.add(base[len(PACKAGE) + 1:].split(".")[0])
    elif isinstance(node, ast.If) and not _is_type_checking(node.test):
        for child in node.body + node.orelse:
            names |= _imported(child, modules)
    elif isinstance(node, ast.Try):
        for child in node.body + node.orelse + node.finalbody:
            names |= _imported(child, modules)
        for handler in node.handlers:
            for child in handler.body:
                names |= _imported(child, modules)
    return names


def import_graph() -> dict[str, set[str]]:
    """Module -> the package's modules it imports at module level."""
    modules = {p.stem for p in ROOT.glob("*.py")}
    graph: dict[str, set[str]] = {}
    for name in sorted(modules):
        tree = ast.parse((ROOT / f"{name}.py").read_text(encoding="utf-8"))
        deps: set[str] = set()
        for node in tree.body:
            deps |= _imported(node, modules)
        graph[name] = deps - {name}
    return graph


def find_cycle(graph: dict[str, set[str]]) -> list[str]:
    """One cycle of `graph` as its modules in order (the first repeated at the end), or []."""
    state: dict[str, int] = {}  # 1: on the path, 2: done
    path: list[str] = []

    def visit(node: str) -> list[str]:
        state[node] = 1
        path.append(node)
        for dep in sorted(graph.get(node, ())):
            if state.get(dep) == 1:
                return path[path.index(dep):] + [dep]
            if dep not in state and (cycle := visit(dep)):
                return cycle
        path.pop()
        state[node] = 2
        return []

    for node in sorted(graph):
        if node not in state and (cycle := visit(node)):
            return cycle
    return []


def test_the_graph_sees_the_package_imports() -> None:
    graph = import_graph()
    assert "online" in graph["firmware"]
    assert "commands" in graph["online"]


def test_the_cycle_finder_finds_a_cycle() -> None:
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert find_cycle({"a": {"b"}, "b": set()}) == []


def test_no_import_cycle_among_the_pmac_modules() -> None:
    assert find_cycle(import_graph()) == []
