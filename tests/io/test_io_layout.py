"""The shape of sescid.io: no import cycle (module-level or inside functions), the bags package
in small modules, short functions with few parameters."""

from __future__ import annotations

import ast
from pathlib import Path

import sescid

SRC = Path(sescid.__file__).parent


def _module_name(path: Path) -> str:
    rel = path.relative_to(SRC.parent).with_suffix("")
    return ".".join(rel.parts).removesuffix(".__init__")


def _graph(package: str) -> dict[str, set[str]]:
    """Module → the modules of ``package`` it imports (anywhere in the file)."""
    folder = SRC.parent.joinpath(*package.split("."))
    paths = {_module_name(p): p for p in sorted(folder.rglob("*.py"))}
    graph: dict[str, set[str]] = {}
    for name, path in paths.items():
        deps: set[str] = set()
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and node.module and not node.level:
                mods = [node.module] + [f"{node.module}.{a.name}" for a in node.names]
            elif isinstance(node, ast.Import):
                mods = [a.name for a in node.names]
            else:
                continue
            deps |= {m for m in mods if m in paths and m != name}
        graph[name] = deps
    return graph


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Every cycle found by a depth-first walk (one per back edge)."""
    found, state = [], {}
    stack: list[str] = []

    def visit(n: str) -> None:
        state[n] = 1
        stack.append(n)
        for d in sorted(graph[n]):
            if state.get(d) == 1:
                found.append([*stack[stack.index(d) :], d])
            elif d not in state:
                visit(d)
        stack.pop()
        state[n] = 2

    for n in sorted(graph):
        if n not in state:
            visit(n)
    return found


def test_no_import_cycle_in_io():
    """A package's __init__ imports its modules; no module imports back up (io.export.urdf ↔
    io.export.mjcf was one)."""
    graph = _graph("sescid.io")
    assert "sescid.io.export.urdf" in graph and "sescid.io.bags.assemble" in graph
    assert _cycles(graph) == []


def test_cycle_finder_finds_a_cycle():
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == [["a", "b", "c", "a"]]


def _functions(path: Path):
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            a = node.args
            n = len(a.posonlyargs) + len(a.args) + len(a.kwonlyargs) + bool(a.vararg)
            n += bool(a.kwarg) - bool(a.args and a.args[0].arg in ("self", "cls"))
            yield node.name, node.end_lineno - node.lineno + 1, n


def test_small_modules_short_functions_few_parameters():
    """io/bags modules ≤ 300 lines; in io/ and base/, no module over 500 lines, no function
    over 100 lines or with 8 parameters or more."""
    bad = []
    for folder in (SRC / "io", SRC / "base"):
        for path in sorted(folder.rglob("*.py")):
            lines = len(path.read_text().splitlines())
            limit = 300 if "bags" in path.parts else 500
            if lines > limit:
                bad.append(f"{path.name}: {lines} lines")
            for name, length, params in _functions(path):
                if length > 100 or params >= 8:
                    bad.append(f"{path.name}:{name}: {length} lines, {params} parameters")
    assert bad == []
