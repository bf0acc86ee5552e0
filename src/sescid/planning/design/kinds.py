"""What a pose tells about the mass model, per measurement kind: the rows a D-optimal design
counts, with the torque sensors' offsets as nuisance.

A pose gives 2 CoP rows (x, y) and/or one row per measured joint torque. Each row is
divided by its kind's noise (CoP σ_c [m], torque σ_τ [N·m]), so the information adds
across kinds: F = Σ_i A_iᵀA_i over θ = [z; o], z the coordinates of vec(r) in an orthonormal
basis V of the identifiable subspace, o one offset per measured joint (always estimated):

    CoP row:    [Φ_xy(q) V / σ_c,  0]
    torque row: [M Φ_τ,j(q) V / σ_τ,  e_j / σ_τ]      (M the total mass, Φ_τ ``torque_regressor``)

What the poses say about the SESC part with the offsets unknown is the Schur complement
F_zz − F_zo F_oo⁻¹ F_oz; with every joint measured at every pose F_oo = (K / σ_τ²) I, so for
a fixed pose count K, log det of the Schur complement and log det F differ by a constant and a
D-optimal design maximises either. V spans the Schur complement of the candidate pool's rows
(the pool's identifiable subspace: torques alone miss the support body's own horizontal
moments). The friction band of a joint (known approach sides) is not planned for.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sescid.errors import OptionError
from sescid.estimation import DEFAULT_RTOL, accumulate, identifiable_eigen
from sescid.kinds import COP, TORQUE, DesignKind, Kinds, parse_kinds
from sescid.kinematics import as_poses
from sescid.robot import Robot
from sescid.simulation import PAPER_NOISE

#: N·m, torque noise a design assumes unless told (a current-based servo torque, per pose)
DEFAULT_TAU_NOISE = 0.05
#: poses per block of the torque regressor (bounds the memory of Φ_τ: n × J × 3N)
ROW_CHUNK = 2_000


@dataclass(frozen=True)
class DesignKinds:
    """The measurement kinds a design plans for, their noise and the measured joints."""

    kinds: Kinds = (COP,)  #: CoP rows, joint-torque rows, or both
    cop_noise: float = PAPER_NOISE  #: m, per pose
    tau_noise: float = DEFAULT_TAU_NOISE  #: N·m, per pose and joint
    tau_joints: tuple[str, ...] = ()  #: measured joints (names)
    total_mass: float = 1.0  #: kg, the scale of the torque rows

    @property
    def has_cop(self) -> bool:
        """The design counts CoP rows."""
        return COP in self.kinds

    @property
    def has_tau(self) -> bool:
        """The design counts torque rows."""
        return TORQUE in self.kinds

    @property
    def rows(self) -> int:
        """Rows per pose."""
        return 2 * self.has_cop + len(self.tau_joints) * self.has_tau

    @property
    def n_nuisance(self) -> int:
        """Offset columns (one per measured joint)."""
        return len(self.tau_joints) if self.has_tau else 0


def design_kinds(
    robot: Robot,
    kinds: Kinds | DesignKind = (COP,),
    cop_noise: float = PAPER_NOISE,
    tau_noise: float = DEFAULT_TAU_NOISE,
    tau_joints: tuple[str, ...] | None = None,
) -> DesignKinds:
    """Checked ``DesignKinds`` (``kinds``: parsed ones, or any ``parse_kinds`` spelling;
    ``tau_joints`` None: every joint); OptionError naming a bad one."""
    planned = parse_kinds(kinds)
    for name, value, unit in (("noise", cop_noise, "m"), ("tau_noise", tau_noise, "N·m")):
        if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
            raise OptionError(name, f"must be a positive noise level [{unit}], got {value}")
    joints = tuple(robot.joint_names) if tau_joints is None else tuple(tau_joints)
    if TORQUE in planned:
        if not joints:
            raise OptionError("tau_joints", "a torque design needs at least one measured joint")
        if len(set(joints)) != len(joints):
            raise OptionError("tau_joints", f"a joint is named twice: {', '.join(joints)}")
        robot.joint_columns(joints)  # ModelError naming an unknown joint
    return DesignKinds(planned, float(cop_noise), float(tau_noise), joints, robot.total_mass)


#: bytes of torque rows kept in memory between the basis and the rows (``TorqueRows``)
KEEP_BYTES = 300_000_000


class TorqueRows:
    """The scaled torque rows X = M Φ_τ / σ_τ of poses ``q``, block by block (``ROW_CHUNK``
    poses): computed once and kept when they fit in ``KEEP_BYTES``, else recomputed on every
    pass (the basis needs one pass, the rows a second)."""

    def __init__(self, robot: Robot, q: np.ndarray, spec: DesignKinds):
        self.robot, self.q, self.spec = robot, q, spec
        n3 = 3 * len(robot.body_names)
        self.kept: list[np.ndarray] | None = None
        if len(q) * len(spec.tau_joints) * n3 * 8 <= KEEP_BYTES:
            self.kept = [x for _, x in self._compute()]

    def _compute(self):
        scale = self.spec.total_mass / self.spec.tau_noise
        for s in range(0, len(self.q), ROW_CHUNK):
            yield s, self.robot.torque_regressor(self.q[s : s + ROW_CHUNK],
                                                 self.spec.tau_joints) * scale  # fmt: skip

    def blocks(self):
        """(start, X (m, J, 3N)) blocks in pose order."""
        if self.kept is None:
            yield from self._compute()
            return
        for k, x in enumerate(self.kept):
            yield k * ROW_CHUNK, x


def _torque_blocks(robot: Robot, q: np.ndarray, spec: DesignKinds, rows: TorqueRows | None):
    """The blocks of ``rows`` (computed for ``q`` when None)."""
    return (rows or TorqueRows(robot, q, spec)).blocks()


def pool_information(
    robot: Robot, q, spec: DesignKinds, torques: TorqueRows | None = None
) -> np.ndarray:
    """(3N, 3N) information about vec(r) of the poses ``q`` (n, nq) [rad], each kind's rows
    divided by its noise, the torque offsets marginalised (the Schur complement: per joint,
    the scatter of its rows about their mean over the poses); ``torques``: their torque rows
    already computed."""
    q = as_poses(q, robot.nq)
    n3 = 3 * len(robot.body_names)
    info = np.zeros((n3, n3))
    if spec.has_cop:
        ne = accumulate(robot, [(q, np.zeros((len(q), 2)))])
        info += ne.ata / spec.cop_noise**2
    if spec.has_tau:
        total = np.zeros((len(spec.tau_joints), n3))
        shift = None
        scatter = np.zeros((n3, n3))
        for _, x in _torque_blocks(robot, q, spec, torques):
            if shift is None:  # about the first block's mean: no cancellation in the sums
                shift = x.mean(axis=0)
            d = x - shift
            flat = d.reshape(-1, n3)
            scatter += flat.T @ flat
            total += d.sum(axis=0)
        info += scatter - total.T @ total / len(q)
    return (info + info.T) / 2


def kind_basis(
    robot: Robot,
    q,
    spec: DesignKinds,
    rtol: float = DEFAULT_RTOL,
    torques: TorqueRows | None = None,
) -> np.ndarray:
    """(3N, p) orthonormal basis of what the kinds' rows over the poses ``q`` determine
    (``pool_information``'s identifiable subspace, the estimation's rank rule)."""
    return identifiable_eigen(pool_information(robot, q, spec, torques), rtol)[1]


@dataclass(frozen=True)
class BlockRows:
    """Each candidate pose's design rows A_i = [x_i, nuisance] (r × (p + K)): ``x`` (n, r, p)
    the SESC part in the basis' coordinates; row a also has ``val[a]`` in nuisance column
    ``col[a]`` (−1: none), the offset of its joint."""

    x: np.ndarray  #: (n, r, p)
    col: np.ndarray  #: (r,) int64
    val: np.ndarray  #: (r,)
    n_nuisance: int

    @classmethod
    def plain(cls, x: np.ndarray) -> BlockRows:
        """The rows x (n, r, p) without offsets (no nuisance column: the CoP alone)."""
        r = x.shape[1]
        return cls(np.ascontiguousarray(x), -np.ones(r, dtype=np.int64), np.zeros(r), 0)

    @property
    def p(self) -> int:
        """SESC coordinates."""
        return int(self.x.shape[2])

    @property
    def size(self) -> int:
        """Length of θ = [z; o]."""
        return self.p + self.n_nuisance

    def take(self, idx) -> BlockRows:
        """The rows of the candidates ``idx``."""
        return BlockRows(np.ascontiguousarray(self.x[idx]), self.col, self.val, self.n_nuisance)

    def dense(self, idx=slice(None)) -> np.ndarray:
        """(m, r, p + K) full rows of the candidates ``idx``."""
        x = self.x[idx]
        out = np.zeros((*x.shape[:2], self.size))
        out[:, :, : self.p] = x
        rows = np.flatnonzero(self.col >= 0)
        out[:, rows, self.p + self.col[rows]] = self.val[rows]
        return out

    def information(self, idx) -> np.ndarray:
        """(p + K, p + K) F = Σ A_iᵀA_i over the candidates ``idx``: the SESC block from the
        rows, the nuisance blocks written out (row a adds ``val[a]`` in column ``col[a]``)."""
        x = self.x[idx]
        m, p = len(x), self.p
        flat = x.reshape(-1, p)
        out = np.zeros((self.size, self.size))
        out[:p, :p] = flat.T @ flat
        for a in np.flatnonzero(self.col >= 0):
            c = p + int(self.col[a])
            v = float(self.val[a])
            cross = x[:, a, :].sum(axis=0) * v
            out[:p, c] += cross
            out[c, :p] += cross
            out[c, c] += m * v * v
        return out


def block_rows(
    robot: Robot, q, spec: DesignKinds, basis: np.ndarray, torques: TorqueRows | None = None
) -> BlockRows:
    """The design rows of the poses ``q`` (n, nq) [rad] in ``basis`` (3N, p): CoP rows first,
    then one row per measured joint; each divided by its kind's noise (``torques``: their
    torque rows already computed)."""
    from sescid.planning.design.doptimal import projected_regressor

    q = as_poses(q, robot.nq)
    p = basis.shape[1]
    cop = tau = None
    if spec.has_cop:
        cop = projected_regressor(robot, q, basis) / spec.cop_noise
    if spec.has_tau:
        nj = len(spec.tau_joints)
        tau = np.empty((len(q), nj, p))
        for s, x in _torque_blocks(robot, q, spec, torques):
            tau[s : s + len(x)] = (x.reshape(-1, x.shape[2]) @ basis).reshape(len(x), nj, p)
    return offset_block_rows(cop, tau, spec.tau_noise)


def offset_block_rows(
    cop: np.ndarray | None, tau: np.ndarray | None, tau_noise: float
) -> BlockRows:
    """The ``BlockRows`` of a pose's CoP rows ``cop`` (n, 2, p) and torque rows ``tau`` (n, J, p)
    (either None: not counted), each already divided by its noise: the CoP rows first, then one
    row per measured joint with its offset (1/σ_τ, ``tau_noise`` [N·m]) in the joint's own
    nuisance column (module docstring)."""
    parts = [a for a in (cop, tau) if a is not None]
    x = parts[0] if len(parts) == 1 else np.concatenate(parts, axis=1)
    n_cop = 0 if cop is None else cop.shape[1]
    nj = 0 if tau is None else tau.shape[1]
    cols = np.concatenate([np.full(n_cop, -1), np.arange(nj)]).astype(np.int64)
    vals = np.concatenate([np.zeros(n_cop), np.full(nj, 1.0 / tau_noise)])
    return BlockRows(np.ascontiguousarray(x), cols, vals, nj)


def theta_information(info: np.ndarray, n_theta: int) -> np.ndarray:
    """(4N, 4N) the information about θ̃ of ``info`` over [θ̃; o], the offsets marginalised
    (Schur complement; offsets no pose measured drop out)."""
    f = (info + info.T) / 2
    if f.shape[0] == n_theta:
        return f
    foo = np.linalg.pinv(f[n_theta:, n_theta:], rcond=1e-12, hermitian=True)
    out = f[:n_theta, :n_theta] - f[:n_theta, n_theta:] @ foo @ f[n_theta:, :n_theta]
    return (out + out.T) / 2


def schur_information(rows: BlockRows, idx) -> np.ndarray:
    """(p, p) information about the SESC coordinates of the candidates ``idx``, the offsets
    marginalised: F_zz − F_zo F_oo⁺ F_oz (``theta_information``)."""
    return theta_information(rows.information(idx), rows.p)


def determined(rows: BlockRows, idx) -> int:
    """How many of the p SESC coordinates the candidates ``idx`` determine, the offsets
    marginalised (the rank rule of ``identifiable_eigen`` on their Schur information): fewer
    than their rows count when a pose's rows repeat one another (two parallel joints of the
    support leg add about one combination a pose, not two)."""
    return len(identifiable_eigen(schur_information(rows, idx))[0])


def min_block_poses(rows_per_pose: int, p: int, n_nuisance: int) -> int:
    """Fewest poses whose rows can determine p SESC coordinates and the offsets: K·r ≥ p + K_o
    (and two poses for an offset to be told from the torque it shifts)."""
    from sescid.estimation.result.identifiability import poses_needed

    return max(poses_needed(p + n_nuisance, max(rows_per_pose, 1)), 2 if n_nuisance else 1)
