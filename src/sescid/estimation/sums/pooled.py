"""Several stances pooled: the body parameters every stance shares as the unknowns.

A robot measured on its right foot, then its left, on both feet, held in a fixture: each stance
s has its own SESC vectors r_s, and each is a linear image of the same body parameters (masses
and first moments, ``Robot.sesc_matrix``)::

    vec(r_s) = L_s x        x = [m / M (N); vec(m c) / (M ℓ) (3N)]        (ℓ = 0.1 m)

with M the total mass the rows are scaled by. Each stance's sums are made over its own r_s by the
usual kernels (``system.Accumulator`` with the stance's robot) and lifted to x
(A_x = L_sᵀ A_s L_s, nuisance columns kept); the stances' sums add up, and a sensor seen in
several stances (a joint's torque sensor) is one set of nuisance columns. Least squares and MAP
run on x unchanged; a stance alone determines only what its r_s shows, pooling adds what the
stances see differently (the support body's own moments, which one foot never moves but the
other does; masses).

The fit is reported as today, for the robot's support: r = L_ref x̂ with its covariance, its
identifiable subspace {g : L_refᵀ g ∈ range(A_x)} and the information on it, named combinations
of r; ``Fit.bodies`` keeps x̂ with its covariance and information and what each stance
determines, and ``Fit.for_support`` gives the same fit in another stance's frame.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from sescid.errors import DataError
from sescid.estimation.result.identifiability import (
    base_combinations,
    eigen_rank,
    label_columns,
)
from sescid.estimation.solvers.solve import Solution, marginal_x
from sescid.estimation.sums.normal_equations import expand
from sescid.estimation.sums.system import Accumulator, KindSums, RowOptions, System
from sescid.kinds import TORQUE
from sescid.robot import Robot
from sescid.stance import Stance, own_stance, stance_robot

#: ℓ, the length unit of the pooled first moments (m): keeps x's columns of one scale
PARAM_UNIT = 0.1


def stance_map(robot: Robot, support: str) -> np.ndarray:
    """L_s (3N, 4N): vec(r_s) = L_s x for the stance ``support`` of ``robot``'s model, x the
    body parameters of ``robot``'s bodies (module docstring)."""
    n = len(robot.body_names)
    scale = np.concatenate([np.ones(n), np.full(3 * n, PARAM_UNIT)])
    return robot.stance(support).sesc_matrix(robot) * scale[None, :]


def prior_x(robot: Robot) -> np.ndarray:
    """X (4N,) of the model file (its masses over its total mass): ``L_ref x`` is its r."""
    theta = robot.body_parameters()
    n = len(robot.body_names)
    x = theta / robot.total_mass
    x[n:] /= PARAM_UNIT
    return x


def x_labels(robot: Robot) -> list[str]:
    """Names of x's components: "m[body]" (mass / M), "h[body].x" (first moment / (M ℓ))."""
    names = robot.body_names
    return [f"m[{b}]" for b in names] + [f"h[{b}].{a}" for b in names for a in "xyz"]


def lift(system: System, lmap: np.ndarray) -> System:
    """A stance's sums over [vec(r_s); nuisance] as sums over [x; nuisance] (fixed order)."""
    k = len(system.nuisance)
    n_x = lmap.shape[1]
    t = np.zeros((system.n_x + k, n_x + k))
    t[: system.n_x, :n_x] = lmap
    t[system.n_x :, n_x:] = np.eye(k)
    parts = {}
    for kind, part in system.parts.items():
        ata, atb = expand(t, part.ne)
        ne = dataclasses.replace(part.ne, ata=(ata + ata.T) / 2, atb=atb)
        parts[kind] = KindSums(part.kind, ne, part.weighted)
    return dataclasses.replace(system, n_x=n_x, parts=parts, space="bodies", stances={})


def accumulate_sources(
    robot: Robot, sources, options: RowOptions | None = None, progress=None
) -> System:
    """The system of several sources, each an iterable of ``Measurements`` chunks (validated;
    ``accumulate_stances``): over the robot's SESC vectors when every row was measured in
    its own support, else over the body parameters the stances share (``pooled``)."""
    systems = accumulate_stances(robot, sources, options or RowOptions(), progress)
    own = own_stance(robot)
    if list(systems) == [own]:
        return systems[own]
    return pooled(robot, systems)


