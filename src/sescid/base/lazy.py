"""Public names of a package loaded on first use (PEP 562), so that importing one name does not
import every module of its package: a command pays only for what it runs."""

from __future__ import annotations

import importlib
import sys
import types
from collections.abc import Callable, Mapping
from typing import Any


class _Package(types.ModuleType):
    """A package whose public names load on first use. A public name that is also a submodule's
    name (``planning.candidates``, the function, in ``planning/candidates.py``) stays the public
    object: importing the submodule does not replace it with the module."""

    _lazy_names: frozenset[str] = frozenset()

    def __setattr__(self, name: str, value: Any) -> None:
        if name in self._lazy_names and isinstance(value, types.ModuleType):
            return
        super().__setattr__(name, value)


def lazy_exports(
    package: str, exports: Mapping[str, str]
) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """``__getattr__`` and ``__dir__`` for ``package``, whose public names (``exports``: name →
    the module that defines it) are imported when first asked for, then kept in the package."""
    module = sys.modules[package]
    names = frozenset(n for n, m in exports.items() if m == f"{package}.{n}")
    if names:  # public names shadowing their own submodule
        module.__class__ = type("Package", (_Package,), {"_lazy_names": names})

    def getattr_(name: str) -> Any:
        source = exports.get(name)
        if source is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(source), name)
        types.ModuleType.__setattr__(sys.modules[package], name, value)
        return value

    def dir_() -> list[str]:
        return sorted(set(vars(sys.modules[package])) | set(exports))

    return getattr_, dir_
