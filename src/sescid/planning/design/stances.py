"""Stances, and what each tells about the body parameters every stance shares.

A *stance* is how the robot is measured: standing on one foot (``stand``, rooted at that sole),
on both feet (``double``: rooted at the reference foot, the CoP of the whole robot in its frame)
or held by a link in a gantry (``gantry``). Every stance sees the same body parameters
θ = [m (N); vec(m c) (3N)] (``Robot.body_parameters``, each body's mass and first moment in its
own frame, as the reference robot's bodies are defined); stance s's SESC vectors are
r_s = E_s θ / M with E_s = ``robot.at(s).sesc_matrix(reference)`` and M the total mass (known:
weighed, or the model's). So a pose in stance s gives

- CoP rows (standing on a foot or on both): Φ_s,xy(q) E_s θ / M, noise σ_c [m];
- joint-torque rows (on one foot or held): τ = Φ_τ,s(q) E_s θ + o, noise σ_τ [N·m], the offset
  o_j of each measured joint shared by every stance (the same sensor).

On both feet the joint torques depend on how the load splits between the feet (a closed
chain), not on θ alone: a double stance gives CoP rows only; a held robot loads no foot: a
gantry gives torque rows only.

Inside, θ is measured in units of the CAD prior (``theta_scale``: θ = D θ̃, a body's mass in
units of m̄ = m + M / (10 N), its first moments in units of ``estimation.map.BODY_COM_SCALE`` m̄,
the per-body prior of a MAP fit with τ = 1), so the rank rule and the prior compare like with
like. Rows are laid out [CoP x, CoP y, τ_1 … τ_J] in every stance (zeros where a stance does
not measure), over [θ̃ (4N); o (J)], each divided by its noise.
"""

from __future__ import annotations

import numpy as np

from sescid.planning.design.kinds import DesignKinds, theta_information
from sescid.robot import Robot
from sescid.stance import Stance, parse_stances, stance_robot

__all__ = ["Stance", "StanceRows", "parse_stances", "stance_robot", "theta_information"]
#: poses per block of rows (bounds the memory of Φ_τ: block × J × 4N)
ROW_BLOCK = 1_000


def theta_scale(robot: Robot) -> np.ndarray:
    """(4N,) D with θ = D θ̃: m̄_j = m_j + M / (10 N) [kg] for the masses, BODY_COM_SCALE · m̄_j
    [kg·m] for each first moment (module docstring)."""
    from sescid.estimation.solvers.map_prior import BODY_COM_SCALE

    m = robot.masses
    m_bar = m + m.sum() / (10 * m.size)
    return np.concatenate([m_bar, np.repeat(BODY_COM_SCALE * m_bar, 3)])


class StanceRows:
    """The rows one stance gives over [θ̃; o] (module docstring), for the design ``spec``."""

    def __init__(self, reference: Robot, stance: Stance, spec: DesignKinds, total_mass: float):
        self.stance, self.spec = stance, spec
        self.robot = stance_robot(reference, stance)
        self.e = self.robot.sesc_matrix(reference) * theta_scale(reference)[None, :]  # (3N, 4N)
        self.mass = float(total_mass)
        self.cop = spec.has_cop and stance.cannot("cop") is None
        self.tau = spec.has_tau and stance.cannot("tau") is None
        self.width = self.e.shape[1] + spec.n_nuisance  #: columns: 4N + J

    @property
    def n_rows(self) -> int:
        """Rows per pose (the layout every stance shares)."""
        return self.spec.rows

    def blocks(self, q: np.ndarray, gravity: np.ndarray | None = None):
        """(start, rows (m, r, 4N + J)) of poses q (n, nq) [rad], ``ROW_BLOCK`` poses at a time;
        ``gravity`` (n, 3): its direction in the stance's frame (None: level), the CoP rows
        then those of ``Robot.regressor_tilted`` (the constant ``Robot.d_tilted``)."""
        spec, nj = self.spec, len(self.spec.tau_joints)
        n4 = self.e.shape[1]
        for s in range(0, len(q), ROW_BLOCK):
            qb = q[s : s + ROW_BLOCK]
            gb = None if gravity is None else gravity[s : s + ROW_BLOCK]
            out = np.zeros((len(qb), self.n_rows, self.width))
            t = 0
            if spec.has_cop:
                if self.cop:  # (m, 2, 3N)
                    rb = self.robot
                    phi = rb.regressor(qb, (0, 1)) if gb is None else rb.regressor_tilted(qb, gb)
                    out[:, :2, :n4] = phi @ self.e / (self.mass * spec.cop_noise)
                t = 2
            if self.tau:
                phi = self.robot.torque_regressor(qb, spec.tau_joints, gb)  # (m, J, 3N)
                out[:, t:, :n4] = phi @ self.e / spec.tau_noise
                out[:, t + np.arange(nj), n4 + np.arange(nj)] = 1.0 / spec.tau_noise
            yield s, out

    def information(self, q: np.ndarray) -> np.ndarray:
        """(4N + J, 4N + J) Σ AᵀA over the poses q."""
        info = np.zeros((self.width, self.width))
        for _, x in self.blocks(q):
            flat = x.reshape(-1, self.width)
            info += flat.T @ flat
        return (info + info.T) / 2

    def projected(self, q: np.ndarray, basis: np.ndarray) -> np.ndarray:
        """(n, r, p + J) the rows of poses q in the coordinates [basis (4N, p); o]."""
        n4, p = basis.shape
        out = np.empty((len(q), self.n_rows, p + self.width - n4))
        for s, x in self.blocks(q):
            out[s : s + len(x), :, :p] = x[:, :, :n4] @ basis
            out[s : s + len(x), :, p:] = x[:, :, n4:]
        return out
