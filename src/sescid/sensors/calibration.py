"""Foot-pad gains and offsets estimated together with the mass model, from several sessions.

Sensor model. Each pad k of a foot reads ``y_k = F_k / g_k + o_k`` (N): a gain ``g_k`` and an
offset ``o_k`` (the offset of a session: FSR offsets drift from day to day, so every session
has its own; the gains belong to a sensor set, shared by the sessions that use it). A pad's
force is then ``F_k = g_k y_k − β_k`` with ``β_k = g_k o_k``: linear in ``(g, β)``.

Statics. Four pads under a foot and three equations of statics: the split of the load over the
pads is statically indeterminate (it depends on the foot's stiffness), so the model uses only
what statics determines per pose — the total normal force and the two moments about the ground
frame's axes (equivalently the CoP) of all loaded pads together:

    Σ_k (g_k y_k − β_k)                = W (−g_z)
    Σ_k (g_k y_k − β_k) p_k / W        = T (R_Gᵀ (d + Φ(q) vec(r) − o_G))

with ``W`` the robot's weight (its weighed mass × g: it fixes the scale of the gains), ``p_k``
the pad's position in the ground frame G (the sole frame of a loaded foot; in double support
both soles are on the ground plane), ``T = [I₂, −g_xy/g_z]`` the projection along gravity ``g``
(unit, in G; ``(0, 0, −1)`` for a level sole) and ``Φ`` the full 3-row regressor of the robot
rooted at its support frame. Everything is linear in ``θ = (vec(r), g, β)``: one least-squares
problem, solved with Gaussian priors (the CAD SESC vectors with scale τ chosen by the evidence
as in ``map``; gains ``N(1, gain_prior²)``; offsets ``N(0, offset_prior²)``), so directions the
data cannot see come from the priors and are named.

What the pads cannot tell (``SensorDirection.kind``):

- ``unloaded-foot``: a foot that never carries load in any session of a sensor set leaves its
  gains unseen (and a session's offsets of a foot it never loads);
- ``offset-twist``: per session and foot, the offset combination orthogonal to (1, p_x, p_y)
  over the 4 pads changes neither the total force nor the moments: statics never sees it;
- ``support-confounded``: with one foot only, the offsets' moments add a constant CoP shift in
  that foot's frame, exactly as the SESC components of the body fixed to that sole do — poses on
  the other foot separate them;
- ``scale``: without a weighed mass the weight is the model's, an assumption, not a measurement;
- ``not-excited``: the gains are told apart only because the pads' load pattern varies beyond
  what the CoP fixes (the statically indeterminate part of the split changes from pose to pose,
  as a real foot's compliance makes it); a split that is linear in the CoP (a rigid plate on
  equal springs) leaves one gain direction per foot unseen.

Noise. Each session has its own noise level on the force rows (N) and on the moment rows (m,
which also take up joint play and other model error), estimated by iterating
``σ² = RSS / (rows − leverage)`` per session and row type (or given), alternating with τ.
Each session's contribution is its share of the total leverage (effective parameters).

Pad positions are not unknowns: a pad position enters the moment rows multiplied by its force,
and a shift of all four pads is a constant CoP shift again (confounded exactly like the
offsets), while the spacing trades against the gains; without a measured prior on them they are
poorly determined, so they stay a given of the sensor file (measure them).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from sescid.errors import DataError, OptionError
from sescid.estimation.fit import Fit
from sescid.estimation.identifiability import DEFAULT_RTOL, _sparse_terms, check_rtol, label_columns
from sescid.estimation.least_squares import cop_system
from sescid.estimation.map import TAU_RANGE, fit_map
from sescid.estimation.normal_equations import NormalEquations
from sescid.kinematics import as_poses
from sescid.robot import Robot

G = 9.80665  #: m/s², standard gravity
#: default prior standard deviations: relative gain, offset (N)
GAIN_PRIOR = 0.2
OFFSET_PRIOR = 0.2
#: starting noise levels of the iteration: force rows N, moment rows m
START_NOISE_FORCE = 0.5
START_NOISE_COP = 0.001
#: smallest estimated noise levels (resolution: 1 mN counts; 1 µm), N and m
NOISE_FLOOR_FORCE = 1e-3
NOISE_FLOOR_COP = 1e-6

UNLOADED_FOOT = "unloaded-foot"
OFFSET_TWIST = "offset-twist"
SUPPORT_CONFOUNDED = "support-confounded"
SCALE = "scale"
NOT_EXCITED = "not-excited"


# --- inputs -----------------------------------------------------------------------------
@dataclass(frozen=True)
class PadFoot:
    """One foot's pads in a session: positions (K, 2) m in its sole frame, per-pose readings."""

    name: str
    sole_frame: str
    pads: np.ndarray  #: (K, 2) pad centres in the sole frame, m
    readings: np.ndarray  #: (n, K) mean reading per pose, N (NaN where unloaded is fine)
    loaded: np.ndarray  #: (n,) bool: the foot carries load at that pose


