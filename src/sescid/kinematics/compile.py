"""The compile policy: numba kernels loaded on first call (``lazy_njit``), and which jobs run in
numpy before that (small ones: loading numba costs more than they do)."""

from __future__ import annotations

import sys
import threading
from collections.abc import Callable
from typing import Any


class _LazyKernel:
    """A numba kernel compiled on first call; until then numba is not even imported."""

    def __init__(self, fn: Callable, options: dict[str, Any], group: str):
        self.fn, self.options, self.group = fn, options, group
        self.__doc__, self.__name__ = fn.__doc__, fn.__name__

    def __call__(self, *args):
        load_group(self.group)
        return getattr(sys.modules[self.fn.__module__], self.fn.__name__)(*args)


#: group → its kernels not yet swapped for numba dispatchers (a registry, like a cache)
_LAZY: dict[str, list[_LazyKernel]] = {}
_SWAP_LOCK = threading.Lock()


def load_group(group: str) -> None:
    """Swap every lazy kernel of ``group`` (a module, or a package and its modules) for its
    numba dispatcher, in every module of the group that holds it: kernels call each other
    through module globals, so all of them are swapped before any compiles. The dispatchers
    use numba's on-disk cache (``cache=True``) where one is writable (beside the package, else
    ``NUMBA_CACHE_DIR`` or the user's cache folder), else compile in memory, silently."""
    if not _LAZY.get(group):
        return
    import numba

    with _SWAP_LOCK:  # a second thread's first call waits here, then finds the dispatchers
        kernels = _LAZY.pop(group, [])
        swapped = {id(k): _dispatcher(k, numba) for k in kernels}
        for name, module in list(sys.modules.items()):
            if module is None or not (name == group or name.startswith(group + ".")):
                continue
            space = vars(module)
            for attr, value in list(space.items()):
                if isinstance(value, _LazyKernel) and id(value) in swapped:
                    space[attr] = swapped[id(value)]


def _dispatcher(kernel: _LazyKernel, numba: Any) -> Any:
    try:
        return numba.njit(**kernel.options)(kernel.fn)
    except RuntimeError as exc:  # "cannot cache function …: no locator available"
        if "no locator available" not in str(exc):
            raise
        # a read-only install (service user, read-only container): compile in memory
        return numba.njit(**(kernel.options | {"cache": False}))(kernel.fn)


def lazy_njit(group: str | None = None, **options: Any) -> Callable[[Callable], Any]:
    """``numba.njit(**options)`` deferred to the first call of any kernel of ``group`` (default:
    the kernel's module; a package name groups kernels that call each other across modules)."""

    def wrap(fn: Callable) -> _LazyKernel:
        kernel = _LazyKernel(fn, options, group or fn.__module__)
        _LAZY.setdefault(kernel.group, []).append(kernel)
        return kernel

    return wrap


def loaded(group: str) -> bool:
    """True once the kernels of ``group`` are numba dispatchers."""
    return not _LAZY.get(group)


#: the group of the kinematics kernels (they call each other across this package's modules)
GROUP = "sescid.kinematics"


#: body-poses (poses × bodies) the chain runs in numpy in a process before the compiled kernels
#: are loaded anyway (ski rental). Loading them costs 0.5–1 s (numba's import and type
#: registries); the numpy chain ~0.1 µs per body-pose (~2.5 µs per OP2 pose), so this budget
#: is ~0.2 s of numpy work: a command on a few thousand poses (``demo``: ~70 000 OP2 poses)
#: never loads numba, a large file or a long session does. Counted in work, not seconds, so
#: which path runs does not depend on the machine's load.
NUMPY_BUDGET = 2_000_000
_numpy_spent = [0]  # body-poses run in numpy so far


def compiled() -> bool:
    """True once the kinematics kernels are loaded (the chain no longer runs in numpy)."""
    return loaded(GROUP)


def _within_budget(m: int, nb: int) -> bool:
    """True while the kernels are not loaded and m more poses of nb bodies keep the numpy
    work within ``NUMPY_BUDGET``."""
    return not loaded(GROUP) and _numpy_spent[0] + m * nb <= NUMPY_BUDGET


def _numpy_path(m: int, nb: int) -> bool:
    """True while the kernels are not loaded, the block (m poses of nb bodies) is at most
    ``SMALL_BLOCK`` poses and the numpy work stays within ``NUMPY_BUDGET`` with it."""
    return m <= SMALL_BLOCK and _within_budget(m, nb)


#: blocks of at most this many poses may run in numpy until the compiled kernels are loaded (one
#: chain block: a CoP/CoM over many poses, or the normal equations of up to this many poses)
SMALL_BLOCK = 1024
