"""One home for every public name: a module-level public name (function, class, constant,
alias) of ``src/sescid`` is defined in one module only (issue 32), so a reader and a static
tool reach its one definition from its name.

Two kinds of module-level name are bindings, not definitions, and are left out: a kernel
module's stand-in for one of ``simd.py``'s SIMD intrinsics (``vadd = simd_intrinsic("vadd")``,
swapped for the intrinsic itself when the kernels load), and a command's function in
``sescid/cli/<command>.py`` named after the command it is (``cli.identify.identify`` is the
click command of ``sescid.identify``).
"""

from __future__ import annotations

import ast
from collections import defaultdict
from pathlib import Path

SRC = Path(__file__).resolve().parents[1] / "src" / "sescid"
#: the module that defines the SIMD intrinsics the kernels' stand-ins name
SIMD = "kinematics/_kernels/simd.py"


def _binds_intrinsic(node: ast.AST) -> bool:
    """``name = simd_intrinsic("…")``: a kernel module's binding of a SIMD intrinsic."""
    value = getattr(node, "value", None)
    return (
        isinstance(value, ast.Call)
        and isinstance(value.func, ast.Name)
        and value.func.id == "simd_intrinsic"
    )


def _defined(path: Path) -> list[str]:
    """The public names a module defines at its top level."""
    names: list[str] = []
    for node in ast.parse(path.read_text(encoding="utf-8")).body:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.append(node.name)
        elif isinstance(node, ast.Assign) and not _binds_intrinsic(node):
            names += [t.id for t in node.targets if isinstance(t, ast.Name)]
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            if not _binds_intrinsic(node):
                names.append(node.target.id)
    return [n for n in names if not n.startswith("_") and n != "__all__"]


def definitions() -> dict[str, list[str]]:
    """Public name → the modules (paths relative to src/sescid) that define it."""
    from sescid.cli import COMMANDS

    where: dict[str, list[str]] = defaultdict(list)
    for path in sorted(SRC.rglob("*.py")):
        rel = path.relative_to(SRC).as_posix()
        for name in _defined(path):
            if rel.startswith("cli/") and name in COMMANDS and rel != "cli/__init__.py":
                continue
            where[name].append(rel)
    return where


def test_every_public_name_is_defined_once():
    twice = {n: m for n, m in definitions().items() if len(m) > 1}
    assert not twice, "names defined in more than one module: " + "; ".join(
        f"{n} in {', '.join(m)}" for n, m in sorted(twice.items())
    )


def test_every_stand_in_is_bound_to_its_own_intrinsic():
    """The exemption above holds only for a stand-in named as the intrinsic of ``simd.py`` it
    stands for (``vadd = simd_intrinsic("vadd")``): not a second definition, the same name."""
    intrinsics = set(_defined(SRC / SIMD))
    bound = []
    for path in sorted(SRC.rglob("*.py")):
        for node in ast.parse(path.read_text(encoding="utf-8")).body:
            if isinstance(node, ast.Assign) and _binds_intrinsic(node):
                (target,) = node.targets
                (arg,) = node.value.args  # type: ignore[attr-defined]
                bound.append((path.name, getattr(target, "id", None), arg.value))
    assert bound
    wrong = [b for b in bound if b[1] != b[2] or b[2] not in intrinsics]
    assert not wrong, f"stand-ins not named as a simd.py intrinsic: {wrong}"


def test_the_rule_sees_a_second_definition(tmp_path):
    """The scan finds a constant, a function and a class alike (the test can fail)."""
    (tmp_path / "m.py").write_text("A = 1\ndef f(): ...\nclass C: ...\n_p = 2\n")
    assert _defined(tmp_path / "m.py") == ["A", "f", "C"]