@dataclass(frozen=True)
class PadSession:
    """A session: poses (n, nq) rad, the feet's pads, optional gravity (n, 3) support frame."""

    name: str
    q: np.ndarray
    feet: tuple[PadFoot, ...]
    gravity: np.ndarray | None = None
    sensors: str = "default"  #: sensor set: sessions with the same label share the gains
    noise_force: float | None = None  #: N, σ of the force rows (None: estimated)
    noise_cop: float | None = None  #: m, σ of the moment rows (None: estimated)


@dataclass(frozen=True)
class KnownSensors:
    """Sensor values held fixed: gains[(sensors, foot)] (K,), offsets[(session, foot)] (K,) N."""

    gains: dict[tuple[str, str], np.ndarray] = field(default_factory=dict)
    offsets: dict[tuple[str, str], np.ndarray] = field(default_factory=dict)


# --- results ----------------------------------------------------------------------------
@dataclass
class SensorParameter:
    """A pad's gain (dimensionless) or offset (N, reading units) with its standard error."""

    kind: str  #: "gain" or "offset"
    owner: str  #: sensor set (gains) or session (offsets)
    foot: str
    pad: int  #: 1-based
    value: float
    std: float
    unseen: float  #: share of this parameter (0–1) along directions the data cannot see
    known: bool = False  #: held fixed (given)

    @property
    def label(self) -> str:
        """``kind[owner/foot/pad]``."""
        return f"{self.kind}[{self.owner}/{self.foot}/{self.pad}]"


@dataclass
class SensorDirection:
    """A sensor direction the sessions do not determine: terms (label, coefficient), why."""

    terms: list[tuple[str, float]]
    kind: str
    reason: str
    #: SESC components that move with it (body, axis, coefficient), for support-confounded
    mass_terms: list[tuple[str, str, float]] = field(default_factory=list)

    def label(self, digits: int = 3) -> str:
        """The combination as text: sensor terms, then SESC terms."""
        parts = [f"{c:+.{digits}g}·{n}" for n, c in self.terms]
        parts += [f"{c:+.{digits}g}·r[{b}].{a}" for b, a, c in self.mass_terms]
        return " ".join(parts)


@dataclass
class SessionContribution:
    """What one session brought: poses, noise levels and its share of the information."""

    name: str
    sensors: str
    poses: int
    loaded_feet: list[str]
    double_support_poses: int
    noise_force: float  #: N
    noise_cop: float  #: m
    noise_by: str  #: "given" or "estimated"
    share: float  #: its rows' share of the fit's effective parameters (leverage), 0–1
    rms_force: float  #: N, residual RMS of its force rows
    rms_cop: float  #: m, residual RMS of its moment rows (as CoP)


@dataclass
class SensorCalibration:
    """Joint result: the mass model (``fit``), gains, offsets, sessions, unseen directions."""

    fit: Fit
    gains: list[SensorParameter]
    offsets: list[SensorParameter]
    sessions: list[SessionContribution]
    unidentifiable: list[SensorDirection]
    total_mass: float  #: kg, the weight's mass
    total_mass_by: str  #: "given" or "model"
    prior_scale: float  #: τ of the SESC prior, m
    prior_scale_by: str  #: "given" or "evidence"
    gain_prior: float
    offset_prior: float
    iterations: int
    converged: bool

    def gain(self, sensors: str, foot: str) -> tuple[np.ndarray, np.ndarray]:
        """(values, stds) (K,) of a sensor set's foot."""
        ps = [p for p in self.gains if p.owner == sensors and p.foot == foot]
        return np.array([p.value for p in ps]), np.array([p.std for p in ps])

    def offset(self, session: str, foot: str) -> tuple[np.ndarray, np.ndarray]:
        """(values, stds) (K,) N of a session's foot offsets."""
        ps = [p for p in self.offsets if p.owner == session and p.foot == foot]
        return np.array([p.value for p in ps]), np.array([p.std for p in ps])

    def summary(self) -> str:
        """Readable lines: sessions, gains, offsets and the unseen directions."""
        lines = [
            f"sensor calibration of {self.fit.robot.name}: {len(self.sessions)} session(s), "
            f"{self.fit.n_poses} poses; weight from {self.total_mass:.4f} kg "
            f"({self.total_mass_by}); SESC prior τ {self.prior_scale * 1e3:.3f} mm "
            f"({self.prior_scale_by}); {self.iterations} iterations"
            + ("" if self.converged else " (noise levels not converged)"),
        ]
        for s in self.sessions:
            lines.append(
                f"  session {s.name} [{s.sensors}]: {s.poses} poses on {'+'.join(s.loaded_feet)}"
                f" ({s.double_support_poses} double support), σ force {s.noise_force:.3f} N, "
                f"σ CoP {s.noise_cop * 1e3:.3f} mm ({s.noise_by}), share {100 * s.share:.0f} %"
            )
        for p in self.gains + self.offsets:
            unit = "" if p.kind == "gain" else " N"
            flag = (
                " (given)" if p.known else (" (partly from the prior)" if p.unseen > 0.01 else "")
            )
            lines.append(f"  {p.label} = {p.value:.4f} ± {p.std:.4f}{unit}{flag}")
        for d in self.unidentifiable:
            lines.append(f"  unidentifiable ({d.kind}): {d.label()}: {d.reason}")
        return "\n".join(lines)


