"""One BLAS thread for small products: limited inside, restored after, nested, pinned by the CLI."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
from threadpoolctl import threadpool_info

from sescid.base import threads


def _blas_threads() -> set[int]:
    return {i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"}


def test_one_thread_inside_and_the_callers_setting_after():
    """Inside the context every loaded BLAS runs one thread; nesting keeps it; after, as before."""
    np.linalg.eigh(np.eye(3))  # numpy's BLAS is loaded
    before = _blas_threads()
    with threads.one_blas_thread():
        assert _blas_threads() == {1}
        with threads.one_blas_thread():
            assert _blas_threads() == {1}
        assert _blas_threads() == {1}
    assert _blas_threads() == before


def test_identify_runs_on_one_blas_thread(op2, rng, monkeypatch):
    """``sescid.identify`` does its dense algebra inside the one-thread context."""
    from sescid.estimation.solvers import solve

    seen = []
    real = solve._estimate

    def spy(*args, **kwargs):
        seen.append(_blas_threads())
        return real(*args, **kwargs)

    monkeypatch.setattr(solve, "_estimate", spy)
    q = rng.uniform(-0.5, 0.5, (200, op2.nq))
    import sescid

    sescid.identify(op2, q, op2.cop(q))
    assert seen and all(s == {1} for s in seen)  # LS and the MAP of auto: one thread each


def test_the_command_line_pins_blas_before_numpy_loads():
    """The ``sescid`` script's entry (``_sescid_launch``) sets the thread variables (keeping the
    user's) before ``sescid``, and so numpy, is imported; the package then knows BLAS is pinned."""
    code = (
        "import os, sys\n"
        "import _sescid_launch\n"
        "_sescid_launch.pin_blas()\n"
        "assert 'numpy' not in sys.modules\n"
        "import sescid\n"
        "from sescid.base.threads import pinned\n"
        "from threadpoolctl import threadpool_info\n"
        "print(os.environ['OPENBLAS_NUM_THREADS'], os.environ['MKL_NUM_THREADS'],\n"
        "      sorted({i['num_threads'] for i in threadpool_info() if i['user_api'] == 'blas'}),\n"
        "      pinned())\n"
    )
    env = {k: v for k, v in os.environ.items() if k not in threads.THREAD_VARIABLES}
    env.pop(threads.PINNED_VARIABLE, None)
    env["MKL_NUM_THREADS"] = "3"  # the user's own choice survives (and then nothing is pinned)
    out = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True
    )
    assert out.stdout.split() == ["1", "3", "[1]", "False"]
    del env["MKL_NUM_THREADS"]
    out = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True
    )
    assert out.stdout.split() == ["1", "1", "[1]", "True"]


def test_pinning_after_numpy_loaded_is_not_taken_for_pinned():
    """``pin_process`` once numpy is loaded (``import sescid`` loads it) sets the variables for
    libraries loaded later, but ``one_blas_thread`` still limits the ones already loaded."""
    code = (
        "import sescid\n"
        "from sescid.base.threads import pin_process, pinned\n"
        "pin_process()\n"
        "print(pinned())\n"
    )
    env = {k: v for k, v in os.environ.items() if k not in threads.THREAD_VARIABLES}
    env.pop(threads.PINNED_VARIABLE, None)
    out = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True
    )
    assert out.stdout.split() == ["False"]


def test_ordered_map_keeps_the_order_and_runs_alone_on_one_core(monkeypatch):
    """Results come back in the items' order; with one usable core no worker is used."""
    import threading

    names = []

    def f(k):
        names.append(threading.current_thread().name)
        return k * k

    assert list(threads.ordered_map(f, range(50))) == [k * k for k in range(50)]
    monkeypatch.setattr(threads, "usable_cores", lambda: 1)
    names.clear()
    assert list(threads.ordered_map(f, range(5))) == [0, 1, 4, 9, 16]
    assert set(names) == {threading.current_thread().name}


def test_sums_and_cops_are_the_same_bits_on_any_number_of_cores(op2, rng, monkeypatch):
    """Blocks on worker threads, added in block order: normal equations and CoPs equal those
    computed on one core bit for bit."""
    from sescid import kinematics
    from sescid.estimation import accumulate

    n = 9 * 2048 + 77  # several blocks and a partial one, more than two CoP parts
    q = rng.uniform(-1, 1, (n, op2.nq))
    cop = rng.normal(0, 0.02, (n, 2))
    sigma = rng.uniform(0.001, 0.01, (n, 2))
    op2.cop(q)  # the kernels are loaded
    many = accumulate(op2, [(q, cop, sigma)])
    cops = kinematics.cop_xy(op2.tree, q, op2.sesc_vectors())
    monkeypatch.setattr(threads, "usable_cores", lambda: 1)
    one = accumulate(op2, [(q, cop, sigma)])
    assert np.array_equal(many.ata, one.ata) and np.array_equal(many.atb, one.atb)
    assert many.yty == one.yty and many.n_rows == one.n_rows == 2 * n
    assert np.array_equal(kinematics.cop_xy(op2.tree, q, op2.sesc_vectors()), cops)


def test_a_forked_child_gets_its_own_workers():
    """After fork the parent's pool has no threads in the child: the child makes its own."""
    import os

    assert list(threads.ordered_map(abs, [-1, -2, -3])) == [1, 2, 3]  # the parent's pool
    pid = os.fork()
    if pid == 0:  # the child: would wait forever on the inherited pool
        ok = list(threads.ordered_map(abs, [-4, -5, -6])) == [4, 5, 6]
        os._exit(0 if ok else 1)
    import signal
    import time

    deadline = time.monotonic() + 30
    while (done := os.waitpid(pid, os.WNOHANG))[0] == 0 and time.monotonic() < deadline:
        time.sleep(0.01)
    if done[0] == 0:  # stuck on the inherited pool
        os.kill(pid, signal.SIGKILL)
        os.waitpid(pid, 0)
    assert done[0] == pid and os.waitstatus_to_exitcode(done[1]) == 0
