"""The numpy path of the chain (before numba loads) against the compiled kernels, and its rule."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from sescid import kinematics as kin
from sescid.kinematics import chains as kchain
from sescid.kinematics import compile as kcompile
from sescid.kinematics import trig as ktrig

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(autouse=True)
def _keep_numpy_spent():
    """Tests that reset the process's numpy-work counter restore it."""
    old = kcompile._numpy_spent[0]
    yield
    kcompile._numpy_spent[0] = old


def _kernel_chain(tree, q):
    nb = len(tree.parent)
    s, c1 = np.empty((nb, len(q))), np.empty((nb, len(q)))
    rot = np.empty((nb, 3, 3, len(q)))
    ktrig._joint_trig(np.ascontiguousarray(q.T), tree.jcol, tree.coef, tree.off, s, c1)
    kchain._chain_block(
        s, c1, tree.parent, tree.nz_ptr, tree.nz_k, tree.nz_j, tree.nz_a, tree.root_r, rot
    )
    return s, c1, rot


@pytest.mark.parametrize("scale", [0.5, 3.0, 2e4])
def test_numpy_chain_is_the_kernel_bit_for_bit(op2, scale, monkeypatch):
    """sin θ, 1 − cos θ, rotations, origins and reduced regressor columns of the numpy path are
    the compiled kernels' bits, small and large angles (|θ| up to ~4·10⁴ rad) alike."""
    tree, m = op2.tree, 300
    q = np.random.default_rng(7).uniform(-scale, scale, (m, op2.nq))
    s_ref, c_ref, rot_ref = _kernel_chain(tree, q)  # loads the kernels
    nb = len(tree.parent)
    org_ref = np.empty((nb, 3, m))
    kchain._origins_block(rot_ref, tree.parent, tree.t, tree.root_o, org_ref)
    cols_ref = kin.reduced_columns(tree, op2.reduction, q).copy()
    # the numpy path, as it runs while the kernels are not loaded
    monkeypatch.setitem(kcompile._LAZY, kcompile.GROUP, [object()])
    kcompile._numpy_spent[0] = 0
    s, c1, rot = np.empty((nb, m)), np.empty((nb, m)), np.empty((nb, 3, 3, m))
    ktrig._trig_poly_numpy(tree, q, s, c1)
    kchain._chain_numpy(tree, s, c1, rot)
    assert np.array_equal(s, s_ref) and np.array_equal(c1, c_ref)
    assert np.array_equal(rot, rot_ref)
    org = np.empty((nb, 3, m))
    kchain._origins(rot, tree, org)
    assert np.array_equal(org, org_ref)
    cols = kin.reduced_columns(tree, op2.reduction, q)
    assert kcompile._numpy_spent[0] == m * nb  # the chain ran in numpy
    assert np.array_equal(cols, cols_ref)


def test_chain_paths_agree_beyond_the_kernel_angle_range(op2, monkeypatch):
    """chain() on angles beyond MAX_ANGLE (libm sin/cos on both paths) gives the same bits in
    numpy as with the kernels loaded."""
    q = np.random.default_rng(3).uniform(-1, 1, (40, op2.nq)) * 3 * kin.MAX_ANGLE
    _kernel_chain(op2.tree, q[:1])  # loads the kernels
    ref = kin.chain(op2.tree, q).copy()
    monkeypatch.setitem(kcompile._LAZY, kcompile.GROUP, [object()])
    kcompile._numpy_spent[0] = 0
    assert np.array_equal(kin.chain(op2.tree, q), ref) and kcompile._numpy_spent[0] > 0


def test_numpy_path_rule(monkeypatch):
    """Blocks of ≤ SMALL_BLOCK poses run in numpy while the body-poses run so far plus the
    block's stay within NUMPY_BUDGET, and never once the kernels are loaded."""
    monkeypatch.setitem(kcompile._LAZY, kcompile.GROUP, [object()])
    kcompile._numpy_spent[0] = 0
    nb = 21
    assert kcompile._numpy_path(kcompile.SMALL_BLOCK, nb) and not kcompile._numpy_path(
        kcompile.SMALL_BLOCK + 1, nb
    )
    kcompile._numpy_spent[0] = kcompile.NUMPY_BUDGET - 100 * nb
    assert kcompile._numpy_path(100, nb) and not kcompile._numpy_path(101, nb)
    monkeypatch.setitem(kcompile._LAZY, kcompile.GROUP, [])
    assert not kcompile._numpy_path(1, nb)


def test_demo_runs_without_numba_and_prints_the_readme_numbers(tmp_path):
    """`sescid demo` in a fresh process stays on the numpy path (numba is never imported) and
    prints the figures the README's §3 table quotes."""
    code = (
        "import sys\nfrom sescid.cli import main\nsys.argv[0] = 'sescid'\n"
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