# --- the linear system ------------------------------------------------------------------
@dataclass
class _Column:
    kind: str  #: "gain" | "offset"
    owner: str
    foot: str
    pad: int


def _check_sessions(robot: Robot, sessions: list[PadSession]) -> None:
    if not sessions:
        raise DataError("sensor calibration needs at least one session")
    names = [s.name for s in sessions]
    if len(set(names)) != len(names):
        raise DataError(f"session names must differ, got {names}")
    for s in sessions:
        q = as_poses(s.q, robot.nq)
        n = q.shape[0]
        for f in s.feet:
            if f.sole_frame not in robot.model.link_frames:
                raise DataError(f"session {s.name}: unknown sole frame '{f.sole_frame}'")
            if f.readings.shape != (n, f.pads.shape[0]) or f.loaded.shape != (n,):
                raise DataError(
                    f"session {s.name}, foot {f.name}: readings must be ({n}, "
                    f"{f.pads.shape[0]}) and loaded ({n},), got {f.readings.shape}, "
                    f"{f.loaded.shape}"
                )
            bad = f.loaded & ~np.all(np.isfinite(f.readings), axis=1)
            if bad.any():
                raise DataError(
                    f"session {s.name}, foot {f.name}: pose {int(np.flatnonzero(bad)[0])} is "
                    "loaded but has a missing reading"
                )
        if s.gravity is not None and np.asarray(s.gravity).shape != (n, 3):
            raise DataError(f"session {s.name}: gravity must be ({n}, 3)")
        for what, v in (("noise_force", s.noise_force), ("noise_cop", s.noise_cop)):
            if v is not None and not (math.isfinite(v) and v > 0):
                raise OptionError(what, f"session {s.name}: must be > 0, got {v}")


def _columns(sessions: list[PadSession]) -> list[_Column]:
    cols: list[_Column] = []
    seen = set()
    for s in sessions:  # gains: one block per (sensor set, foot)
        for f in s.feet:
            if (s.sensors, f.name) not in seen:
                seen.add((s.sensors, f.name))
                cols += [_Column("gain", s.sensors, f.name, k + 1) for k in range(len(f.pads))]
    for s in sessions:  # offsets: one block per (session, foot that it loads)
        for f in s.feet:
            if f.loaded.any():
                cols += [_Column("offset", s.name, f.name, k + 1) for k in range(len(f.pads))]
    return cols


@dataclass
class _Rows:
    a: np.ndarray  #: (m, P) design
    y: np.ndarray  #: (m,)
    session: np.ndarray  #: (m,) session index
    moment: np.ndarray  #: (m,) bool: moment row (m) vs force row (N)
    n_poses: int
    double: list[int]  #: per session, double-support poses
    used: list[int]  #: per session, poses with a loaded foot


