"""No import circle between the modules of a card package (DESIGN.md "Second step": the firmware
depends on no card, the interpreter on the firmware). Imports under `if TYPE_CHECKING:` do not
count: they never run."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

import vdevd.devices

DEVICES = Path(vdevd.devices.__file__).parent


def _is_type_checking(test: ast.expr) -> bool:
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING")


def _imports(tree: ast.Module, package: str, modules: set[str]) -> set[str]:
    """The modules of `package` (full names) that the module-level statements of `tree` import,
    outside `if TYPE_CHECKING:` blocks (an `else:` branch counts)."""
    found: set[str] = set()

    def visit(stmts: list[ast.stmt]) -> None:
        for stmt in stmts:
            if isinstance(stmt, ast.If):
                if not _is_type_checking(stmt.test):
                    visit(stmt.body)
                visit(stmt.orelse)
            elif isinstance(stmt, ast.Try):
                for block in (stmt.body, *(h.body for h in stmt.handlers), stmt.orelse,
                              stmt.finalbody):
                    visit(block)
            elif isinstance(stmt, ast.Import):
                found.update(alias.name for alias in stmt.names)
            elif isinstance(stmt, ast.ImportFrom) and stmt.module and not stmt.level:
                found.add(stmt.module)
                # `from vdevd.devices.oms import cmd_io` imports the module cmd_io
                found.update(f"{stmt.module}.{alias.name}" for alias in stmt.names)

    visit(tree.body)
    return {name for name in found if name in modules and name != package}


def import_graph(card: str) -> dict[str, set[str]]:
    """module -> the modules of the same card package it imports at run time."""
    package = f"vdevd.devices.{card}"
    paths = {f"{package}.{p.stem}" if p.stem != "__init__" else package: p
             for p in sorted((DEVICES / card).glob("*.py"))}
    modules = set(paths)
    return {name: _imports(ast.parse(path.read_text(), str(path)), package, modules)
            for name, path in paths.items()}


def find_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """One import circle of `graph` (its modules in order, the first repeated at the end)."""
    state: dict[str, int] = {}  # 1 on the current path, 2 done
    path: list[str] = []

    def visit(node: str) -> list[str] | None:
        state[node] = 1
        path.append(node)
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == 1:
                return path[path.index(nxt):] + [nxt]
            if nxt not in state and (cycle := visit(nxt)) is not None:
                return cycle
        path.pop()
        state[node] = 2
        return None

    for node in sorted(graph):
        if node not in state and (cycle := visit(node)) is not None:
            return cycle
    return None


def test_find_cycle_finds_a_circle_and_only_one() -> None:
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": set()}) is None
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]


def test_imports_under_type_checking_do_not_count() -> None:
    tree = ast.parse("from typing import TYPE_CHECKING\n"
                     "from p import a\n"
                     "if TYPE_CHECKING:\n    from p.b import B\n"
                     "def f():\n    import p.c\n")
    assert _imports(tree, "p", {"p", "p.a", "p.b", "p.c"}) == {"p.a"}


CARDS = sorted(p.parent.name for p in DEVICES.glob("*/__init__.py"))


def test_every_card_package_is_checked() -> None:
    assert {"galil", "oms", "pmac", "generic"} <= set(CARDS)


@pytest.mark.parametrize("card", CARDS)
def test_no_import_cycle_between_the_modules_of_a_card(card: str) -> None:
    graph = import_graph(card)
    assert len(graph) > 1, f"no modules found for {card}"
    cycle = find_cycle(graph)
    assert cycle is None, "import circle: " + " -> ".join(cycle)
