"""Checks at the data boundary that turn garbage into an error or a stored warning.

``outside_limits`` finds poses outside the model's joint limits; ``fit_warnings`` says when the
data do not excite the identifiable subspace (rank and condition of the information matrix),
when σ̂ = 0 (a constant or noise-free CoP), and ``check_total_mass`` refuses a weighed mass
implausible against the model's (grams or pounds for kilograms): the one rule for every mass a
user gives (identify, the consistent masses, the pad calibration, the guided session).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from sescid.base.text import listed
from sescid.errors import OptionError
from sescid.estimation.data.anchor import com_distance
from sescid.estimation.result.fit import Fit
from sescid.estimation.result.identifiability import structural_count
from sescid.robot import Robot
from sescid.stance import held_trunk

#: a weighed total mass must lie within this factor range of the model's (outside: a unit slip
#: — grams, pounds — or another robot)
TOTAL_MASS_RANGE = (0.5, 2.0)
#: a known CoM height must lie within this factor range of the model's (outside: a unit slip —
#: inches, centimetres — or another robot)
COM_HEIGHT_RANGE = (0.5, 2.0)
#: information matrix worse conditioned than this (on the excited combinations) is flagged
CONDITION_WARN = 1e8
#: σ̂ below this (m, or a weighted scale) is an exact fit: constant CoP or noise-free data
EXACT_FIT = 1e-9
#: fewer residual degrees of freedom than this share of the rows is flagged (a rough σ̂)
FEW_DOF = 0.1
#: angles beyond a limit by less than this are inside (servo play, read-back noise), rad
LIMIT_SLACK = math.radians(2.0)
#: family-wise false-alarm rate of the negative-friction-band warning: a band is called
#: significantly negative when value/std < −z with z the Bonferroni level over the joints
#: (``friction_threshold``; Student's t with the joint's residual degrees of freedom when its
#: noise was estimated from them), so that over many fits of sensors of the right sign
#: (bands ≥ 0) at most this share warn about any joint
FRICTION_ALARM_RATE = 0.01


@dataclass(frozen=True)
class LimitViolation:
    """Poses outside the model's joint limits: how many, and the first one."""

    n_poses: int  #: poses with at least one joint outside its limits
    row: int  #: first such pose (0-based)
    joint: str
    value: float  #: rad
    lower: float  #: rad
    upper: float  #: rad

    def message(self, total: int, at: str | None = None) -> str:
        """One line naming the first violation, in degrees; ``at`` names its place in a file
        ("row 7, column 'r_knee'"; default: pose index and joint)."""
        where = at or f"pose {self.row}, {self.joint}"
        return (
            f"{self.n_poses} of {total} poses are outside the model's joint limits (first: "
            f"{where} = {math.degrees(self.value):.1f}° not in "
            f"[{math.degrees(self.lower):.1f}, {math.degrees(self.upper):.1f}]°)"
        )


#: the start of the warning of a CoP fitted at a trunk (the CLI refuses such a fit)
COP_ON_TRUNK = "a CoP fitted at a trunk"


def outside_limits(robot: Robot, q: ArrayLike | list[np.ndarray]) -> LimitViolation | None:
    """The poses of q (n, nq) [rad] — or of a list of such chunks, counted as one sequence —
    outside ``robot.joint_limits``, or None."""
    chunks = q if isinstance(q, list) else [q]
    lim = np.asarray(robot.joint_limits, dtype=float)
    first: LimitViolation | None = None
    n_bad, start = 0, 0
    for chunk in chunks:
        qq = np.asarray(chunk, dtype=float)
        bad = (qq < lim[:, 0] - LIMIT_SLACK) | (qq > lim[:, 1] + LIMIT_SLACK)
        rows = np.flatnonzero(bad.any(axis=1))
        if rows.size and first is None:
            i = int(rows[0])
            j = int(np.flatnonzero(bad[i])[0])
            first = LimitViolation(
                0,
                start + i,
                robot.joint_names[j],
                float(qq[i, j]),
                float(lim[j, 0]),
                float(lim[j, 1]),
            )
        n_bad += int(rows.size)
        start += len(qq)
    return None if first is None else dataclasses.replace(first, n_poses=n_bad)


