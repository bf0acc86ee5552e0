"""Plain imports: every public name is defined once, listed once in its package's ``__all__`` and
imported by a plain statement a reader (and a static tool) can follow; ``import sescid`` loads
no heavy library."""

from __future__ import annotations

import ast
import importlib
import importlib.util
import pkgutil
import subprocess
import sys
import types
from pathlib import Path

import pytest

import sescid

SRC = Path(sescid.__file__).parent
PACKAGES = ["sescid"] + [
    i.name for i in pkgutil.walk_packages(sescid.__path__, "sescid.") if i.ispkg
]
#: libraries imported inside the functions that need them, never by ``import sescid``
HEAVY = ("scipy", "matplotlib", "mujoco", "numba", "pyarrow", "clarabel", "rosbags", "viser",
         "trimesh", "ruamel", "threadpoolctl", "pxr")  # fmt: skip


def _source(package: str) -> ast.Module:
    return ast.parse((SRC.parent / package.replace(".", "/") / "__init__.py").read_text())


def _modules_of(package: str) -> set[str]:
    """The modules and sub-packages of ``package`` (a stage's sub-package, such as
    ``estimation.result``, lists its modules in ``__all__`` without importing them)."""
    return {i.name for i in pkgutil.iter_modules(importlib.import_module(package).__path__)}


def _member(package: str, name: str) -> object:
    """``package.name``: a bound name, else the module of that name (imported)."""
    pkg = importlib.import_module(package)
    if hasattr(pkg, name):
        return getattr(pkg, name)
    return importlib.import_module(f"{package}.{name}")


def _bound_names(tree: ast.Module) -> set[str]:
    """Names a module binds at its top level by a plain statement (import, def, class, =)."""
    out: set[str] = set()
    for node in tree.body:
        if isinstance(node, ast.Import | ast.ImportFrom):
            out |= {(a.asname or a.name).split(".")[0] for a in node.names}
        elif isinstance(node, ast.FunctionDef | ast.ClassDef):
            out.add(node.name)
        elif isinstance(node, ast.Assign | ast.AnnAssign):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            out |= {t.id for t in targets if isinstance(t, ast.Name)}
    return out


@pytest.mark.parametrize("package", PACKAGES)
def test_every_public_name_is_bound_plainly_and_listed_once(package):
    """Each name in ``__all__`` is listed once and bound by a statement of the package's own
    ``__init__`` (no ``__getattr__``, no table of names), so ``from package import name`` works
    and a static tool finds where it comes from."""
    pkg = importlib.import_module(package)
    names = list(pkg.__all__)
    assert len(names) == len(set(names)), sorted(n for n in names if names.count(n) > 1)
    assert not set(names) - _bound_names(_source(package)) - _modules_of(package)
    for name in names:
        assert _member(package, name) is not None


def test_no_module_loads_names_at_run_time():
    """No module of sescid defines a module-level ``__getattr__``/``__dir__`` or an export table."""
    bad = []
    for path in sorted(SRC.rglob("*.py")):
        tree = ast.parse(path.read_text())
        bound = _bound_names(tree)
        hits = bound & {"__getattr__", "__dir__", "_EXPORTS", "lazy_exports"}
        if hits:
            bad.append(f"{path.relative_to(SRC)}: {sorted(hits)}")
    assert not bad, bad


def test_a_name_public_in_several_packages_is_one_object():
    """A name exported by more than one package (a re-export: ``sescid.load_fit`` and
    ``sescid.estimation.load_fit``) is the same object: a concept has one home."""
    seen: dict[str, tuple[str, object]] = {}
    clash = []
    for package in PACKAGES:
        pkg = importlib.import_module(package)
        for name in pkg.__all__:
            value = _member(package, name)
            if not isinstance(value, type | types.FunctionType):
                continue
            if name in seen and seen[name][1] is not value:
                clash.append(f"{name}: {seen[name][0]} and {package}")
            seen.setdefault(name, (package, value))
    assert not clash, clash


def test_public_functions_and_classes_are_defined_in_sescid():
    """Every public function and class is defined in a module of sescid (not an alias of a
    library's)."""
    outside = []
    for package in PACKAGES:
        pkg = importlib.import_module(package)
        for name in pkg.__all__:
            value = _member(package, name)
            if isinstance(value, type | types.FunctionType):
                if not value.__module__.startswith("sescid"):
                    outside.append(f"{package}.{name}: {value.__module__}")
    assert not outside, outside


def test_import_sescid_loads_no_heavy_library_and_shows_only_its_names():
    """``import sescid`` (the CLI's start-up too) imports none of the heavy libraries, and
    ``dir(sescid)`` shows the public names and sub-modules, no import machinery."""
    code = (
        "import sys, sescid, sescid.cli\n"
        f"print(sorted(m for m in {HEAVY!r} if m in sys.modules))\n"
        "print(sorted(set(dir(sescid)) & {'TYPE_CHECKING', 'annotations', 'lazy_exports'}))\n"
    )
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert res.stdout.split("\n")[:2] == ["[]", "[]"], res.stdout