def accumulate_stances(
    robot: Robot, sources, options: RowOptions, progress=None
) -> dict[Stance, System]:
    """Each stance's system of several sources, each an iterable of ``Measurements`` chunks
    (validated): stance → System over that stance's SESC vectors, each summed with its own
    robot (``Measurements.stance_on``); ``progress(poses_done)`` counts the poses of all
    sources. ``accumulate_sources`` makes one system of them."""
    systems: dict[Stance, System] = {}
    before = 0
    for chunks in sources:
        accs: dict[Stance, Accumulator] = {}
        start = before
        report = None if progress is None else (lambda d, s0=start: progress(s0 + d))
        for m in chunks:
            key = m.stance_on(robot)
            if key not in accs:
                accs[key] = Accumulator(stance_robot(robot, key), options)
            accs[key].add(m, report)
        for key, acc in accs.items():
            part = acc.finish()
            before += part.n_poses
            systems[key] = part if key not in systems else systems[key].merged(part)
    if not systems:
        raise DataError("no data to identify from")
    return systems


def pooled(robot: Robot, systems: dict[Stance, System]) -> System:
    """The system over x of every stance's sums (stance → its System over its r_s), each
    kept under its label (``System.stances``, as a fit names its stances)."""
    lifted: dict[str, System] = {}
    for stance, system in systems.items():
        why = stance.cannot(TORQUE) if TORQUE in system.kinds else None
        if why is not None:  # data_stance refuses it first
            raise DataError(why)
        if any(n.kind == "cop" for n in system.nuisance):
            raise DataError(
                "a CoP offset (bias) per foot is not fitted across stances: fit one stance"
            )
        part, label = lift(system, stance_map(robot, stance.label)), stance.label
        lifted[label] = lifted[label].merged(part) if label in lifted else part  # gantry:FOOT
    out: System | None = None
    for part in lifted.values():
        out = part if out is None else out.merged(part)
    assert out is not None
    return dataclasses.replace(out, space="bodies", stances=lifted)


@dataclass(frozen=True)
class StanceRank:
    """What one stance's data determine alone."""

    support: str
    n_poses: int
    n_rows: int
    rank: int  #: body-parameter combinations its data determine


@dataclass(frozen=True)
class BodyFit:
    """A pooled fit's body parameters x (``pooled``), what determines them, and by stance.

    ``x`` (4N,), ``cov`` (4N, 4N) in x's units (mass / M, first moment / (M ℓ)); ``information``
    (4N, 4N) the data's (nuisance marginalised, weighted rows); ``rank`` of it; ``stances`` what
    each stance determines alone; ``added`` the combinations of x pooling determines beyond the
    best single stance (named by their largest terms)."""

    x: np.ndarray
    x_prior: np.ndarray
    cov: np.ndarray
    information: np.ndarray
    rank: int
    stances: tuple[StanceRank, ...]
    added: tuple[str, ...]
    total_mass: float  #: kg, the M x is scaled by

    def masses(self) -> np.ndarray:
        """(N,) body masses [kg] of x (not constrained to be physical: see ``consistent``)."""
        n = self.x.size // 4
        return self.x[:n] * self.total_mass


def _null(m: np.ndarray, tol: float = 1e-9) -> np.ndarray:
    """Orthonormal basis of the null space of m (rows × n)."""
    if m.size == 0:
        return np.eye(m.shape[1])
    _, s, vt = np.linalg.svd(m, full_matrices=True)
    rank = int(np.sum(s > tol * (s[0] if s.size else 1.0)))
    return vt[rank:].T


def _seen_through(t: np.ndarray, unseen: np.ndarray, ainv: np.ndarray, rtol: float):
    """The information on y = T x of data with pseudo-inverse information ``ainv`` that leave
    x's directions ``unseen`` (orthonormal columns) undetermined: on the directions of y whose
    preimage the data see ({g : Tᵀg ∈ range(A)}); its eigen-decomposition (descending) and
    rank."""
    g = _null(unseen.T @ t.T)
    core = g.T @ t @ ainv @ t.T @ g
    ata = g @ np.linalg.pinv((core + core.T) / 2, hermitian=True) @ g.T
    ata = (ata + ata.T) / 2
    return ata, *eigen_rank(ata, rtol)


