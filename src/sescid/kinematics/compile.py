"""The compile policy: numba kernels loaded on first call (``lazy_njit``), the SIMD intrinsics they
use (``simd_intrinsic``), and which jobs run in numpy instead (``use_kernels``).

The choice of path is a function of the job alone (its size), never of what the process did
before, so the same inputs give the same bits in any process: loading numba costs 0.5–1 s, so a
small job (``sescid identify`` on 38 poses, ``make demo``) runs in numpy and a large one on the
kernels. Where the numpy twin gives the kernel's bits (trig, chain, origins, reduced columns, CoM
sums: the same operations in the same order, tested), kernels that are already loaded also run
small jobs: only the speed differs. The normal equations' product uses fused multiply-adds and a
fixed 8-lane order (``simd``) that numpy cannot reproduce, so there the job size alone decides.

Compiled kernels are kept in numba's on-disk cache, keyed by the numba version, the source
file's content, the kernel's signature and the CPU (its name and features). A wheel built by
``pip install .`` carries the kernels compiled for the installing machine (``sescid
precompile`` at build time); where none fit, the first call compiles (``seed_cache`` copies a
cache the package carries into a cache folder of the user's; a terminal is told, once).
"""

from __future__ import annotations

import contextlib
import functools
import importlib
import shutil
import sys
import threading
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any


class _LazyKernel:
    """A numba kernel compiled on first call; until then numba is not even imported."""

    def __init__(self, fn: Callable, options: dict[str, Any], group: str):
        self.fn, self.options, self.group = fn, options, group
        self.__doc__, self.__name__ = fn.__doc__, fn.__name__

    def __call__(self, *args):
        load_group(self.group)
        fn = getattr(sys.modules[self.fn.__module__], self.fn.__name__)
        if fn is self:  # another thread is swapping the group's kernels: wait for it
            with _SWAP_LOCK:
                fn = getattr(sys.modules[self.fn.__module__], self.fn.__name__)
        return fn(*args)


class _LazyIntrinsic:
    """A placeholder for an intrinsic of ``SIMD`` (a module that imports numba): the group's
    kernels see the real intrinsic once ``load_group`` swapped it in."""

    def __init__(self, name: str):
        self.name = name

    def __call__(self, *args):  # pragma: no cover - only compiled code calls intrinsics
        raise RuntimeError(f"{self.name} is a numba intrinsic: call it from a compiled kernel")


#: group → its kernels not yet swapped for numba dispatchers (a registry, like a cache)
_LAZY: dict[str, list[_LazyKernel]] = {}
#: group → its numba dispatchers, once swapped in
_LOADED: dict[str, list[Any]] = {}
_SWAP_LOCK = threading.Lock()


def load_group(group: str) -> None:
    """Swap every lazy kernel of ``group`` (a module, or a package and its modules) for its
    numba dispatcher, and every SIMD placeholder for its intrinsic, in every module of the group:
    kernels call each other through module globals, so all of them are swapped before any
    compiles. The dispatchers use numba's on-disk cache (``cache=True``) where one is writable
    (``NUMBA_CACHE_DIR``, else beside the package, else the user's cache folder, seeded from
    the package's: ``seed_cache``), else compile in memory."""
    if not _LAZY.get(group):
        return
    import numba

    _announce_compiles()
    with _SWAP_LOCK:  # a second thread's first call waits here, then finds the dispatchers
        kernels = _LAZY.pop(group, [])
        if not kernels:
            return
        swapped: dict[int, Any] = {id(k): _dispatcher(k, numba) for k in kernels}
        _LOADED.setdefault(group, []).extend(swapped.values())
        simd: Any = None
        for name, module in list(sys.modules.items()):
            if module is None or not (name == group or name.startswith(group + ".")):
                continue
            space = vars(module)
            for attr, value in list(space.items()):
                if isinstance(value, _LazyKernel) and id(value) in swapped:
                    space[attr] = swapped[id(value)]
                elif isinstance(value, _LazyIntrinsic):
                    if simd is None:
                        simd = importlib.import_module(SIMD)
                    space[attr] = getattr(simd, value.name)


def _dispatcher(kernel: _LazyKernel, numba: Any) -> Any:
    try:
        dispatcher = numba.njit(**kernel.options)(kernel.fn)
    except RuntimeError as exc:  # "cannot cache function …: no locator available"
        if "no locator available" not in str(exc):
            raise
        # a read-only install (service user, read-only container): compile in memory
        return numba.njit(**(kernel.options | {"cache": False}))(kernel.fn)
    if kernel.options.get("cache"):
        _drop_stale_index(dispatcher)
        seed_cache(dispatcher)
        _load_without_registries(dispatcher)
    return dispatcher