def condition(fit: Fit) -> float:
    """Condition number of the information matrix on the combinations the data excite."""
    sv = np.asarray(fit.singular_values, dtype=float)
    if fit.rank == 0 or sv.size == 0 or sv[fit.rank - 1] <= 0:
        return math.inf
    return float((sv[0] / sv[fit.rank - 1]) ** 2)


def fit_warnings(fit: Fit, structural_rank: int | None = None) -> list[str]:
    """Data-quality warnings of a fit: an unexcited identifiable subspace, an ill-conditioned
    information matrix, σ̂ = 0. ``structural_rank``: rank of the robot's x/y regressor over all
    poses (default ``robot.reduction``'s)."""
    out = []
    p = (
        structural_rank
        if structural_rank is not None
        else structural_count(fit.robot, [k.kind for k in fit.kinds])
    )
    cond = condition(fit)
    if fit.rank < p:
        out.append(
            f"the data excite {fit.rank} of the {p} identifiable combinations (condition of the "
            f"information matrix {cond:.3g}): predictions along the other {p - fit.rank} are "
            "not determined (their intervals are reported as such), use more varied poses"
        )
    elif cond > CONDITION_WARN:
        out.append(
            f"the information matrix is ill-conditioned ({cond:.3g}): some combinations are "
            "barely excited, their intervals are wide"
        )
    if fit.scale is not None and fit.kind("cop") is not None:
        out.append(
            "every measured CoP lies at the support frame's origin (all zero?): a dead or "
            "unplugged foot sensor, or a robot balancing on a point there; fitted as balance "
            "data, whose scale is not in the data"
        )
    if fit.weak:
        names = listed(
            (c.label() for c in fit.weak), sep="; ", where='all in the fit file\'s "weak"'
        )
        whose = "taken from the prior model" if fit.map is None else "decided by the prior"
        out.append(
            f"{len(fit.weak)} combination(s) barely excited by these poses (information below "
            f"10⁻⁷ of the largest), {whose}: {names}; vary the joints that move them"
        )
    from sescid.estimation.result.tilt import TILT_REL_STD_WARN, tilt_direction

    tilt = tilt_direction(fit) if fit.map is None else None
    if tilt is not None and tilt.rel_std > TILT_REL_STD_WARN:
        out.append(
            f"the tilted support determines a CoM-height offset only weakly: "
            f"{tilt.value * 1e3:.1f} ± {tilt.std * 1e3:.1f} mm (prior model "
            f"{tilt.prior * 1e3:.1f} mm); least squares takes it from the data, so CoM heights "
            "are that uncertain: use a MAP fit (method map) with the gravity columns"
        )
    dof = fit.n_rows - fit.rank - sum(e.determined for e in fit.nuisance)
    if dof <= 0 and fit.map is not None:
        out.append(
            f"the data leave no residual degrees of freedom ({fit.n_rows} equations for "
            f"{fit.rank} identifiable combinations): MAP's noise and intervals rest on the prior "
            "(evidence), not on a residual; measure more poses"
        )
    elif dof <= 0:
        out.append(
            "no degrees of freedom are left: σ̂ and every standard error are not determined "
            "(an exact fit was asked for); measure more poses"
        )
    elif dof < FEW_DOF * fit.n_rows:
        out.append(
            f"only {dof} residual degrees of freedom for {fit.n_rows} equations "
            f"({100 * dof / fit.n_rows:.0f} %): the noise estimate and the intervals are rough; "
            "measure more poses"
        )
    if fit.sigma_hat < EXACT_FIT and fit.n_rows > fit.rank:
        what = {k.kind for k in fit.kinds} or {"cop"}
        data = (
            "the CoP is fitted exactly (a constant or all-zero CoP, or noise-free data)"
            if what == {"cop"}
            else "the measurements are fitted exactly (constant or all-zero values, or "
            "noise-free data)"
        )
        out.append(f"σ̂ = 0: {data}; intervals have zero width")
    negative, z = negative_bands(fit)
    if negative:
        shown = ", ".join(
            f"{e.name} {e.value:+.3f} ± {e.std:.3f} ({e.value / e.std:+.1f}σ)" for e in negative[:4]
        )
        out.append(
            f"negative static-friction bands [N·m] ({shown}{' …' if len(negative) > 4 else ''}; "
            f"beyond −{z:.2f}σ, the {FRICTION_ALARM_RATE:.0%} level over the fit's "
            f"{len(_bands(fit))} bands): a band is never below zero — those torque sensors' sign "
            "is reversed, or their approach column is (+1: reached moving up)"
        )
    if held_trunk(fit.robot) and fit.kind("cop") is not None:
        out.append(
            f"{COP_ON_TRUNK}: the support '{fit.robot.support}' is where the robot's mass "
            "splits (held there in a gantry, it loads no foot), yet the data hold a CoP, "
            "measured under a standing foot: load the robot at the sole it stood on (support= / "
            f"--support); this fit is of a robot standing on '{fit.robot.support}'"
        )
    return out


