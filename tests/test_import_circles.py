"""No import circle in sescid: the graph of every import (function-level ones included, those
under ``TYPE_CHECKING`` left out) between the package's modules and its launcher has no cycle.

A function-level import hides a circle from Python (it runs late) but not from a reader: a
module that needs a higher one inside a function is still tied to it. Importing a name from a
package counts as importing the module that name is (``from sescid.model import feet``), else
the package's ``__init__``.
"""

from __future__ import annotations

import ast
from pathlib import Path

SRC = Path(__file__).resolve().parents[1] / "src"


def _modules() -> dict[str, Path]:
    mods = {"_sescid_launch": SRC / "_sescid_launch.py"}
    for path in (SRC / "sescid").rglob("*.py"):
        parts = list(path.relative_to(SRC).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts.pop()
        mods[".".join(parts)] = path
    return mods


def _owner(name: str, mods: dict[str, Path]) -> str | None:
    """The module of ``mods`` a dotted import names (its longest known prefix)."""
    while name not in mods:
        if "." not in name:
            return None
        name = name.rsplit(".", 1)[0]
    return name


def import_graph(mods: dict[str, Path]) -> dict[str, set[str]]:
    """Module → the modules it imports anywhere in its body (TYPE_CHECKING blocks excepted)."""
    graph: dict[str, set[str]] = {}
    for mod, path in mods.items():
        tree = ast.parse(path.read_text(encoding="utf-8"))
        typing_only = {
            id(n)
            for node in ast.walk(tree)
            if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test)
            for n in ast.walk(node)
        }
        out: set[str] = set()
        for node in ast.walk(tree):
            if id(node) in typing_only:
                continue
            if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                for a in node.names:
                    full = f"{node.module}.{a.name}"
                    out.add(full if full in mods else _owner(node.module, mods) or "")
            elif isinstance(node, ast.Import):
                out |= {_owner(a.name, mods) or "" for a in node.names}
        graph[mod] = out - {"", mod}
    return graph


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (iterative Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    found: list[list[str]] = []
    for root in sorted(graph):
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on.add(root)
        while work:
            v, it = work[-1]
            w = next(it, None)
            if w is not None:
                if w not in index:
                    index[w] = low[w] = len(index)
                    stack.append(w)
                    on.add(w)
                    work.append((w, iter(sorted(graph.get(w, ())))))
                elif w in on:
                    low[v] = min(low[v], index[w])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[v])
            if low[v] == index[v]:
                comp = []
                while True:
                    w = stack.pop()
                    on.discard(w)
                    comp.append(w)
                    if w == v:
                        break
                if len(comp) > 1:
                    found.append(sorted(comp))
    return found


def test_no_import_circle():
    circles = cycles(import_graph(_modules()))
    assert not circles, "import circles: " + "; ".join(" ↔ ".join(c) for c in circles)


def test_the_rule_finds_a_circle_hidden_in_a_function(tmp_path):
    """A function-level import that closes a circle is found (the test can fail)."""
    (tmp_path / "a.py").write_text("import b\n")
    (tmp_path / "b.py").write_text("def f():\n    from a import x\n")
    (tmp_path / "c.py").write_text(
        "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    import a\n"
    )
    mods = {p.stem: p for p in tmp_path.glob("*.py")}
    graph = import_graph(mods)
    assert cycles(graph) == [["a", "b"]]
    assert graph["c"] == set()
