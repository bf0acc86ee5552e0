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

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from sescid.audit.checks import Check, model_checks
from sescid.audit.linear import ALL_BODIES, KindRows, Named, attribute, kind_rows
from sescid.errors import DataError, ModelError, OptionError, SescidError
from sescid.estimation import (
    IdentifyOptions,
    MapOptions,
    Measurements,
    fit_measurements,
    for_support,
)
from sescid.estimation.data.balance_rows import balance_residuals
from sescid.robot import Robot, load_robot

#: relative standard deviation of a weighed total mass when none is given
WEIGH_REL_STD = 0.005
#: z beyond which a change is named (two-sided, Bonferroni-corrected over the bodies)
DEFAULT_Z = 3.0
#: folds of the cross-validated error after a fit
DEFAULT_FOLDS = 5
#: a candidate sharing fewer of its joints than this with the others is another robot
SAME_ROBOT_SHARE = 0.5
#: display unit of each kind: (JSON suffix, factor from SI, printed unit)
AUDIT_UNITS = {
    "cop": ("mm", 1e3, "mm"),
    "tau": ("Nm", 1.0, "N·m"),
    "balance": ("deg", 180 / math.pi, "°"),
}
AUDIT_TITLES = {"cop": "CoP", "tau": "torques", "balance": "balance tilt"}


@dataclass(frozen=True)
class KindError:
    """One kind's errors for a candidate, SI (m, N·m, rad): ``AUDIT_UNITS`` converts them."""

    kind: str
    rows: int
    noise: float  #: the data's noise standard deviation
    #: RMS of measured − the file's prediction (a torque sensor's offset and friction band are
    #: fitted aside: sescid's fits estimate them too, they are not the file's)
    prediction: float
    cv: float  #: RMS of measured − held-out prediction of a MAP fit with the file as prior


@dataclass(frozen=True)
class BodyChange:
    """A change the data ask of a candidate (data − file), beyond its noise."""

    bodies: tuple[str, ...]
    change: float  #: kg, the mass change
    std: float  #: kg
    z: float  #: significance of the body's change (mass and first moment), two-sided z
    first_moment: tuple[float, float, float]  #: kg·m, body frame (nan for every body)
    first_moment_std: tuple[float, float, float]
    com_shift: float  #: m, how far the body's CoM moves (nan when not defined)
    share: float  #: the change as a share of the file's mass of those bodies
    #: bodies whose change would explain the data as well (the data cannot tell them apart)
    alternatives: tuple[str, ...] = ()

    def text(self) -> str:
        """One line in plain words."""
        alt = self.alternatives
        if not alt:
            return self._text()
        more = " …" if len(alt) > 3 else ""
        other = "other body" if len(alt) == 1 else "other bodies"
        return self._text() + f" (or {len(alt)} {other} as well: {', '.join(alt[:3])}{more})"

    def _text(self) -> str:
        who = "every body" if self.bodies == (ALL_BODIES,) else self.bodies[0]
        more = "more" if self.change > 0 else "less"
        mass_seen = abs(self.change) >= 2 * self.std and abs(self.change) > 0
        if self.bodies == (ALL_BODIES,):
            return (
                f"{who} carries {abs(self.share) * 100:.1f} % {more} mass than this file says "
                f"({abs(self.change):.3f} ± {self.std:.3f} kg in all, z {self.z:.1f})"
            )
        shift = (
            ""
            if not math.isfinite(self.com_shift)
            else f"its CoM {self.com_shift * 1e3:.1f} mm off"
        )
        if mass_seen:
            out = f"{who} carries {abs(self.change):.3f} ± {self.std:.3f} kg {more}"
            out += " than this file says"
            return out + (f", {shift}" if shift else "") + f" (z {self.z:.1f})"
        return (
            f"{who}: {shift or 'its first moment differs'}, mass as the file says (z {self.z:.1f})"
        )

    def to_json(self) -> dict:
        """The JSON entry: bodies, change, std, z and the first-moment details."""
        return {
            "bodies": list(self.bodies),
            "change": self.change,
            "std": self.std,
            "z": self.z,
            "first_moment": _finite_list(self.first_moment),
            "first_moment_std": _finite_list(self.first_moment_std),
            "com_shift_mm": None if not math.isfinite(self.com_shift) else self.com_shift * 1e3,
            "alternatives": list(self.alternatives),
            "text": self.text(),
        }


def _finite_list(v) -> list[float | None]:
    return [None if not math.isfinite(x) else float(x) for x in v]


def none_if_nan(x: float) -> float | None:
    """JSON's null for a number that is not finite (not determined)."""
    return None if not math.isfinite(x) else float(x)