def _session_rows(robot: Robot, s: PadSession, index: dict, p_x: int, p: int, weight: float):
    """Rows (3 per pose with a loaded foot) of one session, vectorised across poses."""
    q = as_poses(s.q, robot.nq)
    n = q.shape[0]
    loaded = np.stack([f.loaded for f in s.feet], axis=1) if s.feet else np.zeros((n, 0), bool)
    use = loaded.any(axis=1)
    q = q[use]
    k = q.shape[0]
    if k == 0:
        return np.zeros((0, p)), np.zeros(0), 0, 0
    loaded = loaded[use]
    poses = {f.name: robot.link_poses(q, f.sole_frame) for f in s.feet}
    # ground frame: the support sole when loaded, else the first loaded foot
    order = sorted(range(len(s.feet)), key=lambda i: s.feet[i].sole_frame != robot.support)
    rot_g = np.zeros((k, 3, 3))
    org_g = np.zeros((k, 3))
    chosen = np.zeros(k, dtype=bool)
    for i in order:
        pick = loaded[:, i] & ~chosen
        rot, org = poses[s.feet[i].name]
        rot_g[pick], org_g[pick] = rot[pick], org[pick]
        chosen |= pick
    if s.gravity is None:
        g = np.tile([0.0, 0.0, -1.0], (k, 1))
    else:
        gs = np.asarray(s.gravity, dtype=float)[use]
        g = np.einsum("nji,nj->ni", rot_g, gs / np.linalg.norm(gs, axis=1, keepdims=True))
    if np.any(g[:, 2] >= -0.5):
        raise DataError(f"session {s.name}: gravity does not point down through the ground sole")
    tmat = np.concatenate([np.tile(np.eye(2), (k, 1, 1)), -(g[:, :2] / g[:, 2:3])[:, :, None]], 2)
    proj = np.einsum("nab,ncb->nac", tmat, rot_g)  # T R_Gᵀ (k, 2, 3)
    phi = robot.regressor(q, (0, 1, 2))  # (k, 3, 3N)
    a = np.zeros((k, 3, p))
    a[:, 1:, :p_x] = -np.einsum("nac,ncp->nap", proj, phi)
    rhs = np.zeros((k, 3))
    rhs[:, 0] = -weight * g[:, 2]
    rhs[:, 1:] = np.einsum("nac,nc->na", proj, robot.d[None, :] - org_g)
    for i, f in enumerate(s.feet):
        on = loaded[:, i]
        rot, org = poses[f.name]
        pad3 = np.concatenate([f.pads, np.zeros((len(f.pads), 1))], axis=1)
        world = org[:, None, :] + np.einsum("nij,kj->nki", rot, pad3)  # support frame
        pg = np.einsum("nji,nkj->nki", rot_g, world - org_g[:, None, :])[:, :, :2]  # ground xy
        y = np.where(on[:, None], np.nan_to_num(np.asarray(f.readings, float)[use]), 0.0)
        if not on.any():
            continue
        gi = index[("gain", s.sensors, f.name)]
        oi = index[("offset", s.name, f.name)]
        a[:, 0, gi] += y
        a[:, 0, oi] -= on[:, None]
        a[:, 1:, gi] += np.einsum("nk,nka->nak", y, pg) / weight
        a[:, 1:, oi] -= np.einsum("n,nka->nak", on.astype(float), pg) / weight
    double = int(np.sum(loaded.sum(axis=1) > 1))
    return a.reshape(3 * k, p), rhs.reshape(-1), k, double


def _build(robot: Robot, sessions: list[PadSession], cols: list[_Column], weight: float):
    p_x = 3 * len(robot.body_names)
    p = p_x + len(cols)
    index: dict[tuple[str, str, str], np.ndarray] = {}
    for j, c in enumerate(cols):
        index.setdefault((c.kind, c.owner, c.foot), [])  # type: ignore[arg-type]
        index[(c.kind, c.owner, c.foot)].append(p_x + j)  # type: ignore[attr-defined]
    index = {key: np.array(v) for key, v in index.items()}
    blocks, ys, sess, mom, double, used = [], [], [], [], [], []
    for si, s in enumerate(sessions):
        a, y, k, dbl = _session_rows(robot, s, index, p_x, p, weight)
        blocks.append(a)
        ys.append(y)
        sess.append(np.full(3 * k, si))
        mom.append(np.tile([False, True, True], k))
        double.append(dbl)
        used.append(k)
    return _Rows(
        np.vstack(blocks),
        np.concatenate(ys),
        np.concatenate(sess),
        np.concatenate(mom),
        sum(used),
        double,
        used,
    ), index


# --- estimation -------------------------------------------------------------------------
def _spd_inverse(mat: np.ndarray) -> np.ndarray:
    """Inverse of a symmetric positive (semi)definite matrix: Cholesky, else eigen (clipped)."""
    import scipy.linalg  # lazy: scipy's import is ~0.3 s of every command

    try:
        cf = scipy.linalg.cho_factor(mat, check_finite=False)
        return scipy.linalg.cho_solve(cf, np.eye(mat.shape[0]), check_finite=False)
    except np.linalg.LinAlgError:
        lam, vec = np.linalg.eigh(0.5 * (mat + mat.T))
        lam = np.maximum(lam, lam.max() * 1e-15)
        return (vec / lam) @ vec.T