def view(sol: Solution, lmap: np.ndarray, n_x: int, rtol: float) -> Solution:
    """The x-space solution seen in [vec(r_s); nuisance] (r_s = L x): estimate and covariance
    mapped, the information of the r_s-directions the data determine ({g : Lᵀg ∈ range(A)}),
    its eigenvectors and rank."""
    k = sol.theta.size - n_x
    t = np.zeros((lmap.shape[0] + k, n_x + k))
    t[: lmap.shape[0], :n_x] = lmap
    t[lmap.shape[0] :, n_x:] = np.eye(k)
    p = sol.rank
    vp, lp = sol.vecs[:, :p], sol.lam[:p]
    ata, lam, vecs, rank = _seen_through(t, sol.vecs[:, p:], (vp / lp) @ vp.T, rtol)
    return dataclasses.replace(
        sol,
        theta=t @ sol.theta,
        theta0=t @ sol.theta0,
        cov=t @ sol.cov @ t.T,
        ata=ata,
        lam=lam,
        vecs=vecs,
        rank=rank,
    )


def body_fit(robot: Robot, system: System, sol: Solution, x: np.ndarray, cov: np.ndarray,
             rtol: float) -> BodyFit:  # fmt: skip
    """The ``BodyFit`` of a pooled solution (x̂ and its covariance given: LS or MAP)."""
    n_x = system.n_x
    lam, vecs, p = marginal_x(sol, n_x, rtol)
    info = (vecs[:, :p] * lam[:p]) @ vecs[:, :p].T
    labels = x_labels(robot)
    stances = []
    ranges = []
    for support, part in system.stances.items():
        a = np.sum([ks.ne.ata for ks in part.parts.values()], axis=0)
        k = a.shape[0] - n_x
        if k:
            ann = a[n_x:, n_x:]
            coupled = a[:n_x, n_x:] @ np.linalg.pinv(ann, hermitian=True) @ a[n_x:, :n_x]
            a = a[:n_x, :n_x] - coupled
        _, v, r = eigen_rank((a + a.T) / 2, rtol)
        ranges.append(v[:, :r])
        rows = sum(ks.ne.n_rows for ks in part.parts.values())
        stances.append(StanceRank(support, part.n_poses, rows, r))
    # what pooling adds to the best single stance (the robot's own support first)
    order = sorted(
        range(len(stances)), key=lambda i: (-stances[i].rank, stances[i].support != robot.support)
    )
    added = []
    if order:
        q = ranges[order[0]]
        extra = vecs[:, :p] - q @ (q.T @ vecs[:, :p])
        u, s2, _ = np.linalg.svd(extra, full_matrices=False)
        for i in np.flatnonzero(s2 > 0.5):
            d = u[:, i]
            top = np.argsort(-np.abs(d))[:4]
            added.append(" ".join(f"{d[j]:+.2g}·{labels[j]}" for j in top if abs(d[j]) > 0.05))
    mass = system.total_mass
    return BodyFit(x, prior_x(robot), cov, info, p, tuple(stances), tuple(added), mass)


def for_support(fit, support: str):
    """The pooled ``fit`` seen in another stance (its robot, r_s, covariance, determined
    subspace and the information on it); the fit itself for its own support (``support``: a
    stance's label, as the fit names its stances)."""
    robot = fit.robot.stance(support)
    if robot is fit.robot:  # its own support, or both feet in its frame
        return fit
    b = fit.bodies
    if b is None:
        raise DataError(
            f"the fit was made in one stance ('{fit.robot.support}'): it has no body "
            "parameters to predict another stance with (pool the stances' data)"
        )
    lmap = stance_map(fit.robot, support)
    r = (lmap @ b.x).reshape(-1, 3)
    cov = lmap @ b.cov @ lmap.T
    w, v = np.linalg.eigh((b.information + b.information.T) / 2)
    keep = w > 1e-12 * max(float(w.max()), 1e-300)
    ainv = (v[:, keep] / w[keep]) @ v[:, keep].T
    _, lam, vecs, rank = _seen_through(lmap, _null(b.information), ainv, fit.rtol)
    sv = np.sqrt(np.clip(lam, 0, None))
    labels = label_columns(robot)
    base = tuple(base_combinations(sv, vecs, rank, labels, r, cov))
    return dataclasses.replace(
        fit, robot=robot, r=r, r_prior=(lmap @ b.x_prior).reshape(-1, 3), cov=cov,
        basis=vecs[:, :rank], singular_values=sv, rank=rank, base=base, unidentifiable=(),
        weak=(),
    )  # fmt: skip


def check_pooled_prior(prior: str) -> None:
    """A pooled fit's prior is per body ("bodies" or "auto")."""
    if prior == "sesc":
        raise DataError(
            "a per-component prior on one stance's SESC vectors does not cover the body "
            "parameters several stances share: use the per-body prior (prior='bodies')"
        )
