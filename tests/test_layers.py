"""The package's shape: one-way layers, packages that state their concept, no side effects."""

from __future__ import annotations

import ast
import importlib
import importlib.util
import pkgutil
import subprocess
import sys
from pathlib import Path

import pytest

import sescid

SRC = Path(sescid.__file__).parent
#: the ``sescid`` script's entry, beside the package
LAUNCHER = SRC.parent / "_sescid_launch.py"
#: the modules that are sescid's own: the package and the script's entry
OURS = ("sescid", "_sescid_launch")
#: layer of each top-level part of the package; a module may import its own or lower layers only
LAYERS = {
    "errors": 0,
    "base": 0,
    "robots": 0,
    "model": 1,
    "kinematics": 2,
    "tables": 3,
    "sesc": 4,
    "robot": 5,
    "stance": 5,
    "kinds": 5,
    "simulation": 6,
    "estimation": 7,
    "sensors": 8,
    "planning": 9,
    "bench": 10,
    "session": 11,
    "study": 11,
    "io": 12,
    "audit": 13,
    "api": 13,
    "report": 13,
    "cli": 14,
    "__init__": 14,
}


def _part(module: str) -> str:
    """'sescid.estimation.result.fit' → 'estimation'."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else "__init__"


def _modules() -> list[tuple[str, Path]]:
    out = []
    for path in sorted(SRC.rglob("*.py")):
        rel = path.relative_to(SRC.parent).with_suffix("")
        name = ".".join(rel.parts)
        out.append((name.removesuffix(".__init__"), path))
    return out


def _imports(name: str, path: Path) -> list[tuple[int, str]]:
    """(line, absolute module) of every sescid import in a file, function-level ones included."""
    return _imports_of_tree(name, ast.parse(path.read_text()), path.name == "__init__.py")


def _imports_of_tree(name: str, tree: ast.AST, is_init: bool) -> list[tuple[int, str]]:
    """(line, absolute module) of every sescid import in module ``name`` parsed as ``tree``."""
    package = name if is_init else name.rsplit(".", 1)[0]
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found += [(node.lineno, a.name) for a in node.names if a.name.startswith(OURS)]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - (node.level - 1)]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            if mod.startswith(OURS):  # a name may be a module: the graph resolves it
                found += [(node.lineno, f"{mod}.{a.name}") for a in node.names]
    return found


def test_every_part_has_a_layer():
    """Each top-level module or package of sescid is assigned a layer."""
    parts = {_part(name) for name, _ in _modules()}
    assert parts <= set(LAYERS), parts - set(LAYERS)


@pytest.mark.parametrize("name,path", _modules(), ids=[n for n, _ in _modules()])
def test_imports_point_down_the_layers(name, path):
    """No module imports a module of a higher layer (model → … → cli)."""
    mine = LAYERS[_part(name)]
    bad = [
        f"line {line}: {mod}"
        for line, mod in _imports(name, path)
        if LAYERS.get(_part(mod), 99) > mine
    ]
    assert not bad, f"{name} (layer {mine}) imports upward: {bad}"


def test_layer_check_catches_an_upward_import(tmp_path):
    """The import walker sees a function-level relative import (so the rule can fail)."""
    src = tmp_path / "m.py"
    src.write_text("def f():\n    from ..cli import main\n")
    assert _imports("sescid.model.m", src) == [(2, "sescid.cli.main")]


def test_packages_state_their_concept_and_exports():
    """Each sub-package has a docstring and an __all__ whose names exist (a stage's
    sub-package, such as ``estimation.result``, lists its modules without importing them)."""
    for info in pkgutil.walk_packages(sescid.__path__, "sescid."):
        if not info.ispkg:
            continue
        mod = importlib.import_module(info.name)
        assert (mod.__doc__ or "").strip(), f"{info.name} has no docstring"
        names = getattr(mod, "__all__", None)
        assert names, f"{info.name} has no __all__"
        missing = [
            n
            for n in names
            if not hasattr(mod, n) and importlib.util.find_spec(f"{info.name}.{n}") is None
        ]
        assert not missing, f"{info.name}.__all__ names missing objects: {missing}"


def test_public_surface_loads():
    """Every name in sescid.__all__ resolves."""
    for name in sescid.__all__:
        assert getattr(sescid, name) is not None


def test_no_import_time_side_effects():
    """Importing every module leaves the umask, the recursion limit and matplotlib untouched."""
    code = """
import os, sys, importlib, pkgutil
os.umask(0o027)
limit = sys.getrecursionlimit()
import sescid
for info in pkgutil.walk_packages(sescid.__path__, "sescid."):
    importlib.import_module(info.name)
