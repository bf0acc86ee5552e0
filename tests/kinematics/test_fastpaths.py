"""The start-up numpy chain and the single-pose CoM against the compiled, blocked kernels."""

from __future__ import annotations

import subprocess
import sys

import numpy as np

from sescid.kinematics._kernels import chains as kchain
from sescid.kinematics._kernels import trig as ktrig
from sescid.sesc import com_from_sesc


def test_numpy_chain_equals_kernel(op2, rng):
    """Small blocks in numpy (before numba loads) give the kernel's rotations to 1e-15."""
    q = rng.uniform(-3, 3, (50, op2.nq))
    nb = len(op2.tree.parent)
    s, c1 = np.empty((nb, 50)), np.empty((nb, 50))
    ref = np.empty((nb, 3, 3, 50))
    ktrig.joint_trig(np.ascontiguousarray(q.T), op2.tree.jcol, op2.tree.coef, op2.tree.off, s, c1)
    kchain.chain_block(s, c1, op2.tree.arrays, ref)
    s2, c2, rot = np.empty_like(s), np.empty_like(c1), np.empty_like(ref)
    ktrig.trig_numpy(op2.tree, q, s2, c2)
    kchain.chain_numpy(op2.tree, s2, c2, rot)
    np.testing.assert_allclose(rot, ref, rtol=0, atol=2e-15)


def test_single_pose_com_equals_blocked(op2, rng):
    """robot.com on one pose (one compiled call) equals the blocked path on a batch."""
    q = rng.uniform(-1.5, 1.5, (5, op2.nq))
    op2.com(q)  # kernels loaded
    r = op2.sesc_vectors()
    batch = com_from_sesc(op2.tree, np.vstack([q, q]), r)[:5]
    for k in range(5):
        np.testing.assert_allclose(op2.com(q[k])[0], batch[k], rtol=0, atol=1e-16)
        np.testing.assert_allclose(op2.cop(q[k])[0], batch[k, :2], rtol=0, atol=1e-16)


def test_first_kernel_calls_from_two_threads_at_once():
    """Two threads whose first calls load the lazy kernels together both get results."""
    code = (
        "import threading, numpy as np, sescid\n"
        "from sescid import kinematics\n"
        "r = sescid.load_robot('op2')\n"
        "q = np.random.default_rng(0).uniform(-1, 1, (5000, r.nq))\n"
        "out, go = {}, threading.Barrier(4)\n"
        "def run(k):\n"
        "    go.wait()\n"
        "    out[k] = kinematics.cop_xy(r.tree, q, r.sesc_vectors())\n"
        "ts = [threading.Thread(target=run, args=(k,)) for k in range(4)]\n"
        "[t.start() for t in ts]; [t.join() for t in ts]\n"
        "assert len(out) == 4 and all(np.array_equal(out[0], v) for v in out.values())\n"
        "print('ok')\n"
    )
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert res.returncode == 0, res.stderr[-2000:]
    assert res.stdout.strip() == "ok"
