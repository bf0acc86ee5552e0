"""How close a fit comes to the virtual experiment's truth (``sescid experiment --truth``).

The truth file holds the "real" robot's SESC vectors, the poses it actually took (joint play
included) and its true CoPs. ``compare_truth`` gives the RMS CoP error of the identified and of
the manufacturer model at those actual poses, and on fresh poses near them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np

from sescid.bench.truth import Truth
from sescid.errors import DataError
from sescid.estimation import Fit, for_support

#: what a truth comparison compares: the CoP (m) or a line-balanced robot's tilt (rad)
TruthQuantity = Literal["CoP", "balance tilt"]


@dataclass(frozen=True)
class TruthComparison:
    """RMS errors against the true robot, per model: of the CoP (m), or for a robot balancing
    on a line (``quantity`` "balance tilt") of the tilt that balances it (rad)."""

    n_poses: int
    rms_identified: float  #: at the poses actually taken
    rms_manufacturer: float
    n_fresh: int
    within_deg: float
    fresh_identified: float  #: fresh poses uniform within ±within_deg of the actual ones
    fresh_manufacturer: float
    true_mass_kg: float
    model_mass_kg: float
    quantity: TruthQuantity = "CoP"  #: "CoP" (m) or "balance tilt" (rad)
    #: line mount: the CoM's distance from the line at the zero pose, m (true, identified)
    com_distance: tuple[float, float] | None = None


def _rms(d: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.asarray(d) ** 2)))


#: fresh poses and their spread around the actual ones [degrees]
FRESH_POSES = 2000
FRESH_WITHIN_DEG = 5.0


def compare_truth(
    fit: Fit,
    truth_path: str | Path,
    n_fresh: int = FRESH_POSES,
    within_deg: float = FRESH_WITHIN_DEG,
    seed: int = 0,
    fit_path: str | Path | None = None,
) -> TruthComparison:
    """Compare ``fit`` with the truth file at the actual poses and ``n_fresh`` fresh poses;
    ``fit_path`` names the fit in the error of a fit and truth of different robots."""
    t = Truth.load(truth_path)
    if t.support != fit.robot.support and fit.bodies is not None:  # a pooled fit, seen there
        fit = for_support(fit, t.support)
    robot = fit.robot
    if list(t.joint_names) != robot.joint_names or list(t.body_names) != robot.body_names:
        raise DataError(
            f"{fit_path or 'the fit'}: a fit of {robot.name} on '{robot.support}' "
            f"({robot.source}), but {truth_path} is the truth of {t.robot} on '{t.support}': "
            "compare a fit with the truth of the run it was fitted to"
        )
    if t.mount == "line":
        return _compare_line(fit, t, n_fresh, within_deg, seed)
    if t.cop_true is None:
        raise DataError(f"{truth_path}: a {t.mount} run has no CoP truth to compare with")
    r_true, true_mass, model_mass = t.r_true, t.true_mass, t.model_mass
    q, cop = t.q_actual, t.cop_true
    if q.shape != (len(cop), robot.nq) or not np.all(np.isfinite(q)):
        raise DataError(f"{truth_path}: q_actual and cop_true do not match")
    fresh = _fresh(q, n_fresh, within_deg, seed)
    cop_fresh = robot.cop(fresh, r_true)
    return TruthComparison(
        n_poses=len(q),
        rms_identified=_rms(fit.predict_cop(q) - cop),
        rms_manufacturer=_rms(robot.cop(q, fit.r_prior) - cop),
        n_fresh=n_fresh,
        within_deg=within_deg,
        fresh_identified=_rms(fit.predict_cop(fresh) - cop_fresh),
        fresh_manufacturer=_rms(robot.cop(fresh, fit.r_prior) - cop_fresh),
        true_mass_kg=true_mass,
        model_mass_kg=model_mass,
    )


def _fresh(q: np.ndarray, n_fresh: int, within_deg: float, seed: int) -> np.ndarray:
    """(n_fresh, nq) poses uniform within ±within_deg of poses drawn from ``q`` [rad]."""
    if not (n_fresh >= 1 and 0 < within_deg <= 180):
        raise DataError("fresh poses: need n ≥ 1 and 0 < within_deg ≤ 180")
    rng = np.random.default_rng(seed)
    base = q[rng.integers(0, len(q), n_fresh)]
    return base + rng.uniform(-1, 1, base.shape) * math.radians(within_deg)


def _compare_line(fit: Fit, t: Truth, n_fresh: int, within_deg: float, seed: int):
    """A robot balancing on its line: the tilt that balances it, per model (rad)."""
    from sescid.estimation.data.anchor import com_distance
    from sescid.sesc import balance_tilt

    robot = fit.robot
    if robot.line is None:
        raise DataError("the truth is of a robot balancing on a line: the fit's support is not")
    q = t.q_actual
    fresh = _fresh(q, n_fresh, within_deg, seed)

    def tilt(r, poses):
        assert robot.line is not None
        return balance_tilt(robot.tree, robot.line, poses, r)[0]

    true_q, true_fresh = tilt(t.r_true, q), tilt(t.r_true, fresh)
    return TruthComparison(
        n_poses=len(q),
        rms_identified=_rms(tilt(fit.r, q) - true_q),
        rms_manufacturer=_rms(tilt(fit.r_prior, q) - true_q),
        n_fresh=n_fresh,
        within_deg=within_deg,
        fresh_identified=_rms(tilt(fit.r, fresh) - true_fresh),
        fresh_manufacturer=_rms(tilt(fit.r_prior, fresh) - true_fresh),
        true_mass_kg=t.true_mass,
        model_mass_kg=t.model_mass,
        quantity="balance tilt",
        com_distance=(com_distance(robot, t.r_true), com_distance(robot, fit.r)),
    )