def test_a_public_name_that_is_also_a_submodule_stays_the_public_object():
    """``planning.candidates`` is the function, though
    ``planning/feasibility/candidates.py`` is a module: the package binds the name after the
    module has loaded."""
    code = (
        "import sescid.planning.feasibility.candidates, sescid.bench.real_robot\n"
        "import sescid.report.coverage\n"
        "import sescid.planning as p, sescid.bench as b, sescid.report as r\n"
        "from sescid.planning import candidates, compliance\n"
        "print(callable(p.candidates), callable(candidates), callable(compliance),\n"
        "      callable(b.real_robot), callable(r.coverage))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["True"] * 5


def test_the_bound_name_check_can_fail():
    """A name served by ``__getattr__`` is not bound by a statement (so the rule can fail)."""
    tree = ast.parse("from x import a\ndef __getattr__(name):\n    return 1\n__all__ = ['a', 'b']")
    assert _bound_names(tree) == {"a", "__getattr__", "__all__"}


def _private_uses(tree: ast.Module) -> list[str]:
    """``line: module.name`` for each private name (one underscore) a module takes from another
    module of sescid: ``from sescid.x import _y``, or ``m._y`` with ``m`` a sescid module it
    imported."""
    modules: set[str] = set()
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("sescid"):
            for a in node.names:
                if a.name.startswith("_") and not a.name.startswith("__"):
                    out.append(f"{node.lineno}: {node.module}.{a.name}")
                modules.add(a.asname or a.name)
        elif isinstance(node, ast.Import):
            modules |= {a.asname or a.name for a in node.names if a.name.startswith("sescid")}
    for node in ast.walk(tree):
        if (
            isinstance(node, ast.Attribute)
            and isinstance(node.value, ast.Name)
            and node.value.id in modules
            and node.attr.startswith("_")
            and not node.attr.startswith("__")
        ):
            out.append(f"{node.lineno}: {node.value.id}.{node.attr}")
    return out


def test_no_module_takes_another_modules_private_names():
    """A name used across modules is public where it is defined (the kernels' private package
    names its shared kernels plainly), so no module of sescid reaches into another's ``_names``."""
    bad = [
        f"{path.relative_to(SRC)}:{use}"
        for path in sorted(SRC.rglob("*.py"))
        for use in _private_uses(ast.parse(path.read_text()))
    ]
    assert not bad, bad


def test_the_private_name_check_can_fail():
    """Both ways of reaching a private name are seen (so the rule can fail)."""
    tree = ast.parse(
        "from sescid.kinematics._kernels.fused import _body, GRAM_BLOCK\n"
        "from sescid.kinematics._kernels import chains as kc\n"
        "import numpy as np\n"
        "kc._chain_block(1)\nnp._x\nkc.__doc__\n"
    )
    assert _private_uses(tree) == [
        "1: sescid.kinematics._kernels.fused._body",
        "4: kc._chain_block",
    ]


ROOT = SRC.parent.parent
#: the scripts beside the package that import it (a renamed or moved name breaks them only when
#: run: `make bench` stopped on one, a function-level import of a module that had moved)
SCRIPTS = [p for d in ("benchmarks", "tools", "examples") for p in sorted((ROOT / d).rglob("*.py"))]


def _unresolved(path: Path) -> list[str]:
    """Every ``from sescid… import name`` / ``import sescid…`` of ``path`` (at any depth) whose
    module or name does not exist."""
    bad = []
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            if not node.module.split(".")[0] == "sescid":
                continue
            try:
                module = importlib.import_module(node.module)
            except ImportError as exc:
                bad.append(f"{path.name}:{node.lineno} {node.module} ({exc})")
                continue
            for alias in node.names:
                name = f"{node.module}.{alias.name}"
                if not hasattr(module, alias.name) and importlib.util.find_spec(name) is None:
                    bad.append(f"{path.name}:{node.lineno} {name}")
        elif isinstance(node, ast.Import):
            for alias in node.names:
                if (
                    alias.name.split(".")[0] == "sescid"
                    and importlib.util.find_spec(alias.name) is None
                ):
                    bad.append(f"{path.name}:{node.lineno} {alias.name}")
    return bad


@pytest.mark.skipif(not SCRIPTS, reason="not a source checkout (no benchmarks/tools/examples)")
def test_the_scripts_import_only_names_that_exist():
    """benchmarks/, tools/ and examples/ name only sescid modules and names that exist."""
    bad = [b for p in SCRIPTS for b in _unresolved(p)]
    assert not bad, bad


def test_the_script_import_check_can_fail(tmp_path):
    script = tmp_path / "s.py"
    script.write_text("def f():\n    from sescid.io import tables\n    import sescid.nowhere\n")
    assert len(_unresolved(script)) == 2
