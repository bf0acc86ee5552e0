"""One BLAS thread for sescid's dense linear algebra, so a busy machine does not stall it.

sescid's matrices are small (63 × 63 normal equations, a few thousand rows per block). A
multi-threaded BLAS/LAPACK spins its threads waiting for work on such products; with another
process loading the cores they wait for each other: a 63 × 63 ``eigh`` measured 64–75 ms
against 0.3 ms on one thread. So:

- the ``sescid`` command pins the whole process to one BLAS thread before numpy loads
  (``pin_process``: environment variables, honouring any the user set). Importing ``sescid``
  loads numpy, so the command's entry point (``_sescid_launch``, outside the package) runs this
  file on its own first; ``PINNED_VARIABLE`` then tells the package that BLAS loaded pinned;
- API entry points that do dense algebra run inside ``one_blas_thread()``, which limits the
  BLAS libraries already loaded (threadpoolctl) for the duration of the call and restores the
  caller's setting after.

The same bytes on every x86-64 CPU: OpenBLAS picks its kernels by CPU (FMA or not, vector
width), so the eigendecompositions and products of a fit differ in their last bits between
machines (measured: a fit's r and covariance change with ``OPENBLAS_CORETYPE``). ``pin_process``
also asks OpenBLAS for one baseline kernel set (``BLAS_CORE``, SSE3: every x86-64 CPU runs it;
the products are 63 × 63, so speed does not suffer), unless the user chose one. Other
architectures (ARM) and other BLAS libraries (MKL, Accelerate) keep their own kernels.

Large jobs use every core this process may run on through ``ordered_map``: independent blocks
of poses on worker threads (the compiled kernels release the GIL), results in block order, so
a sum over blocks is the same bit for bit whatever the number of threads.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from typing import Any, TypeVar

_T = TypeVar("_T")
R = TypeVar("R")

#: environment variables read by OpenBLAS, MKL, BLIS and OpenMP at load time
THREAD_VARIABLES = (
    "OPENBLAS_NUM_THREADS",
    "MKL_NUM_THREADS",
    "BLIS_NUM_THREADS",
    "OMP_NUM_THREADS",
)

#: set to "1" by ``pin_process`` when it ran before numpy loaded: every BLAS of this process (and
#: of its children, which inherit the variables) loads with the thread variables above
PINNED_VARIABLE = "SESCID_BLAS_PINNED"

_state: dict[str, Any] = {"controller": None, "key": None, "depth": 0}


def _linalg_modules() -> frozenset[str]:
    """The loaded extension modules that link a BLAS (numpy's and scipy's ship their own)."""
    import sys

    return frozenset(
        m for m in sys.modules if m.endswith(("_umath_linalg", "_fblas", "_flapack", "cython_blas"))
    )


#: OpenBLAS's kernel set for the command line on x86-64 (the SSE3 baseline: the same code, and
#: so the same bits, on every x86-64 CPU)
BLAS_CORE = "Prescott"


def pin_process() -> None:
    """Ask every BLAS this process loads later for one thread and, on x86-64, OpenBLAS for its
    baseline kernels (call before numpy is imported; a variable the user set is kept).
    ``one_blas_thread`` then has nothing left to do."""
    import platform
    import sys

    for name in THREAD_VARIABLES:
        os.environ.setdefault(name, "1")
    if platform.machine().lower() in ("x86_64", "amd64"):
        os.environ.setdefault("OPENBLAS_CORETYPE", BLAS_CORE)
    if "numpy" not in sys.modules and all(os.environ[name] == "1" for name in THREAD_VARIABLES):
        os.environ[PINNED_VARIABLE] = "1"


def pinned() -> bool:
    """Whether the BLAS libraries loaded pinned to one thread (``pin_process`` before numpy)."""
    return os.environ.get(PINNED_VARIABLE) == "1" and all(
        os.environ.get(name) == "1" for name in THREAD_VARIABLES
    )


@contextmanager
def one_blas_thread(preload: tuple[str, ...] = ()) -> Iterator[None]:
    """Run the block with the loaded BLAS libraries limited to one thread (nests; restores);
    ``preload``: modules the block will use that link a BLAS of their own (``scipy.linalg``),
    imported first so that theirs is limited too."""
    if preload and not pinned() and _state["depth"] == 0:
        import importlib

        for name in preload:
            importlib.import_module(name)
    if _state["depth"] > 0 or pinned():
        _state["depth"] += 1
        try:
            yield
        finally:
            _state["depth"] -= 1
        return
    key = _linalg_modules()
    if _state["controller"] is None or _state["key"] != key:
        from threadpoolctl import ThreadpoolController

        # scans the loaded libraries (~10 ms): again only when another BLAS may have loaded
        _state["controller"], _state["key"] = ThreadpoolController(), key
    _state["depth"] += 1
    try:
        with _state["controller"].limit(limits=1, user_api="blas"):
            yield
    finally:
        _state["depth"] -= 1


def usable_cores() -> int:
    """Cores this process may run on (its CPU affinity), at least 1."""
    try:
        return max(len(os.sched_getaffinity(0)), 1)
    except (AttributeError, OSError):  # pragma: no cover - not Linux
        return os.cpu_count() or 1


#: worker threads of ``ordered_map`` at most (beyond this the blocks' memory traffic dominates)
MAX_WORKERS = 8


def ordered_map(fn: Callable[[_T], R], items: Sequence[_T]) -> Iterator[R]:
    """``map(fn, items)`` on the usable cores, results yielded in the items' order; in this
    thread alone when there is one core or one item. ``fn`` must release the GIL to gain."""
    workers = min(usable_cores(), MAX_WORKERS, len(items))
    if workers <= 1:
        yield from map(fn, items)
        return
    pool = _state.get("pool")
    # a forked child inherits the pool but not its threads: it makes its own
    if pool is None or pool._max_workers < workers or _state.get("pool_pid") != os.getpid():
        from concurrent.futures import ThreadPoolExecutor

        pool = _state["pool"] = ThreadPoolExecutor(workers, thread_name_prefix="sescid")
        _state["pool_pid"] = os.getpid()
    yield from pool.map(fn, items)


__all__ = [
    "BLAS_CORE",
    "MAX_WORKERS",
    "PINNED_VARIABLE",
    "THREAD_VARIABLES",
    "one_blas_thread",
    "ordered_map",
    "pin_process",
    "pinned",
    "usable_cores",
]
