"""``audit``: score candidate model files of one robot against what was measured.

For each candidate (a URDF or MJCF of the same robot): its total mass against the weighed one;
its prediction error on the data per kind, against the data's noise (the residual of the data's
own least-squares fit); the error left after a MAP fit with the candidate as the prior,
k-fold cross-validated (a candidate is not rewarded for what a fit absorbs); the bodies whose mass
or CoM the data reject (``linear.attribute``: beyond the noise, a two-sided z); the model checks
(``checks``). The ranking is by the candidate's mean squared normalised misfit (each row over its
kind's noise, the weighed mass over its uncertainty): 1 means "within the noise".
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from sescid.audit.checks import model_checks
from sescid.audit.linear import KindRows, attribute, kind_rows
from sescid.audit.result import AuditResult, CandidateAudit, KindError, body_change
from sescid.errors import DataError, ModelError, OptionError, SescidError
from sescid.estimation import (
    IdentifyOptions,
    MapOptions,
    Measurements,
    fit_measurements,
    for_support,
)
from sescid.estimation.data.balance_rows import balance_residuals
from sescid.estimation.result.identifiability import basis_of
from sescid.kinds import KINDS
from sescid.robot import Robot, load_robot

#: relative standard deviation of a weighed total mass when none is given
WEIGH_REL_STD = 0.005
#: z beyond which a change is named (two-sided, Bonferroni-corrected over the bodies)
DEFAULT_Z = 3.0
#: folds of the cross-validated error after a fit
DEFAULT_FOLDS = 5
#: a candidate sharing fewer of its joints than this with the others is another robot
SAME_ROBOT_SHARE = 0.5


@dataclass(frozen=True)
class AuditOptions:
    """How candidates are audited (``audit``): the stance ``support`` (and support ``line``) the
    files are loaded at, the weighed ``total_mass`` [kg] with its standard deviation
    ``mass_std`` [kg] (None: ``WEIGH_REL_STD`` of it), the z ``level`` a change must reach to be
    named, the ``folds`` of the cross-validated error (0: skip it) and per-kind ``noise``
    standard deviations (SI) instead of the data's own estimate. Checked when made."""

    support: str | None = None
    line: Any = None
    total_mass: float | None = None
    mass_std: float | None = None
    level: float = DEFAULT_Z
    folds: int = DEFAULT_FOLDS
    noise: dict[str, float] | None = None

    def __post_init__(self) -> None:
        folds, total_mass = self.folds, self.total_mass
        if not (isinstance(folds, int) and (folds == 0 or folds >= 2)):
            raise OptionError("folds", f"folds must be 0 (no cross-validation) or ≥ 2, got {folds}")
        if total_mass is not None and not (math.isfinite(total_mass) and total_mass > 0):
            raise OptionError("total_mass", f"the weighed mass must be > 0 kg, got {total_mass}")

    @property
    def weigh_std(self) -> float:
        """The weighed mass's standard deviation [kg] (1 without a weighed mass: unused)."""
        if self.mass_std is not None:
            return self.mass_std
        return WEIGH_REL_STD * self.total_mass if self.total_mass else 1.0


# --- reading the inputs ---------------------------------------------------------------------
def _load(model: Any, support: str | None, line: Any) -> Robot:
    return model if isinstance(model, Robot) else load_robot(model, support, line)


def _label(model: Any) -> str:
    return model.source if isinstance(model, Robot) else str(model)


def _same_robot(robots: list[Robot], labels: list[str]) -> None:
    first = set(robots[0].joint_names)
    for r, lab in zip(robots[1:], labels[1:], strict=True):
        common = len(first & set(r.joint_names))
        if common < SAME_ROBOT_SHARE * max(len(first), r.nq):
            raise ModelError(
                f"{lab} and {labels[0]} are not the same robot ({common} joints in common of "
                f"{r.nq} and {len(first)}): audit candidates of one robot"
            )


def _file_joints(path: Path, known: set[str]) -> set[str]:
    """The joints a data file names (angle or torque columns), among the ``known`` ones."""
    from sescid.tables import iter_table

    table = next(iter(iter_table(path)))
    out = set()
    for c in table.names():
        for base in (c, c.removesuffix("_deg"), c.removesuffix("_ticks"), c.removeprefix("tau_se_"),
                     c.removeprefix("tau_"), c.removeprefix("true_tau_")):  # fmt: skip
            if base in known:
                out.add(base)
    return out