def _load_without_registries(dispatcher: Any) -> None:
    """Load the kernel's cached machine code without numba's compile-time registries.

    numba's ``Cache.load_overload`` refreshes the target context first: it imports and installs
    every typing and lowering registry numba has (typed containers, random, linalg — which
    imports scipy.linalg —, datetime, …), 0.3–0.5 s of CPU in every process, none of which
    cached code uses: it needs its runtime (NRT, the allocator its arrays call) and the C
    symbols the process registers when numba and the context start (helpers, exceptions, libm,
    the hash secret). A compile still refreshes everything first (numba's ``CompilerBase``), so
    a cache miss compiles as before. The code loaded is the same bytes either way. Left as it
    is where this numba's cache does not look like the one known here."""
    cache: Any = getattr(dispatcher, "_cache", None)
    load = getattr(cache, "_load_overload", None)
    guard = getattr(cache, "_guard_against_spurious_io_errors", None)
    try:
        from numba.core.runtime import nrt
    except ImportError:  # pragma: no cover - another numba layout
        return
    rtsys: Any = getattr(nrt, "rtsys", None)
    if load is None or guard is None or not hasattr(rtsys, "initialize"):
        return

    def load_overload(sig: Any, target_context: Any) -> Any:
        import numba.cpython.hashing  # noqa: F401 - registers the hash secret's symbols

        rtsys.initialize(target_context)
        with guard():
            return load(sig, target_context)

    cache.load_overload = load_overload


def seed_cache(dispatcher: Any) -> bool:
    """Copy the kernel's compiled entries the package carries (its ``__pycache__``, written when
    the wheel was built) into the cache folder numba chose instead, when that folder has none:
    a package folder the user cannot write (numba then caches in the user's folder) or a
    ``NUMBA_CACHE_DIR``. numba checks what it loads (its version, the source's content, the
    CPU), so a copy that does not fit is only ignored. True when files were copied."""
    cache: Any = getattr(dispatcher, "_cache", None)
    index: Any = getattr(cache, "_cache_file", None)
    impl: Any = getattr(cache, "_impl", None)
    if index is None or impl is None or not hasattr(index, "_index_name"):
        return False  # no cache, or a numba whose cache layout is not the one known here
    try:
        py_file = Path(impl.locator._py_file)
        shipped = py_file.parent / "__pycache__"
        target = Path(cache._cache_path)
        if target.resolve() == shipped.resolve() or not (shipped / index._index_name).is_file():
            return False
        if (target / index._index_name).exists():
            return False  # the user's cache has this kernel's index: numba keeps it up to date
        base = impl.filename_base
        for data in shipped.glob(f"{base}.*.nbc"):
            shutil.copyfile(data, target / data.name)
        shutil.copyfile(shipped / index._index_name, target / index._index_name)
    except (OSError, AttributeError):
        return False  # nothing copied that numba would trust more than a compile
    return True


#: what a terminal is told before the first kernel compiles in a process
COMPILING = (
    "sescid: compiling the numba kernels for this CPU (once: later runs load them; "
    "`sescid precompile` does it ahead)"
)
#: the same where numba has no cache folder it can write
COMPILING_NO_CACHE = (
    "sescid: compiling the numba kernels (no writable cache folder, so every run compiles: "
    "set NUMBA_CACHE_DIR to a folder of yours)"
)


@functools.cache
def _announce_compiles() -> None:
    """Register (once per process) a numba listener that tells a terminal, in one line on
    stderr, before the first of sescid's kernels compiles instead of loading from the cache."""
    from numba.core import event

    lock = threading.Lock()
    told: list[bool] = []

    class Notice(event.Listener):
        def on_start(self, ev: Any) -> None:
            dispatcher = (ev.data or {}).get("dispatcher")
            module = getattr(getattr(dispatcher, "py_func", None), "__module__", "") or ""
            if told or not module.startswith("sescid.") or not sys.stderr.isatty():
                return
            with lock:
                if told:
                    return
                told.append(True)
            null = type(getattr(dispatcher, "_cache", None)).__name__ == "NullCache"
            print(COMPILING_NO_CACHE if null else COMPILING, file=sys.stderr, flush=True)

        def on_end(self, ev: Any) -> None:
            pass

    event.register("numba:compile", Notice())


