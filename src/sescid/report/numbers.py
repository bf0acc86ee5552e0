"""The report's numbers, computed once from a fit and its data (no fitting, no HTML).

Residuals are measured − predicted per row of each kind (a CoP component in m, a joint torque
at a pose in N·m): for the identified model net of the sensor offsets and friction bands it
estimated (``sescid.estimation``'s one rule); for the manufacturer (CAD) model net of its own
best sensor terms of the same form (a constant offset per torque sensor, its friction band with
approach sides, a constant CoP offset when the fit estimated one: a projection, closed form),
so that the two models are compared on their masses, not on sensor errors.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sescid.estimation import Fit, Kind, Measurements
from sescid.estimation.solvers.least_squares import residuals

#: the two models every residual is shown for
CAD, IDENTIFIED = "manufacturer model", "identified"
#: joints drawn in the support-leg figure when the support is the trunk itself (a gantry)
MAX_LEG_JOINTS = 6


@dataclass(frozen=True)
class ResidualStats:
    """Statistics of a group of residual rows (measured − predicted), in their unit."""

    name: str  #: "x", "y", a joint, or "all"
    n_rows: int
    mean: float
    rms: float  #: √(mean of squares)
    mae: float  #: mean of absolute values


def residual_stats(name: str, res: np.ndarray) -> ResidualStats:
    """``ResidualStats`` of all entries of ``res`` (any shape)."""
    flat = np.asarray(res, dtype=float).reshape(-1)
    if flat.size == 0:
        return ResidualStats(name, 0, math.nan, math.nan, math.nan)
    return ResidualStats(
        name,
        flat.size,
        float(flat.mean()),
        float(np.sqrt(np.mean(flat**2))),
        float(np.mean(np.abs(flat))),
    )


@dataclass(frozen=True)
class KindNumbers:
    """One measurement kind at the report's poses: measured (n, k), what each model predicts
    (what the sensor would read: sensor terms included), residuals and their statistics."""

    kind: Kind  #: "cop" (m) or "tau" (N·m)
    unit: str
    columns: tuple[str, ...]  #: ("x", "y") or the measured joints
    measured: np.ndarray  #: (n, k)
    predicted: dict[str, np.ndarray]  #: model → (n, k)
    residual: dict[str, np.ndarray]  #: model → (n, k), measured − predicted
    stats: dict[str, tuple[ResidualStats, ...]]  #: model → per column, then "all"

    def total(self, model: str = IDENTIFIED) -> ResidualStats:
        """The statistics over every row of this kind."""
        return self.stats[model][-1]


def _kind_numbers(kind, unit, columns, measured, residual: dict[str, np.ndarray]) -> KindNumbers:
    stats = {
        model: tuple(residual_stats(c, res[:, k]) for k, c in enumerate(columns))
        + (residual_stats("all", res),)
        for model, res in residual.items()
    }
    predicted = {model: measured - res for model, res in residual.items()}
    return KindNumbers(kind, unit, tuple(columns), measured, predicted, residual, stats)


def project_out(x: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """Rows x (n, k) minus their least-squares fit on the columns cols (n, c): what the columns
    cannot explain (each of the k columns of x on its own)."""
    if cols.shape[1] == 0:
        return x
    coef, *_ = np.linalg.lstsq(cols, x, rcond=None)
    return x - cols @ coef


def torque_nuisance_columns(n: int, approach: np.ndarray | None) -> np.ndarray:
    """(n, 1 or 2) a torque sensor's nuisance columns: its offset, and the approach side that
    multiplies its friction band when known."""
    ones = np.ones((n, 1))
    return ones if approach is None else np.column_stack([ones, approach])


def cop_numbers(fit: Fit, data: Measurements) -> KindNumbers | None:
    """The CoP's numbers (None without CoP data)."""
    if data.cop is None:
        return None
    res = residuals(fit, data)["cop"]
    cad = data.cop - fit.robot.cop(data.q, fit.r_prior, data.gravity)
    if fit.cop_offset is not None:  # the CAD model's own constant offset
        cad = project_out(cad, np.ones((data.n, 1)))
    return _kind_numbers("cop", "m", ("x", "y"), data.cop, {CAD: cad, IDENTIFIED: res})


def cad_torques(fit: Fit, data: Measurements) -> np.ndarray:
    """(n, J) holding torques of the manufacturer model (its SESC vectors and mass), N·m."""
    return fit.robot.torques(
        data.q, fit.r_prior, joints=data.tau_joints, gravity=data.gravity, g0=fit.gravity_accel
    )


def torque_numbers(fit: Fit, data: Measurements) -> KindNumbers | None:
    """The joint torques' numbers (None without torque data)."""
    if data.tau is None or not data.tau_joints:
        return None
    res = residuals(fit, data)["tau"]
    cad = project_out(
        data.tau - cad_torques(fit, data), torque_nuisance_columns(data.n, data.approach)
    )
    return _kind_numbers("tau", "N·m", data.tau_joints, data.tau, {CAD: cad, IDENTIFIED: res})