def _read(data: Any, robot: Robot, label: str, known: set[str]) -> list[Measurements]:
    """The data as validated Measurements for one candidate (files read with its joints)."""
    items = data if isinstance(data, list | tuple) else [data]
    out: list[Measurements] = []
    for item in items:
        if isinstance(item, Measurements):
            if item.q.shape[1] != robot.nq:
                raise DataError(
                    f"{item.source}: {item.q.shape[1]} joint columns, {label} has {robot.nq} "
                    "joints: give the data as files (their columns name the joints)"
                )
            out.append(item)
            continue
        from sescid.api import file_stance
        from sescid.io.measurements import read_measurements

        path, stance = file_stance(item)
        missing = sorted(_file_joints(path, known) - set(robot.joint_names))
        if missing:
            raise ModelError(
                f"{label}: no joint {', '.join(missing)} of the data ({path.name}): this file "
                "does not describe the robot the data were measured on"
            )
        out += list(read_measurements(path, robot, support=stance))
    return [m.checked(robot) for m in out]


# --- the errors after a fit, cross-validated ------------------------------------------------
def _fold_ids(n: int, folds: int, seed: int) -> np.ndarray:
    return np.random.default_rng(seed).permutation(n) % folds


def _held_out(fit, m: Measurements) -> dict[str, np.ndarray]:
    """Residuals per kind of a fit on held-out data ``m``."""
    fs = for_support(fit, m.stance_on(fit.robot).label)
    out = {}
    if m.cop is not None:
        pred = fs.predict_cop(m.q, m.gravity) + fit.cop_bias
        ok = ~np.isnan(m.cop)
        out["cop"] = (m.cop - pred)[ok]
    if m.tau is not None and m.tau_joints:
        pred = fs.predict_torque(m.q, list(m.tau_joints), m.gravity, reading=True)
        out["tau"] = (m.tau - pred).reshape(-1)
    if m.balance is not None:
        assert m.gravity is not None
        out["balance"] = balance_residuals(fs.robot, fs.r, m.q, m.balance, m.gravity)
    return out


def cv_errors(
    robot: Robot, data: list[Measurements], folds: int, total_mass: float | None, seed: int = 0
) -> dict[str, float]:
    """RMS per kind of held-out residuals of MAP fits with the robot's file as the prior,
    ``folds``-fold over the poses of every data set (nan when a fold cannot be fitted)."""
    ids = [_fold_ids(m.n, folds, seed + i) for i, m in enumerate(data)]
    res: dict[str, list[np.ndarray]] = {}
    opts = IdentifyOptions(total_mass=total_mass)
    for f in range(folds):
        train = [m.take(np.flatnonzero(i != f)) for m, i in zip(data, ids, strict=True)]
        test = [m.take(np.flatnonzero(i == f)) for m, i in zip(data, ids, strict=True)]
        train = [m for m in train if m.n]
        try:
            fit = fit_measurements(robot, train, method=MapOptions(), options=opts)
        except SescidError:
            return {k: math.nan for k in KINDS}
        for m in test:
            if m.n:
                for k, v in _held_out(fit, m).items():
                    res.setdefault(k, []).append(v)
    return {k: float(np.sqrt(np.mean(np.concatenate(v) ** 2))) for k, v in res.items()}