@contextlib.contextmanager
def counting_compiles() -> Iterator[list[str]]:
    """Collect the names of sescid's kernels that compile inside the block (not those loaded
    from numba's cache): ``with counting_compiles() as names: ...``."""
    from numba.core import event

    names: list[str] = []

    class Count(event.Listener):
        def on_start(self, ev: Any) -> None:
            fn = getattr((ev.data or {}).get("dispatcher"), "py_func", None)
            if fn is not None and (fn.__module__ or "").startswith("sescid."):
                names.append(f"{fn.__module__}.{fn.__qualname__}")

        def on_end(self, ev: Any) -> None:
            pass

    with event.install_listener("numba:compile", Count()):
        yield names


def _drop_stale_index(dispatcher: Any) -> None:
    """Forget an on-disk cache index another version of sescid left (an upgrade keeps
    ``__pycache__``; a user cache folder outlives installs). numba unpickles an index before it
    compares the source's stamp, so an index whose signatures name a record type this version
    renamed or removed raises (AttributeError) on the first call instead of recompiling. Such an
    index is emptied, or caching is turned off for this kernel where the folder is read-only."""
    cache: Any = getattr(dispatcher, "_cache", None)
    index: Any = getattr(cache, "_cache_file", None)
    if index is None or not hasattr(index, "_load_index"):
        return  # numba without that cache layout: nothing to check
    try:
        index._load_index()
    except Exception:  # noqa: BLE001 - any unreadable index is stale by definition
        try:
            cache.flush()
        except OSError:
            from numba.core.caching import NullCache

            dispatcher._cache = NullCache()


def lazy_njit(group: str | None = None, **options: Any) -> Callable[[Callable], Any]:
    """``numba.njit(**options)`` deferred to the first call of any kernel of ``group`` (default:
    the kernel's module; a package name groups kernels that call each other across modules).
    Kernels whose results must not depend on the CPU take no ``fastmath`` (FMA contraction and
    reassociation follow the CPU's features): ``simd`` gives explicit FMAs and vectors."""

    def wrap(fn: Callable) -> _LazyKernel:
        kernel = _LazyKernel(fn, options, group or fn.__module__)
        _LAZY.setdefault(kernel.group, []).append(kernel)
        return kernel

    return wrap


def simd_intrinsic(name: str) -> Any:
    """A module-level stand-in for ``SIMD``'s ``<name>`` in a kernel module of the kinematics
    group (the real intrinsic replaces it when the group loads)."""
    return _LazyIntrinsic(name)


def loaded(group: str) -> bool:
    """True once the kernels of ``group`` are numba dispatchers."""
    return not _LAZY.get(group)


#: the group of the kinematics kernels (they call each other across this package's modules)
GROUP = "sescid.kinematics"
#: the module of the SIMD intrinsics (imports numba and llvmlite: loaded with the kernels)
SIMD = "sescid.kinematics._kernels.simd"


def cache_folder() -> str | None:
    """The folder of numba's on-disk cache of the kinematics kernels (once loaded), or None
    where they have none (no writable folder: they compile in every process)."""
    dispatchers = _LOADED.get(GROUP) or [None]
    cache: Any = getattr(dispatchers[0], "_cache", None)
    path = getattr(cache, "_cache_path", None)
    return None if path is None or type(cache).__name__ == "NullCache" else str(path)


def compiled() -> bool:
    """True once the kinematics kernels are loaded."""
    return loaded(GROUP)


def load_kernels() -> None:
    """Load the kinematics kernels now (a long-running controller or session that queries one
    pose at a time: ``robot.com`` then takes the single-pose kernel). Results do not change."""
    load_group(GROUP)


#: work units a job may do in numpy before loading the kernels pays (ski rental): one unit is
#: one body of one pose in the chain (~0.1 µs in numpy) or one column of one row in the normal
#: equations (about as much); loading costs 0.5–1 s, so this is ~0.2 s of numpy work: a command
#: on a few thousand poses (``identify`` on 38, ``demo``'s 1000-pose fit and 20 000-pose CoPs)
#: never loads numba, a large file does. Counted in work, not seconds: the path does not depend
#: on the machine or its load.
NUMPY_JOB = 2_000_000


def use_kernels(work: int) -> bool:
    """True when a job of ``work`` units runs on the compiled kernels (``NUMPY_JOB``): the job's
    size alone decides, so the same inputs take the same path in every process."""
    return work > NUMPY_JOB


def prefer_kernels(work: int) -> bool:
    """``use_kernels``, or kernels already loaded: for paths whose numpy twin gives the kernel's
    bits, where the choice changes the speed only."""
    return work > NUMPY_JOB or compiled()