def _log_evidence(a: np.ndarray, z: np.ndarray, prec: np.ndarray) -> float:
    """Log p(z | priors) of whitened rows a θ ≈ z, θ ~ N(0, diag(1/prec)) (constants dropped)."""
    import scipy.linalg

    mat = a.T @ a + np.diag(prec)
    try:
        cf = scipy.linalg.cho_factor(mat, check_finite=False)
    except np.linalg.LinAlgError:
        return -math.inf
    b = a.T @ z
    quad = z @ z - b @ scipy.linalg.cho_solve(cf, b, check_finite=False)
    return -0.5 * (2 * np.sum(np.log(np.diag(cf[0]))) - np.sum(np.log(prec)) + quad)


def calibrate_sensors(
    robot: Robot,
    sessions: list[PadSession],
    *,
    total_mass: float | None = None,
    prior_scale: float | None = None,
    gain_prior: float = GAIN_PRIOR,
    offset_prior: float = OFFSET_PRIOR,
    known: KnownSensors | None = None,
    rtol: float = DEFAULT_RTOL,
    max_iter: int = 30,
    tol: float = 1e-4,
) -> SensorCalibration:
    """Estimate the SESC vectors with every pad's gain and each session's offsets (module doc).

    ``total_mass``: the weighed mass (kg) that fixes the gains' scale (None: the model's, named
    as an unidentifiable ``scale``). ``prior_scale``: τ of the CAD prior on the SESC vectors (m;
    None: by evidence). ``known``: sensor values held fixed (e.g. a perfectly calibrated bench).
    """
    check_rtol(rtol)
    for name, v in (("gain_prior", gain_prior), ("offset_prior", offset_prior)):
        if not (math.isfinite(v) and v > 0):
            raise OptionError(name, f"must be > 0, got {v}")
    if prior_scale is not None and not (math.isfinite(prior_scale) and prior_scale > 0):
        raise OptionError("prior_scale", f"must be > 0 m, got {prior_scale}")
    if total_mass is not None and not (math.isfinite(total_mass) and total_mass > 0):
        raise OptionError("total_mass", f"must be > 0 kg, got {total_mass}")
    _check_sessions(robot, sessions)
    known = known or KnownSensors()
    mass = robot.total_mass if total_mass is None else float(total_mass)
    weight = mass * G
    cols = _columns(sessions)
    rows, index = _build(robot, sessions, cols, weight)
    if rows.n_poses == 0:
        raise DataError("no pose of any session has a loaded foot")
    p_x = 3 * len(robot.body_names)
    p = rows.a.shape[1]
    theta0 = np.concatenate([robot.sesc_vectors().reshape(-1), np.zeros(len(cols))])
    prior_sd = np.ones(p)
    for j, c in enumerate(cols):
        theta0[p_x + j] = 1.0 if c.kind == "gain" else 0.0
        prior_sd[p_x + j] = gain_prior if c.kind == "gain" else offset_prior
    # fixed (known) parameters: gains, and offsets as β = g·o
    fixed = np.zeros(p, dtype=bool)
    for (owner, foot), vals in known.gains.items():
        key = ("gain", owner, foot)
        if key not in index:
            raise OptionError("known", f"no gains of sensor set '{owner}', foot '{foot}'")
        fixed[index[key]] = True
        theta0[index[key]] = np.asarray(vals, dtype=float)
    sens_of = {s.name: s.sensors for s in sessions}
    for (owner, foot), vals in known.offsets.items():
        key = ("offset", owner, foot)
        gkey = ("gain", sens_of.get(owner, ""), foot)
        if key not in index or not fixed[index[gkey]].all():
            raise OptionError("known", f"offsets of {owner}/{foot} need that foot's gains known")
        fixed[index[key]] = True
        theta0[index[key]] = np.asarray(vals, dtype=float) * theta0[index[gkey]]
    free = ~fixed
    z_all = rows.y - rows.a @ theta0  # residual at the prior mean (fixed parts exact)
    a_free = rows.a[:, free]
    var_f = np.array(
        [START_NOISE_FORCE**2 if s.noise_force is None else s.noise_force**2 for s in sessions]
    )
    var_c = np.array(
        [START_NOISE_COP**2 if s.noise_cop is None else s.noise_cop**2 for s in sessions]
    )
    free_x = free[:p_x]
    sens_prec = 1.0 / prior_sd[p_x:][free[p_x:]] ** 2
    tau = prior_scale if prior_scale is not None else 1e-3
    converged = False
    iterations = 0
    for it in range(1, max_iter + 1):
        iterations = it
        sw = 1.0 / np.sqrt(np.where(rows.moment, var_c[rows.session], var_f[rows.session]))
        aw, zw = a_free * sw[:, None], z_all * sw
        if prior_scale is None:

            def neg(lt: float, aw=aw, zw=zw) -> float:
                prec = np.concatenate([np.full(int(free_x.sum()), math.exp(-2 * lt)), sens_prec])
                val = -_log_evidence(aw, zw, prec)
                return val if math.isfinite(val) else 1e300

            grid = np.linspace(math.log(TAU_RANGE[0]), math.log(TAU_RANGE[1]), 13)
            evid = [neg(t) for t in grid]
            kk = int(np.argmin(evid))
            import scipy.optimize

            res = scipy.optimize.minimize_scalar(
                neg, bounds=(grid[max(kk - 1, 0)], grid[min(kk + 1, 12)]), method="bounded"
            )
            tau = math.exp(float(res.x) if res.fun <= evid[kk] else float(grid[kk]))
        prec = np.concatenate([np.full(int(free_x.sum()), tau**-2), sens_prec])
        minv = _spd_inverse(aw.T @ aw + np.diag(prec))
        delta = minv @ (aw.T @ zw)
        resid = z_all - a_free @ delta
        lev = np.einsum("ij,jk,ik->i", aw, minv, aw)
        new_f, new_c = var_f.copy(), var_c.copy()
        for si, s in enumerate(sessions):
            for is_m, given, new in ((False, s.noise_force, new_f), (True, s.noise_cop, new_c)):
                sel = (rows.session == si) & (rows.moment == is_m)
                if given is not None or not sel.any():
                    continue
                dof = max(sel.sum() - lev[sel].sum(), 1.0)
                floor = NOISE_FLOOR_COP if is_m else NOISE_FLOOR_FORCE
                new[si] = max(float(resid[sel] @ resid[sel]) / dof, floor**2)
        change = max(np.max(np.abs(np.log(new_f / var_f))), np.max(np.abs(np.log(new_c / var_c))))
        var_f, var_c = new_f, new_c
        if change < tol:
            converged = True
            break
    theta = theta0.copy()
    theta[free] += delta
    cov = np.zeros((p, p))
    cov[np.ix_(free, free)] = minv

    # the mass model: the x block with the sensors marginalised (a MAP Fit)
    fit = _mass_fit(robot, aw, zw, free, p_x, theta0, tau, sens_prec, rtol, rows)
    fx = np.flatnonzero(free[:p_x])
    cop_rows = rows.moment
    fit = dataclasses.replace(
        fit,
        r=theta[:p_x].reshape(-1, 3),
        cov=cov[np.ix_(range(p_x), range(p_x))] if fx.size == p_x else np.zeros((p_x, p_x)),
        rms=float(np.sqrt(np.mean(resid[cop_rows] ** 2))),
        mae=float(np.mean(np.abs(resid[cop_rows]))),
        map=None
        if fit.map is None
        else dataclasses.replace(
            fit.map,
            prior_scale_by="given" if prior_scale is not None else "evidence",
            noise_by="per-session estimate",
        ),
    )

    null_proj = _sensor_null_projector(rows, free, p_x, prior_sd, sw, rtol)
    params = _parameters(cols, theta, cov, p_x, fixed, null_proj, free, sens_of)
    unseen = _directions(robot, sessions, cols, rows, free, p_x, prior_sd, sw, rtol, theta)
    if total_mass is None:
        unseen.append(
            SensorDirection(
                [(p.label, 1.0) for p in params if p.kind == "gain" and not p.known],
                SCALE,
                f"no weighed mass: the gains' common scale rests on the model's mass "
                f"{mass:.4f} kg (weigh the robot and give it)",
            )
        )
    contrib = []
    total_lev = float(lev.sum()) or 1.0
    for si, s in enumerate(sessions):
        sel = rows.session == si
        fr, mr = sel & ~rows.moment, sel & rows.moment
        given = s.noise_force is not None and s.noise_cop is not None
        contrib.append(
            SessionContribution(
                name=s.name,
                sensors=s.sensors,
                poses=rows.used[si],
                loaded_feet=[f.name for f in s.feet if f.loaded.any()],
                double_support_poses=rows.double[si],
                noise_force=math.sqrt(var_f[si]),
                noise_cop=math.sqrt(var_c[si]),
                noise_by="given" if given else "estimated",
                share=float(lev[sel].sum()) / total_lev,
                rms_force=float(np.sqrt(np.mean(resid[fr] ** 2))) if fr.any() else math.nan,
                rms_cop=float(np.sqrt(np.mean(resid[mr] ** 2))) if mr.any() else math.nan,
            )
        )
    return SensorCalibration(
        fit=fit,
        gains=[q for q in params if q.kind == "gain"],
        offsets=[q for q in params if q.kind == "offset"],
        sessions=contrib,
        unidentifiable=unseen,
        total_mass=mass,
        total_mass_by="model" if total_mass is None else "given",
        prior_scale=tau,
        prior_scale_by="given" if prior_scale is not None else "evidence",
        gain_prior=gain_prior,
        offset_prior=offset_prior,
        iterations=iterations,
        converged=converged,
    )


