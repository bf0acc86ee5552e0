"""From the solver's variables to masses and CoMs, the consistent model, and the Fit record."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from sescid.errors import SescidError
from sescid.estimation.result.fit import Fit
from sescid.estimation.result.records import BodyInertials
from sescid.estimation.solvers.consistent.boxes import mirror_plane
from sescid.estimation.solvers.consistent.qp import H_UNIT
from sescid.robot import Robot

_ACTIVE_M = 1e-7  #: a CoM within this of a box face counts as on it, m
_ACTIVE_KG = 1e-7  #: a mass within this (× M) of the floor counts as on it


def model_coms(robot: Robot) -> np.ndarray:
    """(N, 3) CAD CoMs of the bodies in their frames, m."""
    return np.array([b.com for b in robot.model.bodies])


def tidy(x, big_m, floor, box_list, com_cad, pairs, robot: Robot):
    """Solver output → masses (kg) and CoMs (m, body frames) meeting the constraints exactly."""
    nb = len(box_list)
    frame = np.array([b.frame_only for b in robot.model.bodies], dtype=bool)
    masses = np.where(frame, 0.0, np.maximum(x[:nb] * big_m, floor))
    h = x[nb:].reshape(nb, 3) * big_m * H_UNIT
    lo = np.array([b.lo for b in box_list])
    hi = np.array([b.hi for b in box_list])
    tiny = masses <= 1e-12 * big_m
    coms = np.where(tiny[:, None], com_cad, h / np.where(tiny, 1.0, masses)[:, None])
    if pairs:  # make mirrored pairs exact mirror images (the solver meets them to ~1e-10)
        normal, offset = mirror_plane(robot, pairs)
        rot, org = robot.forward(np.zeros((1, robot.nq)))
        rot, org = rot[0], org[0]
        for i, j in pairs:
            m = 0.5 * (masses[i] + masses[j])
            pi = org[i] + rot[i] @ coms[i]
            pj = org[j] + rot[j] @ coms[j]
            pj_m = pj - 2 * (normal @ pj - offset) * normal
            pi_new = 0.5 * (pi + pj_m)
            pj_new = pi_new - 2 * (normal @ pi_new - offset) * normal
            masses[i] = masses[j] = m
            coms[i] = rot[i].T @ (pi_new - org[i])
            coms[j] = rot[j].T @ (pj_new - org[j])
    coms = np.clip(coms, lo, hi)
    masses *= big_m / masses.sum()
    return masses, coms


def consistent_model(robot: Robot, masses: np.ndarray, coms: np.ndarray):
    """The robot's RobotModel with new body masses (N,) kg and CoMs (N, 3) m (body frames)."""
    bodies = [
        dataclasses.replace(b, mass=float(m), com=np.asarray(c, dtype=float).copy())
        for b, m, c in zip(robot.model.bodies, masses, coms, strict=True)
    ]
    return dataclasses.replace(robot.model, bodies=bodies)


def make_fit(src: Fit, r, masses, coms, layout: tuple, d_rss: float, info: dict) -> Fit:
    """The consistent Fit: r (N, 3) from the masses (N,) kg and CoMs (N, 3) m, the record of the
    constraints (``layout`` = (boxes, mirrored pairs)) and which are active, the residual's
    increase ``d_rss`` m² over ``src`` and the solver's ``info``."""
    box_list, pairs = layout
    robot = src.robot
    names = robot.body_names
    model = robot.model
    big_m = info["total_mass"]
    active = []
    com_link = np.empty((len(names), 3))
    for i, name in enumerate(names):
        x = model.link_frames[model.bodies[i].name][1]
        com_link[i] = x[:3, :3].T @ (coms[i] - x[:3, 3])
        box = box_list[i]
        faces = [
            f"{'xyz'[a]}{side}"
            for a in range(3)
            for side, dist in (("-", coms[i][a] - box.lo[a]), ("+", box.hi[a] - coms[i][a]))
            if dist <= _ACTIVE_M and masses[i] > _ACTIVE_KG * big_m
        ]
        if not model.bodies[i].frame_only and masses[i] - info["mass_floor"] <= _ACTIVE_KG * big_m:
            active.append(f"{name}: mass at floor")
        active += [f"{name}: CoM on box face {f}" for f in faces]
    rms = math.sqrt(src.rms**2 + d_rss / max(src.n_rows, 1)) if math.isfinite(src.rms) else src.rms
    dof = src.n_rows - src.rank
    sigma_hat = math.sqrt(rms**2 * src.n_rows / dof) if dof > 0 and math.isfinite(rms) else math.nan
    base = tuple(
        dataclasses.replace(
            c, value=float(sum(coef * r[names.index(b), "xyz".index(a)] for b, a, coef in c.terms))
        )
        for c in src.base
    )
    inertials = BodyInertials(
        masses=np.asarray(masses, dtype=float),
        coms=np.asarray(coms, dtype=float),
        coms_link=com_link,
        box_lo=np.array([b.lo for b in box_list]),
        box_hi=np.array([b.hi for b in box_list]),
        box_source=[b.source for b in box_list],
        active_constraints=active,
        mirror_pairs=[[names[i], names[j]] for i, j in pairs],
        source_method=src.method_label,
        source_rms=src.rms,
        cop_rss_increase=d_rss,
        cad_masses=robot.masses,
        grown_boxes=[names[i] for i, b in enumerate(box_list) if b.grown],
        **info,
    )
    bodies = src.bodies
    if bodies is not None:  # pooled stances: the body parameters are these masses' now
        from sescid.estimation.sums.pooled import PARAM_UNIT

        m = np.asarray(masses, dtype=float)
        first = (m[:, None] * np.asarray(coms, dtype=float)).reshape(-1)
        x = np.concatenate([m, first / PARAM_UNIT]) / bodies.total_mass
        bodies = dataclasses.replace(bodies, x=x)
    return dataclasses.replace(
        src,
        r=r,
        method="consistent",
        base=base,
        inertials=inertials,
        rms=rms,
        sigma_hat=sigma_hat,
        mae=math.nan,
        bodies=bodies,
    )


def fit_inertials(fit: Fit) -> tuple[np.ndarray, np.ndarray]:
    """Body masses (N,) kg and CoMs (N, 3) m (body frames) held by a consistent fit."""
    b = fit.inertials
    if b is None:
        raise SescidError(
            f"this {fit.method} fit has no body masses; run the consistent step first "
            "(sescid.consistent_from_fit)"
        )
    masses, coms = np.asarray(b.masses, dtype=float), np.asarray(b.coms, dtype=float)
    if coms.shape != (len(fit.robot.body_names), 3) or masses.shape != (coms.shape[0],):
        raise SescidError("the fit's body masses/CoMs do not match the robot's bodies")
    if not (np.all(np.isfinite(masses)) and np.all(masses >= 0) and np.all(np.isfinite(coms))):
        raise SescidError("the fit's body masses/CoMs must be finite, masses ≥ 0 kg")
    return masses, coms