# --- the audit --------------------------------------------------------------------------------
def audit_one(
    robot: Robot, label: str, data: list[Measurements], options: AuditOptions
) -> CandidateAudit:
    """One candidate's audit (rank 0: set by ``audit``)."""
    weighed, mass_std, level = options.total_mass, options.weigh_std, options.level
    theta = robot.body_parameters()
    rows: list[KindRows] = kind_rows(robot, data, theta, options.noise)
    sigmas = {k.kind: k.noise for k in rows}
    n = len(robot.body_names)

    # the nuisance columns (whitened, every kind's rows, the mass row last): projected out
    blocks = [k.nuisance / k.noise for k in rows] + ([np.zeros((1, 0))] if weighed else [])
    total = sum(b.shape[0] for b in blocks)
    nuis = np.zeros((total, sum(b.shape[1] for b in blocks)))
    r0 = c0 = 0
    for b in blocks:
        nuis[r0 : r0 + b.shape[0], c0 : c0 + b.shape[1]] = b
        r0, c0 = r0 + b.shape[0], c0 + b.shape[1]
    qn = basis_of(nuis, 1e-9)

    def residual(th: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Whitened residual and Jacobian at body parameters θ (the weighed mass a row), the
        sensor offsets and friction bands projected out."""
        at = rows if th is theta else kind_rows(robot, data, th, sigmas)
        e_parts = [(k.y - k.pred) / k.noise for k in at]
        a_parts = [k.jac / k.noise for k in at]
        if weighed is not None:
            e_parts.append(np.array([(weighed - float(th[:n].sum())) / mass_std]))
            row = np.zeros((1, 4 * n))
            row[0, :n] = 1.0 / mass_std
            a_parts.append(row)
        e, a = np.concatenate(e_parts), np.concatenate(a_parts)
        return e - qn @ (qn.T @ e), a - qn @ (qn.T @ a)

    gap = math.nan if weighed is None else weighed - robot.total_mass
    e, a = residual(theta)
    dofs = [k.dof for k in rows if k.dof > 0]
    noise_dof = min(dofs) if dofs else math.inf
    named, z_all, _ = attribute(e, a, robot, theta, level, noise_dof, residual)
    masses = robot.masses
    rejected = tuple(body_change(x, masses, robot) for x in named)
    folds = options.folds
    cv = cv_errors(robot, data, folds, weighed) if folds >= 2 else {}
    errors = []
    at = 0
    for k in rows:  # the file's error, what the nuisance columns absorb aside
        res = e[at : at + k.y.size] * k.noise
        at += k.y.size
        rms = float(np.sqrt(np.mean(res**2)))
        errors.append(KindError(k.kind, k.y.size, k.noise, rms, cv.get(k.kind, math.nan)))
    return CandidateAudit(
        model=label,
        total_mass=robot.total_mass,
        mass_gap=gap,
        errors=tuple(errors),
        score=float(np.mean(e**2)),
        z_overall=z_all,
        rank=0,
        rejected=rejected,
        checks=tuple(model_checks(robot)),
    )


def audit(
    data: Any, models: Sequence[Any], options: AuditOptions | None = None, **overrides: Any
) -> AuditResult:
    """Score candidate model files of one robot against measurements (module docstring).

    ``data``: a data file (``FILE@FRAME`` for a stance), a ``Measurements`` or a list of
    either (pooled). ``models``: model files (URDF/MJCF paths, embedded names) or ``Robot``s,
    loaded at ``support`` (on the support ``line`` for balance data, ``load_robot``).
    ``options``: ``AuditOptions``; keyword ``overrides`` replace its fields: ``total_mass``, the
    weighed mass [kg], with its standard deviation ``mass_std`` [kg] (default
    ``WEIGH_REL_STD`` of it); ``level``, the z a change must reach to be named; ``folds``, of
    the cross-validated error after a fit (0: skip it); ``noise``, per-kind noise standard
    deviations (SI) instead of the data's own estimate; ``support``, ``line``."""
    known_fields = {f.name for f in dataclasses.fields(AuditOptions)}
    unknown = sorted(set(overrides) - known_fields)
    if unknown:
        raise OptionError(unknown[0], "is not an option of audit")
    opts = dataclasses.replace(options or AuditOptions(), **overrides)
    if len(models) < 1:
        raise OptionError("models", "give at least one candidate model file")
    labels = [_label(m) for m in models]
    robots = [_load(m, opts.support, opts.line) for m in models]
    _same_robot(robots, labels)
    known = set().union(*(set(r.joint_names) for r in robots))
    out = []
    n_poses = 0
    for robot, label in zip(robots, labels, strict=True):
        sets = _read(data, robot, label, known)
        n_poses = sum(m.n for m in sets)
        out.append(audit_one(robot, label, sets, opts))
    order = sorted(range(len(out)), key=lambda i: (out[i].score, i))
    ranked = list(out)
    for rank, i in enumerate(order, 1):
        ranked[i] = dataclasses.replace(out[i], rank=rank)
    weighed = math.nan if opts.total_mass is None else float(opts.total_mass)
    return AuditResult(tuple(ranked), weighed, n_poses, opts.level, opts.folds)
