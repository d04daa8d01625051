"""No import cycle among the modules of vdevd/devices/oms: each module's module-level imports of
the same package (those under `if TYPE_CHECKING:` aside, they never run) form a graph without a
cycle, so every module can be imported first and none sees another half-initialised."""

from __future__ import annotations

import ast
from pathlib import Path

import vdevd.devices.oms as package

PACKAGE = package.__name__
HERE = Path(package.__file__).resolve().parent


def _is_type_checking(test: ast.expr) -> bool:
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING")


def _module_level(body: list[ast.stmt]) -> list[ast.stmt]:
    """The statements that run at import: the body, and the branches of top-level `if`/`try`
    blocks, except `if TYPE_CHECKING:`."""
    out: list[ast.stmt] = []
    for node in body:
        if isinstance(node, ast.If):
            if not _is_type_checking(node.test):
                out += _module_level(node.body)
            out += _module_level(node.orelse)
        elif isinstance(node, ast.Try):
            for block in (node.body, node.orelse, node.finalbody, *[h.body for h in node.handlers]):
                out += _module_level(block)
        else:
            out.append(node)
    return out


def imports_of(path: Path, modules: set[str]) -> set[str]:
    """The package's modules that the module at `path` imports when it is imported."""
    found: set[str] = set()
    for node in _module_level(ast.parse(path.read_text(encoding="utf-8")).body):
        if isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module is not None and node.level == 0:
            # `from pkg import mod` imports pkg.mod; `from pkg.mod import name` imports pkg.mod
            names = [node.module] + [f"{node.module}.{alias.name}" for alias in node.names]
        else:
            continue
        found.update(n.removeprefix(PACKAGE + ".") for n in names if n.startswith(PACKAGE + "."))
    return found & modules


def graph() -> dict[str, set[str]]:
    paths = {p.stem: p for p in HERE.glob("*.py") if p.stem != "__init__"}
    return {name: imports_of(path, set(paths)) - {name} for name, path in paths.items()}


def find_cycle(edges: dict[str, set[str]]) -> list[str] | None:
    """One cycle of the graph as a path `a -> b -> ... -> a`, or None."""
    state: dict[str, int] = {}  # 1 on the stack, 2 done
    stack: list[str] = []

    def visit(node: str) -> list[str] | None:
        state[node] = 1
        stack.append(node)
        for nxt in sorted(edges[node]):
            if state.get(nxt) == 1:
                return stack[stack.index(nxt):] + [nxt]
            if nxt not in state and (cycle := visit(nxt)) is not None:
                return cycle
        stack.pop()
        state[node] = 2
        return None

    for node in sorted(edges):
        if node not in state and (cycle := visit(node)) is not None:
            return cycle
    return None


def test_the_cycle_finder_finds_a_cycle() -> None:
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert find_cycle({"a": {"b"}, "b": set()}) is None


def test_the_graph_sees_the_package_imports() -> None:
    edges = graph()
    assert {"cmd_motion", "commands", "syntax"} <= edges["firmware"]
    assert "firmware" not in edges["cmd_motion"]  # only under TYPE_CHECKING there


def test_no_import_cycle_among_the_oms_modules() -> None:
    cycle = find_cycle(graph())
    assert cycle is None, " -> ".join(cycle or [])