def _mass_fit(robot, aw, zw, free, p_x, theta0, tau, sens_prec, rtol, rows) -> Fit:
    """A MAP ``Fit`` of vec(r) from the whitened rows with the free sensor columns marginalised."""
    nx = int(free[:p_x].sum())
    if nx != p_x:
        raise OptionError("known", "the SESC vectors cannot be held fixed here")
    ax, as_ = aw[:, :nx], aw[:, nx:]
    if as_.shape[1]:
        minv = _spd_inverse(as_.T @ as_ + np.diag(sens_prec))
        cross = ax.T @ as_
        bs = as_.T @ zw
        ata = ax.T @ ax - cross @ minv @ cross.T
        b = ax.T @ zw - cross @ (minv @ bs)
        ztz = float(zw @ zw - bs @ minv @ bs)
    else:
        ata, b, ztz = ax.T @ ax, ax.T @ zw, float(zw @ zw)
    ata = 0.5 * (ata + ata.T)
    x0 = theta0[:p_x]
    atb = b + ata @ x0
    yty = ztz + 2 * x0 @ atb - x0 @ ata @ x0
    ne = NormalEquations(ata, atb, float(yty), int(aw.shape[0]), rows.n_poses)
    return fit_map(
        robot, cop_system(robot, ne, weighted=True), prior_scale=tau, noise=1.0, rtol=rtol
    )


