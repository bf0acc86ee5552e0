"""The size budgets of issue 32: no module over 450 lines, at most 12 functions with 8 or more
parameters outside the compiled kernels (numba kernels take their arrays one by one)."""

from __future__ import annotations

import ast
from pathlib import Path

import sescid

SRC = Path(sescid.__file__).parent
#: lines a module may have at most
MAX_LINES = 450
#: parameters (``self``/``cls`` aside) from which a function counts as long-winded
MANY = 8
#: long-winded functions allowed outside compiled kernels
MAX_MANY = 12


def _modules() -> list[Path]:
    return sorted(SRC.rglob("*.py"))


def _compiled(fn: ast.FunctionDef | ast.AsyncFunctionDef) -> bool:
    """A function compiled by numba (``lazy_njit``/``njit``/``jit`` decorator)."""
    for d in fn.decorator_list:
        node = d.func if isinstance(d, ast.Call) else d
        name = node.attr if isinstance(node, ast.Attribute) else getattr(node, "id", "")
        if name in ("lazy_njit", "njit", "jit"):
            return True
    return False


def many_parameters(tree: ast.AST) -> list[tuple[str, int]]:
    """(name, count) of the functions in ``tree`` with ``MANY`` or more parameters, compiled
    kernels aside (``*args``/``**kwargs`` count one each)."""
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef) and not _compiled(node):
            a = node.args
            names = [p.arg for p in a.posonlyargs + a.args + a.kwonlyargs]
            n = len([p for p in names if p not in ("self", "cls")])
            n += (a.vararg is not None) + (a.kwarg is not None)
            if n >= MANY:
                found.append((node.name, n))
    return found


def test_no_module_over_the_line_budget():
    """Every module in src/sescid has at most ``MAX_LINES`` lines."""
    long = {
        str(p.relative_to(SRC)): n
        for p in _modules()
        if (n := len(p.read_text().splitlines())) > MAX_LINES
    }
    assert not long, long


def test_few_functions_take_many_parameters():
    """At most ``MAX_MANY`` functions outside compiled kernels take ``MANY`` or more parameters."""
    found = [
        (f"{p.relative_to(SRC)}:{name}", n)
        for p in _modules()
        for name, n in many_parameters(ast.parse(p.read_text()))
    ]
    assert len(found) <= MAX_MANY, sorted(found, key=lambda x: -x[1])


def test_the_parameter_count_can_fail():
    """A plain function with 8 parameters counts; a numba kernel and a method's self do not."""
    code = (
        "def f(a, b, c, d, e, g, h, *, i): pass\n"
        "@lazy_njit(cache=True)\ndef k(a, b, c, d, e, g, h, i): pass\n"
        "class C:\n    def m(self, a, b, c, d, e, g, h): pass\n"
    )
    assert many_parameters(ast.parse(code)) == [("f", 8)]
