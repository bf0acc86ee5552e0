"""The numpy path of the chain (before numba loads) against the compiled kernels, and its rule."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from sescid import kinematics as kin
from sescid.kinematics import compile as kcompile
from sescid.kinematics._kernels import chains as kchain
from sescid.kinematics._kernels import trig as ktrig

ROOT = Path(__file__).resolve().parents[2]


def _kernel_chain(tree, q):
    nb = len(tree.parent)
    s, c1 = np.empty((nb, len(q))), np.empty((nb, len(q)))
    rot = np.empty((nb, 3, 3, len(q)))
    ktrig.joint_trig(np.ascontiguousarray(q.T), tree.jcol, tree.coef, tree.off, s, c1)
    kchain.chain_block(s, c1, tree.arrays, rot)
    return s, c1, rot


@pytest.mark.parametrize("scale", [0.5, 3.0, 2e4])
def test_numpy_chain_is_the_kernel_bit_for_bit(op2, scale):
    """sin θ, 1 − cos θ, rotations, origins, reduced regressor columns and CoM sums of the numpy
    path are the compiled kernels' bits, small and large angles (|θ| up to ~4·10⁴ rad) alike."""
    tree, m = op2.tree, 300
    q = np.random.default_rng(7).uniform(-scale, scale, (m, op2.nq))
    s_ref, c_ref, rot_ref = _kernel_chain(tree, q)  # loads the kernels
    nb = len(tree.parent)
    org_ref = np.empty((nb, 3, m))
    kchain.origins_block(rot_ref, tree.parent, tree.t, tree.root_o, org_ref)
    cols_ref = kin.reduced_columns(tree, op2.reduction, q, None, True).copy()
    s, c1, rot = np.empty((nb, m)), np.empty((nb, m)), np.empty((nb, 3, 3, m))
    ktrig.trig_poly_numpy(tree, q, s, c1)
    kchain.chain_numpy(tree, s, c1, rot)
    assert np.array_equal(s, s_ref) and np.array_equal(c1, c_ref)
    assert np.array_equal(rot, rot_ref)
    org = np.empty((nb, 3, m))
    kchain.origins(rot, tree, org, False)
    assert np.array_equal(org, org_ref)
    assert np.array_equal(kin.reduced_columns(tree, op2.reduction, q, None, False), cols_ref)
    r = op2.sesc_vectors()
    com = kin.com_sum(rot, r, tree.root_o, 3).T
    assert np.array_equal(com, kin.com_rows(tree, q, r, 3))  # compiled: the kernels are loaded
    one = [kchain.com_one(tree, np.ascontiguousarray(qk), r) for qk in q[:5]]
    assert all(o is not None and np.array_equal(o[0], c) for o, c in zip(one, com, strict=False))


def test_chain_paths_agree_beyond_the_kernel_angle_range(op2):
    """chain() on angles beyond MAX_ANGLE (libm sin/cos on both paths) gives the same bits in
    numpy as with the kernels."""
    q = np.random.default_rng(3).uniform(-1, 1, (40, op2.nq)) * 3 * kin.MAX_ANGLE
    ref = kin.chain(op2.tree, q, None, True).copy()
    assert np.array_equal(kin.chain(op2.tree, q, None, False), ref)


def test_the_path_depends_on_the_job_alone():
    """numpy below NUMPY_JOB work units, the kernels above, whatever ran before; kernels already
    loaded may run a small job only where both paths give the same bits (prefer_kernels)."""
    assert not kcompile.use_kernels(kcompile.NUMPY_JOB)
    assert kcompile.use_kernels(kcompile.NUMPY_JOB + 1)
    kin.load_kernels()
    assert not kcompile.use_kernels(1) and kcompile.prefer_kernels(1)
    assert "_numpy_spent" not in vars(kcompile)  # no process-wide counter


def test_a_fit_is_the_same_bits_whatever_ran_before(tmp_path):
    """The same small and large fits in a fresh process and after the kernels were loaded by
    other work: the same bytes (the path is the job's, not the process's history)."""
    code = (
        "import sys, numpy as np, sescid\n"
        "r = sescid.load_robot('op2')\n"
        "if sys.argv[1] == 'warm':\n"
        "    sescid.kinematics.cop_xy(r.tree, np.zeros((3, r.nq)), r.sesc_vectors())\n"
        "out = []\n"
        "for n in (300, 30000):\n"
        "    rng = np.random.default_rng(n)\n"
        "    q = rng.uniform(-0.5, 0.5, (n, r.nq))\n"
        "    f = sescid.identify(r, q, rng.normal(0, 0.01, (n, 2)))\n"
        "    out.append(f.r.tobytes().hex() + f.cov.tobytes().hex() + repr(f.mae))\n"
        "print('numba' in sys.modules, hash(tuple(out)))\n"
    )
    env = dict(os.environ, PYTHONPATH=str(ROOT / "src"), PYTHONHASHSEED="0")
    runs = [
        subprocess.run([sys.executable, "-c", code, how], capture_output=True, text=True,
                       env=env, check=True).stdout.split()
        for how in ("cold", "warm")
    ]  # fmt: skip
    assert runs[0][1] == runs[1][1]


def test_demo_runs_without_numba_and_prints_the_readme_numbers(tmp_path):
    """`sescid demo` in a fresh process stays on the numpy path (numba is never imported) and
    prints the figures the README's §3 table quotes."""
    code = (
        "import sys\nfrom _sescid_launch import main\nsys.argv[0] = 'sescid'\n"
        "try:\n    main()\nfinally:\n    print('numba imported:', 'numba' in sys.modules)\n"
    )
    env = dict(os.environ, PYTHONPATH=str(ROOT / "src"))
    out = subprocess.run(
        [sys.executable, "-c", code, "demo", "--out-dir", str(tmp_path / "d")],
        capture_output=True,
        text=True,
        env=env,
        cwd=tmp_path,
    )
    assert out.returncode == 0, out.stderr
    assert "numba imported: False" in out.stdout
    readme = (ROOT / "README.md").read_text()
    table = readme[
        readme.index("## The paper's §3 study") : readme.index("## A short walk-through")
    ]
    for printed, quoted in [
        ("regressor rank p = 42 of 63", "| regressor rank | 42 of 63 |"),
        ("MAE estimated vs measured CoP: 3.853 mm", "| 3.853 mm |"),
        ("fitted poses: 0.693 mm", "| 0.693 mm |"),
        ("20000 fresh poses: 0.696 mm", "| 0.696 mm |"),
    ]:
        assert printed in out.stdout and quoted in table, printed


@pytest.mark.parametrize(("p", "m"), [(1, 1), (6, 3), (43, 2000)])
def test_the_small_jobs_gram_is_numpys_bit_for_bit_once_kernels_load(p, m):
    """A small job's normal-equation product (one column at a time, a product and a sum per
    element) gives the same bits in numpy and in its compiled twin, which runs it once the
    kernels are loaded (a planner's): the path changes the speed only."""
    from sescid.kinematics._kernels.gram import gram_in_order, padded

    rng = np.random.default_rng(p)
    x = rng.normal(size=(p, m)) * 10.0 ** rng.integers(-4, 4, size=(p, 1))
    ref = np.zeros((padded(p), padded(p)))
    kin.gram_numpy(x, ref)
    out = np.zeros_like(ref)
    gram_in_order(np.ascontiguousarray(x.T), out)
    assert out.tobytes() == ref.tobytes()
    kin.load_kernels()
    assert kin.gram_columns(x, False).tobytes() == ref.tobytes()