def _scaled_schur(rows, free, p_x, prior_sd, sw, rtol):
    """Sensor-block Schur complement (x eliminated, no priors) in prior-std units."""
    a = rows.a * sw[:, None]
    ax = a[:, :p_x]
    s_idx = np.flatnonzero(free[p_x:]) + p_x
    as_ = a[:, s_idx] * prior_sd[s_idx]
    lam, vec = np.linalg.eigh(ax.T @ ax)
    keep = lam > (rtol**2) * lam.max()
    pinv = (vec[:, keep] / lam[keep]) @ vec[:, keep].T
    cross = ax.T @ as_
    schur = as_.T @ as_ - cross.T @ pinv @ cross
    return 0.5 * (schur + schur.T), s_idx, ax, as_, pinv, cross


def _null_basis(schur: np.ndarray, rtol: float) -> np.ndarray:
    if schur.size == 0:
        return np.zeros((0, 0))
    lam, vec = np.linalg.eigh(schur)
    top = max(lam.max(), 1e-300)
    return vec[:, np.sqrt(np.clip(lam, 0, None)) <= rtol * math.sqrt(top) * 1e2]


def _sensor_null_projector(rows, free, p_x, prior_sd, sw, rtol) -> np.ndarray:
    schur, *_ = _scaled_schur(rows, free, p_x, prior_sd, sw, rtol)
    nb = _null_basis(schur, rtol)
    return nb @ nb.T


def _parameters(cols, theta, cov, p_x, fixed, null_proj, free, sens_of) -> list[SensorParameter]:
    """Gains and offsets o = β / g (delta method for the offsets' standard errors)."""
    out = []
    s_idx = np.flatnonzero(free[p_x:]) + p_x
    pos = {int(j): i for i, j in enumerate(s_idx)}
    gain_of: dict[tuple[str, str, int], int] = {}
    for j, c in enumerate(cols):
        if c.kind == "gain":
            gain_of[(c.owner, c.foot, c.pad)] = p_x + j
    for j, c in enumerate(cols):
        col = p_x + j
        unseen = float(null_proj[pos[col], pos[col]]) if col in pos else 0.0
        if c.kind == "gain":
            value, var = float(theta[col]), cov[col, col]
        else:
            gc = gain_of[(sens_of[c.owner], c.foot, c.pad)]
            g, beta = theta[gc], theta[col]
            value = float(beta / g)
            jac = np.array([-beta / g**2, 1.0 / g])
            sub = cov[np.ix_([gc, col], [gc, col])]
            var = float(jac @ sub @ jac)
            if gc in pos:
                unseen = max(unseen, float(null_proj[pos[gc], pos[gc]]))
        out.append(
            SensorParameter(
                c.kind,
                c.owner,
                c.foot,
                c.pad,
                value,
                math.sqrt(max(var, 0.0)),
                min(unseen, 1.0),
                bool(fixed[col]),
            )
        )
    return out