def _bands(fit: Fit) -> list:
    """The fit's determined friction bands (with a standard error)."""
    return [
        e for e in fit.nuisance
        if e.kind == "tau" and e.what == "friction" and e.determined and e.std > 0
    ]  # fmt: skip


def friction_threshold(
    n_bands: int, rate: float = FRICTION_ALARM_RATE, dof: float = math.inf
) -> float:
    """The z that n_bands independent estimates all stay above (−z) with probability
    1 − ``rate`` or more (Bonferroni: the one-sided level rate/n_bands), each standardised by
    a standard error of ``dof`` degrees of freedom (Student's t; inf: a normal)."""
    level = rate / max(n_bands, 1)
    if math.isfinite(dof) and dof > 0:
        from scipy.stats import t

        return float(t.isf(level, dof))
    from statistics import NormalDist

    return -NormalDist().inv_cdf(level)


def negative_bands(fit: Fit) -> tuple[list, float]:
    """The friction bands significantly below zero (value/std < −z, ``friction_threshold``
    over the fit's determined bands, with each joint's residual degrees of freedom when its
    noise was estimated per joint), and the smallest z."""
    bands = _bands(fit)
    dof = {r.joint: r.dof for r in fit.torque_noise if r.by == "estimated"}
    z = {e.name: friction_threshold(len(bands), dof=dof.get(e.name, math.inf)) for e in bands}
    lowest = min(z.values(), default=friction_threshold(len(bands)))
    return [e for e in bands if e.value < -z[e.name] * e.std], lowest


def check_total_mass(robot: Robot, total_mass: float | None, name: str = "total_mass") -> None:
    """OptionError naming ``name`` unless a given total mass [kg] is a positive number within
    ``TOTAL_MASS_RANGE`` × the model's (None: nothing given, nothing to check)."""
    if total_mass is None:
        return
    m = float(total_mass)
    model = robot.total_mass
    if not (math.isfinite(m) and m > 0):
        raise OptionError(name, f"total mass must be a positive number of kg, got {total_mass}")
    lo, hi = TOTAL_MASS_RANGE
    ratio = m / model
    if not lo <= ratio <= hi:
        unit = " (grams? the unit is kg)" if 500 < ratio < 2000 else ""
        unit = unit or (" (pounds? the unit is kg)" if 2.0 < ratio < 2.5 else "")
        raise OptionError(
            name,
            f"{m:g} kg is not this robot's mass: {ratio:.3g} × the model's {model:.4g} kg, "
            f"expected within {lo:g}–{hi:g} ×{unit}",
        )


def check_com_height(
    robot: Robot, height: float | None, r: np.ndarray | None = None, name: str = "com_height"
) -> None:
    """OptionError naming ``name`` unless a known CoM height [m] (the CoM's distance from the
    support at the zero pose, ``anchor.com_distance``) lies within ``COM_HEIGHT_RANGE`` × the
    model's (SESC vectors ``r``, default the robot's); None: nothing given."""
    if height is None:
        return
    h = float(height)
    model = com_distance(robot, robot.sesc_vectors() if r is None else np.asarray(r))
    if not (math.isfinite(h) and h > 0) or model <= 0:
        return  # the option's range says so, or the model has no height to compare with
    lo, hi = COM_HEIGHT_RANGE
    ratio = h / model
    if not lo <= ratio <= hi:
        unit = next(
            (f" ({u}? the unit is m)" for u, f in (("inches", 39.37), ("centimetres", 100.0),
             ("millimetres", 1000.0)) if 0.7 * f <= ratio <= 1.4 * f),
            "",
        )  # fmt: skip
        raise OptionError(
            name,
            f"{h:g} m is not this robot's CoM height: {ratio:.3g} × the model's {model:.3g} m "
            f"(its CoM's distance from the support at the zero pose), expected within "
            f"{lo:g}–{hi:g} ×{unit}",
        )