@dataclass(frozen=True)
class CandidateAudit:
    """One candidate file's audit."""

    model: str  #: the path (or name) as given
    total_mass: float  #: kg, the file's
    mass_gap: float  #: kg, weighed − file (nan without a weighed mass)
    errors: tuple[KindError, ...]
    score: float  #: mean squared normalised misfit (1: within the noise)
    z_overall: float  #: significance of everything the data see against this file
    rank: int  #: 1 = best
    rejected: tuple[BodyChange, ...]
    checks: tuple[Check, ...]

    def error(self, kind: str) -> KindError | None:
        """The record of one kind, None when the data have none."""
        return next((e for e in self.errors if e.kind == kind), None)

    def to_json(self) -> dict:
        """The candidate's JSON object (``audit`` docs)."""
        pred, cv, noise = {}, {}, {}
        for e in self.errors:
            suffix, f, _ = AUDIT_UNITS[e.kind]
            pred[f"{e.kind}_{suffix}"] = none_if_nan(e.prediction * f)
            cv[f"{e.kind}_{suffix}"] = none_if_nan(e.cv * f)
            noise[f"{e.kind}_{suffix}"] = none_if_nan(e.noise * f)
        return {
            "model": self.model,
            "rank": self.rank,
            "total_mass": self.total_mass,
            "mass_gap": none_if_nan(self.mass_gap),
            "prediction_error": pred,
            "cv_error": cv,
            "noise": noise,
            "score": self.score,
            "z_overall": self.z_overall,
            "rejected": [r.to_json() for r in self.rejected],
            "checks": [c.to_json() for c in self.checks],
        }


@dataclass(frozen=True)
class AuditResult:
    """``audit``'s answer: every candidate (in the order given) and the verdict."""

    candidates: tuple[CandidateAudit, ...]
    weighed_mass: float  #: kg (nan: not given)
    n_poses: int
    level: float  #: the z a change must reach to be named
    folds: int

    @property
    def ranked(self) -> list[CandidateAudit]:
        """The candidates best first."""
        return sorted(self.candidates, key=lambda c: c.rank)

    @property
    def best(self) -> CandidateAudit:
        """The rank-1 candidate."""
        return self.ranked[0]

    def verdict(self) -> str:
        """The verdict in plain words (a few lines)."""
        best = self.best
        ok = not best.rejected
        lines = [
            f"best: {best.model} "
            + (
                "— the data agree with it within their noise"
                if ok
                else "— closest to the data, but the data still reject part of it"
            )
        ]
        for c in self.ranked:
            if c.rejected:
                lines.append(
                    f"{c.model}: the data reject it: " + "; ".join(r.text() for r in c.rejected)
                )
            if c.checks:
                lines.append(f"{c.model}: {len(c.checks)} model check(s) fail")
        return "\n".join(lines)

    def text(self) -> str:
        """The ranking table and the verdict, for the terminal."""
        kinds = [e.kind for e in self.candidates[0].errors]
        head = f"audit of {len(self.candidates)} candidate(s) on {self.n_poses} poses"
        if math.isfinite(self.weighed_mass):
            head += f", weighed {self.weighed_mass:.3f} kg"
        lines = [head]
        for e in self.candidates[0].errors:
            suffix, f, unit = AUDIT_UNITS[e.kind]
            title = AUDIT_TITLES[e.kind]
            lines.append(f"  {title} noise of the data: {e.noise * f:.3g} {unit} ({e.rows} rows)")
        for c in self.ranked:
            parts = [f"#{c.rank} {c.model}: {c.total_mass:.3f} kg"]
            if math.isfinite(c.mass_gap):
                parts.append(f"gap {c.mass_gap:+.3f} kg")
            for k in kinds:
                e = c.error(k)
                assert e is not None
                _, f, unit = AUDIT_UNITS[k]
                cv = f" (cv {e.cv * f:.3g})" if math.isfinite(e.cv) else ""
                parts.append(f"{AUDIT_TITLES[k]} {e.prediction * f:.3g} {unit}{cv}")
            parts.append(f"score {c.score:.2f}")
            lines.append("  " + ", ".join(parts))
            for r in c.rejected:
                lines.append(f"      rejected: {r.text()}")
            for ch in c.checks:
                lines.append(f"      check: {ch.body}: {ch.problem}")
        return "\n".join(lines + ["verdict: " + self.verdict().replace("\n", "\n  ")])

    def to_json(self) -> dict:
        """The whole audit as JSON (``--json``)."""
        return {
            "format": "sescid-audit",
            "weighed_mass": none_if_nan(self.weighed_mass),
            "n_poses": self.n_poses,
            "z_level": self.level,
            "folds": self.folds,
            "best": self.best.model,
            "verdict": self.verdict(),
            "candidates": [c.to_json() for c in self.ranked],
        }


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
    return [m.checked(robot if m.support is None else robot.stance(m.support)) for m in out]


