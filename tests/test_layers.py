"""The package's shape: one-way layers, packages that state their concept, no side effects."""

from __future__ import annotations

import ast
import importlib
import pkgutil
import subprocess
import sys
from pathlib import Path

import pytest

import sescid

SRC = Path(sescid.__file__).parent
#: layer of each top-level part of the package; a module may import its own or lower layers only
LAYERS = {
    "errors": 0,
    "base": 0,
    "robots": 0,
    "model": 1,
    "kinematics": 2,
    "sesc": 3,
    "robot": 4,
    "simulation": 5,
    "estimation": 6,
    "sensors": 7,
    "planning": 8,
    "bench": 9,
    "session": 10,
    "study": 10,
    "io": 11,
    "api": 12,
    "report": 12,
    "cli": 13,
    "__init__": 13,
}


def _part(module: str) -> str:
    """'sescid.estimation.fit' → 'estimation'."""
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
    tree = ast.parse(path.read_text())
    package = name if path.name == "__init__.py" else name.rsplit(".", 1)[0]
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found += [(node.lineno, a.name) for a in node.names if a.name.startswith("sescid")]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - (node.level - 1)]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            if mod.startswith("sescid"):
                if mod == "sescid" or (node.module is None and node.level):
                    found += [(node.lineno, f"{mod}.{a.name}") for a in node.names]
                else:
                    found.append((node.lineno, mod))
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
    assert _imports("sescid.model.m", src) == [(2, "sescid.cli")]


def test_packages_state_their_concept_and_exports():
    """Each sub-package has a docstring and an __all__ whose names exist."""
    for info in pkgutil.walk_packages(sescid.__path__, "sescid."):
        if not info.ispkg:
            continue
        mod = importlib.import_module(info.name)
        assert (mod.__doc__ or "").strip(), f"{info.name} has no docstring"
        names = getattr(mod, "__all__", None)
        assert names, f"{info.name} has no __all__"
        missing = [n for n in names if not hasattr(mod, n)]
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


def test_help_needs_no_numerics():
    """`import sescid` and the CLI group import neither numpy nor numba (fast --help)."""
    code = (
        "import sys, sescid, sescid.cli; "
        "print(sorted(m for m in ('numpy', 'numba', 'scipy', 'matplotlib') if m in sys.modules))"
    )
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert res.stdout.strip() == "[]"


def test_the_layout_page_is_current():
    """docs/layout.md lists every module as it is (python tools/layout_doc.py rewrites it)."""
    res = subprocess.run(
        [sys.executable, str(SRC.parents[1] / "tools" / "layout_doc.py"), "--check"],
        capture_output=True, text=True, check=False,
    )  # fmt: skip
    assert res.returncode == 0, res.stdout