def _directions(robot, sessions, cols, rows, free, p_x, prior_sd, sw, rtol, theta):
    """Name the sensor directions the sessions leave undetermined (see the module doc)."""
    schur, s_idx, ax, as_, pinv, cross = _scaled_schur(rows, free, p_x, prior_sd, sw, rtol)
    nb = _null_basis(schur, rtol)
    pos = {int(j): i for i, j in enumerate(s_idx)}
    labels = [
        f"{cols[j - p_x].kind}[{cols[j - p_x].owner}/{cols[j - p_x].foot}/{cols[j - p_x].pad}]"
        for j in s_idx
    ]
    proj = nb @ nb.T
    found: list[np.ndarray] = []
    out: list[SensorDirection] = []

    def take(v: np.ndarray, kind: str, reason: str) -> None:
        v = v / np.linalg.norm(v)
        if np.linalg.norm(proj @ v) > 1 - 1e-6:
            found.append(v)
            terms = [(labels[i], float(v[i])) for i in np.flatnonzero(np.abs(v) > 1e-9)]
            out.append(SensorDirection(terms, kind, reason))

    loaded_by: dict[tuple[str, str], bool] = {}
    for s in sessions:
        for f in s.feet:
            key = (s.sensors, f.name)
            loaded_by[key] = loaded_by.get(key, False) or bool(f.loaded.any())
    for j in s_idx:
        c = cols[j - p_x]
        v = np.zeros(len(s_idx))
        v[pos[int(j)]] = 1.0
        if c.kind == "gain" and not loaded_by[(c.owner, c.foot)]:
            take(v, UNLOADED_FOOT, f"the {c.foot} foot never carries load with sensors {c.owner}")
    for s in sessions:
        for f in s.feet:
            idx = [pos.get(int(p_x + j)) for j, c in enumerate(cols)
                   if c.kind == "offset" and c.owner == s.name and c.foot == f.name]  # fmt: skip
            if not f.loaded.any():
                out.append(
                    SensorDirection(
                        [(f"offset[{s.name}/{f.name}/{k + 1}]", 1.0) for k in range(len(f.pads))],
                        UNLOADED_FOOT,
                        f"session {s.name} never loads the {f.name} foot: its offsets there are "
                        "not seen (not estimated)",
                    )
                )
                continue
            if not idx or any(i is None for i in idx):
                continue
            basis = np.column_stack([np.ones(len(f.pads)), f.pads])
            import scipy.linalg

            tw = scipy.linalg.null_space(basis.T)
            for t in tw.T:
                v = np.zeros(len(s_idx))
                v[idx] = t / prior_sd[s_idx[idx]]
                take(
                    v,
                    OFFSET_TWIST,
                    f"session {s.name}, {f.name} foot: this offset combination changes neither "
                    "the total force nor its moments, so statics never sees it (from the prior)",
                )
    rest = proj.copy()
    if found:
        qf, _ = np.linalg.qr(np.column_stack(found))
        rest -= qf @ qf.T
    w, u = np.linalg.eigh(rest)
    mass_labels = label_columns(robot)
    for k in np.flatnonzero(w > 0.5):
        v = u[:, k]
        xcomp = -pinv @ cross @ v  # the SESC change that hides it
        terms = [(labels[i], float(v[i])) for i in np.flatnonzero(np.abs(v) > 1e-3)]
        if np.linalg.norm(xcomp) <= 1e-6 * max(np.linalg.norm(v), 1e-300):
            out.append(
                SensorDirection(
                    terms,
                    NOT_EXCITED,
                    "the pads' load pattern did not vary independently of the CoP in these "
                    "poses (e.g. a split linear in the CoP), so these gains are not separated",
                )
            )
            continue
        mass = _sparse_terms(xcomp, mass_labels, tol=1e-2)
        out.append(
            SensorDirection(
                terms,
                SUPPORT_CONFOUNDED,
                "these offsets shift the CoP by a constant in their foot's frame, as the SESC "
                "components of the body fixed to that sole do; poses on the other foot "
                "separate them",
                mass,
            )
        )
    return out