# --- the errors after a fit, cross-validated ------------------------------------------------
def _fold_ids(n: int, folds: int, seed: int) -> np.ndarray:
    return np.random.default_rng(seed).permutation(n) % folds


def _held_out(fit, m: Measurements) -> dict[str, np.ndarray]:
    """Residuals per kind of a fit on held-out data ``m``."""
    fs = for_support(fit, m.support) if m.support is not None else fit
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
            return {k: math.nan for k in ("cop", "tau", "balance")}
        for m in test:
            if m.n:
                for k, v in _held_out(fit, m).items():
                    res.setdefault(k, []).append(v)
    return {k: float(np.sqrt(np.mean(np.concatenate(v) ** 2))) for k, v in res.items()}


def _orth(a: np.ndarray) -> np.ndarray:
    """Orthonormal basis of a's column space (an empty one for no columns)."""
    if a.shape[1] == 0:
        return np.zeros((a.shape[0], 0))
    u, s, _ = np.linalg.svd(a, full_matrices=False)
    return u[:, s > 1e-9 * max(float(s[0]), 1e-300)]


# --- the audit --------------------------------------------------------------------------------
def audit_one(
    robot: Robot,
    label: str,
    data: list[Measurements],
    weighed: float | None,
    mass_std: float,
    level: float,
    folds: int,
    noise: dict[str, float] | None = None,
) -> CandidateAudit:
    """One candidate's audit (rank 0: set by ``audit``)."""
    theta = robot.body_parameters()
    rows: list[KindRows] = kind_rows(robot, data, theta, noise)
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
    qn = _orth(nuis)

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


def body_change(x: Named, masses: np.ndarray, robot: Robot) -> BodyChange:
    """A named change as the record audit and compare report (its share of the file's mass)."""
    if x.bodies == (ALL_BODIES,):
        base = float(masses.sum())
    else:
        base = float(masses[robot.body_names.index(x.bodies[0])])
    share = x.mass / base if base > 0 else math.nan
    fm, fs = x.moment, x.moment_std
    return BodyChange(
        x.bodies, x.mass, x.mass_std, x.z, (float(fm[0]), float(fm[1]), float(fm[2])),
        (float(fs[0]), float(fs[1]), float(fs[2])), x.com_shift, share, x.alternatives,
    )  # fmt: skip


def audit(
    data: Any,
    models: Sequence[Any],
    *,
    support: str | None = None,
    line: Any = None,
    total_mass: float | None = None,
    mass_std: float | None = None,
    level: float = DEFAULT_Z,
    folds: int = DEFAULT_FOLDS,
    noise: dict[str, float] | None = None,
) -> AuditResult:
    """Score candidate model files of one robot against measurements (module docstring).

    ``data``: a data file (``FILE@FRAME`` for a stance), a ``Measurements`` or a list of
    either (pooled). ``models``: model files (URDF/MJCF paths, embedded names) or ``Robot``s,
    loaded at ``support`` (on the support ``line`` for balance data, ``load_robot``).
    ``total_mass``: the weighed mass [kg], with its standard deviation ``mass_std`` [kg]
    (default ``WEIGH_REL_STD`` of it). ``level``: the z a change must reach
    to be named. ``folds``: of the cross-validated error after a fit (0: skip it). ``noise``:
    per-kind noise standard deviations (SI) instead of the data's own estimate."""
    if len(models) < 1:
        raise OptionError("models", "give at least one candidate model file")
    if not (isinstance(folds, int) and (folds == 0 or folds >= 2)):
        raise OptionError("folds", f"folds must be 0 (no cross-validation) or ≥ 2, got {folds}")
    if total_mass is not None and not (math.isfinite(total_mass) and total_mass > 0):
        raise OptionError("total_mass", f"the weighed mass must be > 0 kg, got {total_mass}")
    labels = [_label(m) for m in models]
    robots = [_load(m, support, line) for m in models]
    _same_robot(robots, labels)
    known = set().union(*(set(r.joint_names) for r in robots))
    std = mass_std if mass_std is not None else (WEIGH_REL_STD * total_mass if total_mass else 1.0)
    out = []
    n_poses = 0
    for robot, label in zip(robots, labels, strict=True):
        sets = _read(data, robot, label, known)
        n_poses = sum(m.n for m in sets)
        out.append(audit_one(robot, label, sets, total_mass, std, level, folds, noise))
    order = sorted(range(len(out)), key=lambda i: (out[i].score, i))
    ranked = list(out)
    for rank, i in enumerate(order, 1):
        c = out[i]
        ranked[i] = CandidateAudit(
            c.model, c.total_mass, c.mass_gap, c.errors, c.score, c.z_overall, rank,
            c.rejected, c.checks,
        )  # fmt: skip
    return AuditResult(
        tuple(ranked), math.nan if total_mass is None else float(total_mass), n_poses, level, folds
    )
