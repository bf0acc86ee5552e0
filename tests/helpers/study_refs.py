"""The studies' independent references (tools/defaults_study.py, stances_study.py,
stances_physics.py import them as a library): "real" robots drawn around a model, body
parameters θ = [m; vec(m c)], and dense-numpy MAP references over θ with the weighed total
mass given as ``identify`` is.

The tools reach this folder on the development venv's path (the Makefile writes a ``.pth`` for
``tests/helpers``), the tests through pytest's ``pythonpath``.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from sescid.estimation import Measurements
from sescid.sesc import sesc_vectors

EXAMPLE_DATA = "share/example-robot-data/robots"
TORQUE_ROBOTS = {  # name: (model, sole, held link)
    "OP2": ("op2", None, "MP_BODY"),
    "TALOS": ("talos_data/robots/talos_reduced.urdf", "right_sole_link", "base_link"),
    "Unitree G1": ("g1_description/urdf/g1_29dof_rev_1_0.urdf", "right_ankle_roll_link", "pelvis"),
}


def model_path(rel: str) -> str:
    """An example-robot-data model (a test dependency) or an embedded robot's name."""
    if not rel.endswith(".urdf"):
        return rel
    import cmeel

    base = Path(cmeel.__file__).resolve().parent.parent / "cmeel.prefix"
    return str(base / EXAMPLE_DATA / rel)


# --- the real robots --------------------------------------------------------------------------
def real_bodies(robot, rng, extra: float = 0.05):
    """The model's bodies with CAD errors and unmodelled mass (module docstring)."""
    heavy = np.argsort(-robot.masses, kind="stable")[:8]
    out = []
    for b in robot.model.bodies:
        if b.mass <= 0:
            out.append(b)
            continue
        m = max(b.mass * (1 + rng.normal(0, 0.1)), 0.1 * b.mass)
        out.append(dataclasses.replace(b, mass=m, com=b.com + rng.normal(0, 0.005, 3)))
    total = robot.total_mass * extra
    for i, share in zip(
        rng.choice(heavy, 4, replace=False), rng.dirichlet(np.ones(4)), strict=True
    ):
        b = out[i]
        me, at = share * total, b.com + rng.normal(0, 0.02, 3)
        out[i] = dataclasses.replace(
            b, mass=b.mass + me, com=(b.mass * b.com + me * at) / (b.mass + me)
        )
    return out


def body_parameters(bodies) -> np.ndarray:
    """θ = [m (N); vec(m c) (3N)] in kg and kg·m, body frames."""
    return np.concatenate(
        [[b.mass for b in bodies], np.concatenate([b.mass * b.com for b in bodies])]
    )


def to_sesc(robot, theta: np.ndarray) -> np.ndarray:
    """SESC vectors (N, 3) of body parameters θ (``body_parameters``)."""
    n = len(robot.body_names)
    bodies = [
        dataclasses.replace(
            b,
            mass=theta[i],
            com=theta[n + 3 * i : n + 3 * i + 3] / theta[i] if theta[i] > 0 else b.com,
        )
        for i, b in enumerate(robot.model.bodies)
    ]
    return sesc_vectors(dataclasses.replace(robot.model, bodies=bodies))


# --- the independent MAP reference ------------------------------------------------------------
#: relative standard deviation of the weighed total mass in the references (a scale: exact)
WEIGHED_REL = 1e-6


def reference_map(
    robot, m: Measurements, sigma: float, prior_mean, prior_var, mass: float
) -> np.ndarray:
    """MAP over body parameters θ and per-joint offsets (flat), dense numpy (module docstring),
    given the weighed total ``mass`` as ``identify`` is (a pseudo-observation Σ m_i = mass);
    returns the SESC vectors (N, 3)."""
    from sescid.estimation.solvers.consistent import sesc_map
    from sescid.estimation.solvers.consistent.qp import H_UNIT

    n = len(robot.body_names)
    k = sesc_map(robot) * np.concatenate([np.ones(n), np.full(3 * n, 1 / H_UNIT)])[None, :]
    # τ = M Φ r with r = K θ / M: τ = Φ K θ (independent of M)
    phi = robot.torque_regressor(m.q, m.tau_joints)  # (n, J, 3N), τ = M Φ vec(r)
    nq, nj = m.tau.shape
    rows = np.einsum("njp,pk->njk", phi, k).transpose(1, 0, 2).reshape(nq * nj, -1)
    offsets = np.kron(np.eye(nj), np.ones((nq, 1)))
    a = np.hstack([rows, offsets])
    y = m.tau.T.reshape(-1)
    theta = map_solve(a / sigma, y / sigma, prior_mean, prior_var, n, mass)
    return (k @ theta[: 4 * n]).reshape(-1, 3) / theta[:n].sum()


def map_solve(a, y, prior_mean, prior_var, n: int, mass: float) -> np.ndarray:
    """The MAP of whitened rows ``a x ≈ y`` (x = [θ; nuisances], flat prior on the nuisances),
    the Gaussian prior on θ and the weighed mass Σ θ[:n] = ``mass``."""
    w = np.zeros(a.shape[1])
    w[:n] = 1.0 / (WEIGHED_REL * mass)
    a = np.vstack([a, w])
    y = np.concatenate([y, [mass / (WEIGHED_REL * mass)]])
    prec = np.zeros(a.shape[1])
    prec[: 4 * n] = 1.0 / prior_var
    x0 = np.concatenate([prior_mean, np.zeros(a.shape[1] - 4 * n)])
    lhs = a.T @ a + np.diag(prec)
    return x0 + np.linalg.solve(lhs, a.T @ (y - a @ x0))


def pooled_reference(ref, data, sigma, mean, var, mass):
    """Independent pooled MAP over θ and per-joint offsets (dense numpy), the weighed ``mass``
    given as ``identify`` is; returns r (N, 3)."""
    n = len(ref.body_names)
    blocks, ys = [], []
    for m in data:
        robot = ref.at(m.support or ref.support)
        e = robot.sesc_matrix(ref)  # r = E θ / M: τ = M Φ r = Φ E θ
        phi = robot.torque_regressor(m.q, m.tau_joints)
        nq, nj = m.tau.shape
        rows = np.einsum("njp,pk->njk", phi, e).transpose(1, 0, 2).reshape(nq * nj, -1)
        blocks.append(np.hstack([rows, np.kron(np.eye(nj), np.ones((nq, 1)))]))
        ys.append(m.tau.T.reshape(-1))
    a, y = np.vstack(blocks), np.concatenate(ys)
    theta = map_solve(a / sigma, y / sigma, mean, var, n, mass)
    return (ref.sesc_matrix() @ theta[: 4 * n] / theta[:n].sum()).reshape(-1, 3)