def support_leg_joints(
    fit: Fit, joints: tuple[str, ...], tau: np.ndarray
) -> tuple[tuple[int, ...], bool]:
    """Columns of ``joints`` between the support body and the trunk (the model file's root),
    from the support upwards, and True; when none is measured there (a support that is the
    trunk itself: a gantry), the ``MAX_LEG_JOINTS`` measured joints whose torque varies most
    over the poses, and False."""
    model = fit.robot.model
    trunk = model.link_frames[model.model_root][0] if model.model_root in model.link_frames else 0
    chain = []
    b = trunk
    while b > 0:
        chain.append(model.bodies[b].joint_name)
        b = model.bodies[b].parent
    cols = [joints.index(j) for j in reversed(chain) if j in joints]
    if cols:
        return tuple(cols), True
    spread = np.ptp(tau, axis=0)
    return tuple(sorted(np.argsort(-spread, kind="stable")[:MAX_LEG_JOINTS].tolist())), False


@dataclass(frozen=True)
class MassRow:
    """One body of a consistent fit: CAD and identified mass (kg), CoM in the body's link frame
    (m), its shift from the CAD CoM (m), and the constraints active on it."""

    body: str
    cad_mass: float
    mass: float
    change: float  #: (mass − CAD) / CAD; nan for a body the CAD model gives no mass
    com_link: np.ndarray  #: (3,)
    com_shift: float  #: |CoM − CAD CoM|
    active: tuple[str, ...]


def mass_rows(fit: Fit) -> list[MassRow] | None:
    """The identified masses and CoMs of a consistent fit (None for a fit without them)."""
    b = fit.inertials
    if b is None:
        return None
    model = fit.robot.model
    cad = fit.robot.masses if b.cad_masses is None else np.asarray(b.cad_masses, dtype=float)
    out = []
    for i, body in enumerate(model.bodies):
        x = model.link_frames[body.name][1]
        cad_com = x[:3, :3].T @ (np.asarray(body.com, dtype=float) - x[:3, 3])
        prefix = f"{body.name}: "
        active = tuple(a[len(prefix) :] for a in b.active_constraints if a.startswith(prefix))
        m0, m1 = float(cad[i]), float(b.masses[i])
        com = np.asarray(b.coms_link[i], dtype=float)
        out.append(
            MassRow(
                body=body.name,
                cad_mass=m0,
                mass=m1,
                change=(m1 - m0) / m0 if m0 > 0 else math.nan,
                com_link=com,
                com_shift=float(np.linalg.norm(com - cad_com)),
                active=active,
            )
        )
    return out


#: a joint is called worse than CAD when its residual RMS exceeds CAD's by more than this
WORSE_MARGIN = 0.10
#: … and "lightly loaded" when CAD's residual RMS there is below this share of the largest
LIGHT_SHARE = 0.25
#: … and "decided elsewhere" when its rows carry less than this share of the fit's parameters
DECIDED_ELSEWHERE = 0.5


@dataclass(frozen=True)
class WorseJoint:
    """A joint whose identified residual RMS exceeds the manufacturer model's, and why."""

    joint: str
    rms: float  #: identified, N·m
    cad_rms: float  #: manufacturer model, N·m
    reason: str


def worse_joints(fit: Fit, k: KindNumbers) -> tuple[WorseJoint, ...]:
    """The joints whose identified residual RMS exceeds CAD's by over ``WORSE_MARGIN``, each
    with the likeliest reason, from the fit's records: one noise level shared by light and
    heavy joints; a residual within the joint's own noise σ_j; rows that carry little of the
    fit (``JointNoise.params`` < ``DECIDED_ELSEWHERE``: the bodies beyond it decided by the
    prior and the other joints); else other joints' data pulling those bodies from CAD."""
    noise = {r.joint: r for r in fit.torque_noise}
    fit_s, cad_s = k.stats[IDENTIFIED][:-1], k.stats[CAD][:-1]
    largest = max((s.rms for s in cad_s if math.isfinite(s.rms)), default=math.nan)
    out = []
    for f, c in zip(fit_s, cad_s, strict=True):
        if not (f.rms > (1 + WORSE_MARGIN) * c.rms):
            continue
        n = noise.get(f.name)
        if n is None and c.rms < LIGHT_SHARE * largest:
            why = (
                f"lightly loaded: CAD's residual here ({c.rms:.3g} N·m) weighs little against "
                f"the most loaded joint's ({largest:.3g} N·m) under one shared noise level"
            )
        elif n is None:
            why = "one noise level shared by every joint"
        elif n.unit == "N·m" and f.rms <= (1 + WORSE_MARGIN) * n.sigma:
            why = (
                f"within this joint's own noise (σ_j {n.sigma:.3g} N·m): CAD fits these rows "
                "as well to within the noise"
            )
        elif math.isfinite(n.params) and n.params < DECIDED_ELSEWHERE:
            why = (
                f"its rows carry {n.params:.2f} of the fit's parameters: the bodies beyond it "
                "are decided by the prior and the other joints' data, not by its own torques"
            )
        else:
            why = (
                "the other joints' data move the bodies beyond it away from CAD (its rows "
                f"carry {n.params:.2f} of the fit's parameters): an error the model cannot "
                "represent (unmodelled mass, joint play, a sensor's gain) lands here"
            )
        out.append(WorseJoint(f.name, f.rms, c.rms, why))
    return tuple(out)
