"""Torque-sensor gains: a reading (1 + γ_j)(τ_j + o_j + s f_j) + e for a per-joint gain γ_j.

A gain makes the model bilinear (γ_j times the torque of r), so it is solved by Gauss–Newton:
linearised at the current estimate (θ_k, γ_k),

    (τ_m + γ_k p_k) / (1 + γ_k) = p(θ) + γ p_k / (1 + γ_k),      p(θ) = Φ_τ x + o + s f,

which is the torque kind's linear system with each joint's readings rescaled and one more
column per joint (its current predicted reading), solved with everything else in the system
(CoP rows included); a few iterations reach the joint optimum. Each gain has a Gaussian prior
N(0, s²) (``gain_prior``). The torques measure M·r times a gain: a gain common to every joint is
a different scale of r, which no torque can tell apart — only the gains' ratios are determined
by the data, their common part by the prior (said in each gain's record).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from sescid.estimation.data.measurements import Measurements
from sescid.estimation.result.fit import Fit
from sescid.estimation.solvers.least_squares import torque_readings
from sescid.estimation.sums.normal_equations import NormalEquations
from sescid.estimation.sums.pooled import accumulate_sources
from sescid.estimation.sums.system import KindSums, Nuisance, RowOptions, System, torque_nuisance
from sescid.kinds import TORQUE
from sescid.robot import Robot

#: Gauss–Newton stops when no gain moved by more than this
GAIN_TOL = 1e-10
GAIN_MAX_ITER = 30


def _dense_torque_sums(robot: Robot, data, gains, base, options, nuisance, sigma) -> KindSums:
    """The linearised torque rows of every source as normal equations over θ = [vec(r);
    ``nuisance``] (the gain columns last), with the gains' prior as one pseudo-row each
    (γ_j = 0 ± s, in the rows' noise ``sigma``)."""
    n_x = 3 * len(robot.body_names)
    index = {n: k for k, n in enumerate(nuisance)}
    size = n_x + len(nuisance)
    ne = NormalEquations.empty(size)
    mass = torque_mass(robot, options)
    for m, p_k in zip(data, base, strict=True):
        if m.tau is None:
            continue
        phi = robot.torque_regressor(m.q, m.tau_joints, m.gravity, options.gravity_accel) * mass
        for j, joint in enumerate(m.tau_joints):
            g = gains[joint]
            cols = np.zeros((m.n, size))
            cols[:, :n_x] = phi[:, j]
            cols[:, n_x + index[Nuisance(TORQUE, "offset", joint, "N·m", _scale(nuisance))]] = 1.0
            if m.approach is not None:
                key = Nuisance(TORQUE, "friction", joint, "N·m", _scale(nuisance))
                cols[:, n_x + index[key]] = m.approach
            cols[:, n_x + index[_gain(joint, nuisance)]] = p_k[:, j] / (1.0 + g)
            y = (m.tau[:, j] + g * p_k[:, j]) / (1.0 + g)
            w = None
            if options.weighted and m.tau_se is not None:
                w = ((1.0 + g) / m.tau_se[:, j]) ** 2
            ne.add(cols.T, y, w)
        ne.n_poses += m.n
    for n in nuisance:
        if n.what == "gain":
            k = n_x + index[n]
            ne.ata[k, k] += (sigma / n.prior_scale) ** 2
            ne.n_rows += 1
    return KindSums(TORQUE, ne, options.weighted)


def _scale(nuisance) -> float:
    return next(n.prior_scale for n in nuisance if n.kind == TORQUE and n.what != "gain")


def _gain(joint: str, nuisance) -> Nuisance:
    return next(n for n in nuisance if n.what == "gain" and n.name == joint)


def gain_system(
    robot: Robot, data: list[Measurements], gains, base, options, sigma, rows: RowOptions
) -> System:
    """The pooled system linearised at the current gains (module docstring): the CoP rows as
    accumulated (``rows``: the method's), the torque rows dense with one gain column per joint."""
    joints = [j for j in robot.joint_names if j in gains]
    cop = [dataclasses.replace(m.without(TORQUE)) for m in data if m.cop is not None]
    first = next(m for m in data if m.tau is not None)
    tau_nuis = torque_nuisance(first)
    gain_nuis = tuple(Nuisance(TORQUE, "gain", j, "1", options.gain_prior) for j in joints)
    nuisance = tau_nuis + gain_nuis
    torque = _dense_torque_sums(robot, data, gains, base, options, nuisance, sigma)
    n_x = 3 * len(robot.body_names)
    given = options.total_mass is not None
    system = System(
        n_x, nuisance, {TORQUE: torque}, torque_mass(robot, options), given, torque.ne.n_poses,
        gravity_accel=options.gravity_accel,
    )  # fmt: skip
    if cop:
        part = accumulate_sources(robot, [[m] for m in cop], rows)
        system = part.merged(dataclasses.replace(system, n_poses=0))
        system.n_poses = sum(m.n for m in data)
    return system


def torque_mass(robot: Robot, options) -> float:
    """The total mass that scales the torque rows, kg."""
    return robot.total_mass if options.total_mass is None else float(options.total_mass)


def with_gains(
    solve, robot: Robot, data: list[Measurements], options, start: Fit, rows: RowOptions
) -> Fit:
    """Gauss–Newton over (θ, γ) from a fit without gains (``start``); ``solve(system)`` fits a
    system (least squares or MAP), whose CoP rows are made as ``rows`` says. The result's
    nuisance holds the gains."""
    joints = sorted({j for m in data for j in m.tau_joints})
    gains = dict.fromkeys(joints, 0.0)
    fit = start
    for _ in range(GAIN_MAX_ITER):
        base = [torque_readings(fit, m) if m.tau is not None else None for m in data]
        system = gain_system(robot, data, gains, base, options, _row_noise(fit), rows)
        fit = solve(system)
        new = {e.name: e.value for e in fit.nuisance if e.what == "gain"}
        moved = max(abs(new[j] - gains[j]) for j in joints)
        gains = new
        if not math.isfinite(moved) or moved < GAIN_TOL:
            break
    return _annotate(fit)


def _row_noise(fit: Fit) -> float:
    """The torque rows' noise in their own units: σ_τ of the current fit for one unweighted
    torque kind (rows in N·m), 1 when the rows are scaled by their noise (weighted, pooled)."""
    kind = fit.kind(TORQUE)
    if kind is None or len(fit.kinds) > 1 or kind.weighted:
        return 1.0
    return kind.sigma if math.isfinite(kind.sigma) and kind.sigma > 0 else 1.0


def _annotate(fit: Fit) -> Fit:
    """Each gain's record says what determined it: its ratio to the others, the prior the rest."""
    out = []
    for e in fit.nuisance:
        if e.what == "gain":
            e = dataclasses.replace(
                e,
                reason="the ratios of the gains come from the data, their common part from the "
                "prior (a common gain is a different scale of M·r, which no torque sees)",
            )
        out.append(e)
    return dataclasses.replace(fit, nuisance=tuple(out))