now = os.umask(0o022)
assert now == 0o027, oct(now)
assert sys.getrecursionlimit() == limit
assert "matplotlib.pyplot" not in sys.modules
print("ok")
"""
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=False)
    assert res.returncode == 0 and res.stdout.strip() == "ok", res.stderr


def _cli_imports() -> list[tuple[str, int, str, str]]:
    """(cli module, line, imported-from module, name) of every sescid import in the CLI."""
    out = []
    for name, path in _modules():
        if not name.startswith("sescid.cli"):
            continue
        tree = ast.parse(path.read_text())
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("sescid"):
                for alias in node.names:
                    out.append((name, node.lineno, node.module, alias.name))
            elif isinstance(node, ast.Import):  # `import sescid.x`: a whole module, never public
                for alias in node.names:
                    if alias.name.startswith("sescid"):
                        out.append((name, node.lineno, alias.name, "*"))
    return out


#: imports of CLI modules that other helpers own, to be fixed there (module, from, name)
_PENDING = {}


def _private_cli_imports() -> list[str]:
    """``cli_module:line from module import name`` for each CLI import that is not public."""
    bad = []
    for cli_mod, line, module, name in _cli_imports():
        if module.startswith("sescid.cli") or (cli_mod, module, name) in _PENDING:
            continue
        mod = importlib.import_module(module)
        top = module.count(".") == 1  # sescid.<package or module>, never a sub-module
        if not top or name not in getattr(mod, "__all__", ()):
            bad.append(f"{cli_mod}:{line} from {module} import {name}")
    return bad


def test_the_cli_imports_only_public_names():
    """The command line imports only names a package (or top-level module) of sescid lists in
    __all__, and CLI modules from each other (the shell is the CLI's own)."""
    bad = _private_cli_imports()
    assert not bad, "\n".join(bad)


def test_public_name_check_catches_a_sub_module_import(monkeypatch):
    """A sub-module import, even of a name its package exports, is refused (the rule can fail)."""
    extra = [
        ("sescid.cli.x", 1, "sescid.estimation.result.fit_json", "save_fit"),
        ("sescid.cli.x", 2, "sescid.bench.mujoco", "MujocoBenchConfig"),
        ("sescid.cli.x", 3, "sescid.estimation", "fit_json"),
        ("sescid.cli.x", 4, "sescid.io", "*"),
        ("sescid.cli.x", 5, "sescid.estimation", "save_fit"),
    ]
    monkeypatch.setitem(globals(), "_cli_imports", lambda: extra)
    assert [b.split(" ", 1)[0] for b in _private_cli_imports()] == [
        "sescid.cli.x:1",
        "sescid.cli.x:2",
        "sescid.cli.x:3",
        "sescid.cli.x:4",
    ]


def _runtime_imports(name: str, path: Path) -> set[str]:
    """The sescid modules a file imports at run time (``if TYPE_CHECKING:`` blocks aside)."""
    tree = ast.parse(path.read_text())
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            node.body = []
    return {mod for _, mod in _imports_of_tree(name, tree, path.name == "__init__.py")}


def _cycles(edges: dict[str, set[str]]) -> list[list[str]]:
    """Every cycle a depth-first walk of the import graph meets (module → imported modules)."""
    seen: dict[str, int] = {}
    stack: list[str] = []
    cycles = []

    def visit(v: str) -> None:
        seen[v] = 1
        stack.append(v)
        for w in sorted(edges.get(v, ())):
            if seen.get(w) == 1:
                cycles.append(stack[stack.index(w) :] + [w])
            elif w not in seen:
                visit(w)
        stack.pop()
        seen[v] = 2

    for v in sorted(edges):
        if v not in seen:
            visit(v)
    return cycles


def _import_graph() -> dict[str, set[str]]:
    """Module → the sescid modules it imports at run time (function-level imports included).

    An import resolves to the longest known module (``from sescid.io import x`` → ``sescid.io``,
    the package's ``__init__``). A package's ``__init__`` re-exporting its own modules is an
    edge like any other, so a module that imports its own package (whose ``__init__`` imports
    it back) closes a circle; the ``sescid`` script's entry (``_sescid_launch``, beside the
    package) is a node too.
    """
    graph = {name: _runtime_imports(name, path) for name, path in _modules()}
    graph["_sescid_launch"] = _runtime_imports("_sescid_launch", LAUNCHER)
    known = set(graph)

    def resolve(mod: str) -> str | None:
        while mod and mod not in known:
            mod = mod.rsplit(".", 1)[0] if "." in mod else ""
        return mod or None

    return {m: {r for d in deps if (r := resolve(d)) and r != m} for m, deps in graph.items()}


def test_no_import_cycle():
    """No two modules import each other, directly or through others (function-level imports
    included, type-checking imports aside)."""
    cycles = _cycles(_import_graph())
    assert not cycles, cycles[:3]


def test_cycle_check_finds_a_cycle_through_three_modules():
    """The walk reports a → b → c → a and nothing for a chain (so the rule can fail)."""
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == [["a", "b", "c", "a"]]
    assert _cycles({"a": {"b", "c"}, "b": {"c"}, "c": set()}) == []


def test_type_checking_imports_are_not_edges(tmp_path):
    """An import under ``if TYPE_CHECKING:`` is no run-time edge; a function-level one is."""
    src = tmp_path / "m.py"
    src.write_text(
        "from typing import TYPE_CHECKING\n"
        "if TYPE_CHECKING:\n    from sescid.robot import Robot\n"
        "def f():\n    from ..sesc import cop\n"
    )
    assert _runtime_imports("sescid.model.m", src) == {"sescid.sesc.cop"}


def test_the_layout_page_is_current():
    """docs/layout.md lists every module as it is (python tools/layout_doc.py rewrites it)."""
    res = subprocess.run(
        [sys.executable, str(SRC.parents[1] / "tools" / "layout_doc.py"), "--check"],
        capture_output=True, text=True, check=False,
    )  # fmt: skip
    assert res.returncode == 0, res.stdout
