"""Least-squares identification of the SESC vectors from CoP measurements.

Each pose gives two equations ``cop − d_xy = Φ_xy(q) · vec(r)``. The regressor is rank deficient
(the OP2's has rank 42 of 63): the fit determines ``r`` only up to its null space. sescid solves
the least-squares problem in the eigenbasis of the normal matrix ``A = ΦᵀΦ`` and fills the
undetermined directions from the prior model (the URDF's own SESC vectors ``r0``):

    r̂ = r0 + V_p Λ_p⁻¹ V_pᵀ (Φᵀy − A r0)

— the least-squares solution closest to ``r0``. CoP predictions do not depend on that choice;
CoM height does (partly), and the fit says how much. Rank: eigen-directions whose singular value
``√λ`` exceeds ``rtol · √λ_max`` (default ``rtol = 1e-6``, far above the ~1e-8 round-off floor of
the normal equations and far below the smallest identifiable value of any real pose set).

The normal equations are accumulated block by block, so a stream of chunks (``identify_stream``)
gives the same answer as the in-memory path without storing Φ.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg

from .errors import SescidError
from .kinematics import Workspace, as_poses, reduced_columns, regressor
from .robot import Robot

DEFAULT_RTOL = 1e-6
#: poses per block when accumulating normal equations
ACCUMULATE_BLOCK = 2048
_AXES = "xyz"


@dataclass
class NormalEquations:
    """Running sums of a (weighted) least-squares problem y ≈ Φ x, Φ with P columns."""

    ata: np.ndarray  #: (P, P) ΦᵀWΦ
    atb: np.ndarray  #: (P,) ΦᵀWy
    yty: float = 0.0  #: yᵀWy
    n_rows: int = 0
    n_poses: int = 0

    @classmethod
    def empty(cls, n_params: int) -> NormalEquations:
        return cls(np.zeros((n_params, n_params)), np.zeros(n_params))

    def add(self, phi_t: np.ndarray, y: np.ndarray, w: np.ndarray | None = None) -> None:
        """Add rows given as columns: phi_t = Φᵀ (P, m), y (m,), optional weights w (m,) = 1/σ²."""
        if w is not None:
            sw = np.sqrt(w)
            phi_t = phi_t * sw
            y = y * sw
        self.ata += phi_t @ phi_t.T
        self.atb += phi_t @ y
        self.yty += float(y @ y)
        self.n_rows += phi_t.shape[1]


def check_cop(cop, n: int, what: str = "cop") -> np.ndarray:
    """Validate CoP measurements (n, 2), finite metres."""
    arr = np.asarray(cop, dtype=float)
    if arr.shape != (n, 2):
        raise SescidError(f"{what}: expected shape ({n}, 2) in metres, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        row = int(np.argwhere(~np.isfinite(arr))[0, 0])
        raise SescidError(f"{what}: non-finite CoP at pose {row}")
    return arr


def _row_weights(sigma, n: int) -> np.ndarray | None:
    """Per-pose CoP standard errors (n,) or (n, 2) in m → row weights (2n,) = 1/σ²."""
    if sigma is None:
        return None
    s = np.asarray(sigma, dtype=float)
    if s.ndim == 1:
        s = np.repeat(s[:, None], 2, axis=1)
    if s.shape != (n, 2):
        raise SescidError(f"sigma: expected shape ({n},) or ({n}, 2) in metres, got {s.shape}")
    if not np.all(np.isfinite(s) & (s > 0)):
        row = int(np.argwhere(~(np.isfinite(s) & (s > 0)))[0, 0])
        raise SescidError(f"sigma: standard error at pose {row} must be finite and > 0")
    return (1.0 / s**2).reshape(-1)


def accumulate(
    robot: Robot,
    chunks: Iterable[tuple],
    ne: NormalEquations | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> NormalEquations:
    """Accumulate normal equations from chunks ``(q, cop)`` or ``(q, cop, sigma)``.

    ``progress(done, total)`` is called after each block with the poses done in the chunk.
    """
    ne = ne or NormalEquations.empty(3 * len(robot.body_names))
    d_xy = robot.d[:2]
    ws = Workspace(robot.tree, ACCUMULATE_BLOCK)
    red = robot.reduction
    acc = NormalEquations.empty(red.g.shape[0])  # in reduced coordinates β = G r
    for chunk in chunks:
        q, cop = chunk[0], chunk[1]
        sigma = chunk[2] if len(chunk) > 2 else None
        q = as_poses(q, robot.nq)
        cop = check_cop(cop, q.shape[0])
        w = _row_weights(sigma, q.shape[0])
        for s in range(0, q.shape[0], ws.block):
            blk = slice(s, s + ws.block)
            x = reduced_columns(robot.tree, red, q[blk], ws)  # (P_red, 2m): x rows, y rows
            y = (cop[blk] - d_xy).T.reshape(-1)
            acc.add(x, y, None if w is None else w.reshape(-1, 2)[blk].T.reshape(-1))
            if progress is not None:
                progress(min(s + ws.block, q.shape[0]), q.shape[0])
        ne.n_poses += q.shape[0]
    ne.ata += red.g.T @ acc.ata @ red.g
    ne.atb += red.g.T @ acc.atb
    ne.yty += acc.yty
    ne.n_rows += acc.n_rows
    return ne


@dataclass
class Combination:
    """A named linear combination of SESC components: Σ coef · r[body][axis] (m)."""

    terms: list[tuple[str, str, float]]  #: (body, axis, coefficient)
    value: float = float("nan")  #: estimate, m
    std: float = float("nan")  #: standard error, m
    reason: str = ""

    def label(self, digits: int = 3) -> str:
        parts = []
        for k, (body, axis, c) in enumerate(self.terms):
            name = f"r[{body}].{axis}"
            if k == 0 and abs(c - 1) < 1e-12:
                parts.append(name)
                continue
            sign = "-" if c < 0 else "+"
            mag = f"{abs(c):.{digits}g}·"
            parts.append(f"{sign} {'' if abs(abs(c) - 1) < 1e-12 else mag}{name}")
        text = " ".join(parts)
        return text[2:] if text.startswith("+ ") else text

    def to_json(self) -> dict:
        return {
            "terms": [[b, a, c] for b, a, c in self.terms],
            "label": self.label(),
            "value": None if math.isnan(self.value) else self.value,
            "std": None if math.isnan(self.std) else self.std,
            "reason": self.reason,
        }

    @classmethod
    def from_json(cls, d: dict) -> Combination:
        return cls(
            terms=[(b, a, float(c)) for b, a, c in d["terms"]],
            value=float("nan") if d.get("value") is None else d["value"],
            std=float("nan") if d.get("std") is None else d["std"],
            reason=d.get("reason", ""),
        )


@dataclass
class Fit:
    """An identified model: SESC vectors, their uncertainty and what the data could determine."""

    robot: Robot
    r: np.ndarray  #: (N, 3) identified SESC vectors, m (undetermined directions from r_prior)
    r_prior: np.ndarray  #: (N, 3) the prior model's SESC vectors, m
    cov: np.ndarray  #: (3N, 3N) covariance of vec(r), m² (zero along undetermined directions)
    basis: np.ndarray  #: (3N, p) orthonormal basis of the identifiable subspace
    singular_values: np.ndarray  #: (3N,) √eig(ΦᵀWΦ), descending
    rank: int
    n_poses: int
    n_rows: int
    sigma_hat: float  #: residual standard deviation, m (nan when n_rows ≤ rank)
    rms: float  #: residual RMS per CoP component, m
    mae: float  #: mean absolute residual per CoP component, m (nan for streamed data)
    rtol: float
    method: str = "least-squares"
    base: list[Combination] = field(default_factory=list)
    unidentifiable: list[Combination] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    extra: dict = field(default_factory=dict)  #: method-specific results (JSON-serialisable)

    # --- predictions ------------------------------------------------------------------
    def predict_cop(self, q) -> np.ndarray:
        """CoP (n, 2) in m at poses q (n, nq) [rad]."""
        return self.robot.cop(q, self.r)

    def predict_com(self, q) -> np.ndarray:
        """CoM (n, 3) in m; its z partly comes from the prior (see ``com_z_from_prior``)."""
        return self.robot.com(q, self.r)

    def predict_std(self, q, rows=(0, 1, 2)) -> np.ndarray:
        """Standard error (n, len(rows)) in m of the predicted CoM components ``rows``.

        Counts the uncertainty of the identified directions only; the prior-filled part of the
        CoM height is taken as exact here.
        """
        q = as_poses(q, self.robot.nq)
        out = np.empty((q.shape[0], len(rows)))
        for s in range(0, q.shape[0], 4096):
            phi = regressor(self.robot.tree, q[s : s + 4096], rows)
            out[s : s + 4096] = np.sqrt(np.einsum("nri,ij,nrj->nr", phi, self.cov, phi))
        return out

    def com_z_from_prior(self, q) -> np.ndarray:
        """(n,) part of the predicted CoM height (m) that comes from the prior model r_prior.

        The z row of the regressor has components outside the identifiable subspace; along
        those, r̂ equals r_prior, so this part of CoM_z is the prior's, not the data's.
        """
        _, outside = self._z_rows(q)
        return outside @ self.r_prior.reshape(-1)

    def com_z_prior_fraction(self, q) -> np.ndarray:
        """(n,) fraction of the z regressor row's norm outside the identifiable subspace."""
        phi_z, outside = self._z_rows(q)
        return np.linalg.norm(outside, axis=1) / np.linalg.norm(phi_z, axis=1)

    def _z_rows(self, q) -> tuple[np.ndarray, np.ndarray]:
        """The z regressor rows (n, 3N) and their part outside the identifiable subspace."""
        q = as_poses(q, self.robot.nq)
        phi_z = regressor(self.robot.tree, q, (2,))[:, 0, :]
        return phi_z, phi_z - (phi_z @ self.basis) @ self.basis.T

    # --- summaries --------------------------------------------------------------------
    @property
    def r_magnitudes(self) -> np.ndarray:
        """R_i = |r_i| (N,) in m (the paper's Fig. 3a)."""
        return np.linalg.norm(self.r, axis=1)

    @property
    def r_std(self) -> np.ndarray:
        """(N, 3) standard errors of r (m); 0 along directions filled from the prior."""
        return np.sqrt(np.clip(np.diag(self.cov), 0, None)).reshape(-1, 3)

    def summary(self) -> str:
        scale = (
            f"sigma_hat {self.sigma_hat:.3f} (scale of normalised residuals)"
            if self.extra.get("weighted")
            else f"sigma_hat {self.sigma_hat * 1e3:.3f} mm"
        )
        lines = [
            f"{self.method} fit of {self.robot.name} (support {self.robot.support}): "
            f"{self.n_poses} poses, rank {self.rank} of {self.r.size}",
            f"  {scale}, residual RMS {self.rms * 1e3:.3f} mm"
            + ("" if math.isnan(self.mae) else f", MAE {self.mae * 1e3:.3f} mm"),
        ]
        lines += [f"  note: {n}" for n in self.notes]
        return "\n".join(lines)

    def save(self, path) -> None:
        """Write the fit as JSON (format ``sescid-fit/1``, documented in ``sescid.io``)."""
        from .io import save_fit  # io depends on estimate, not the other way round

        save_fit(self, path)


def _label_columns(robot: Robot) -> list[tuple[str, str]]:
    return [(b, a) for b in robot.body_names for a in _AXES]


def structural_null_directions(robot: Robot) -> list[tuple[np.ndarray, str]]:
    """Directions of vec(r) that no CoP can see, for any poses, with the reason.

    - the support body never moves: its vertical component has no effect on the CoP;
    - a body's component along its own joint axis turns with the parent only, so just its sum
      with the parent's matching component is seen.
    """
    n = len(robot.body_names)
    out = []
    root = np.zeros((n, 3))
    root[0] = robot.tree.root_r.T @ np.array([0.0, 0.0, 1.0])
    out.append(
        (
            root.reshape(-1),
            f"vertical component of the support body {robot.body_names[0]}: it never moves, "
            "so it never shifts the CoP (it sets the CoM height offset only)",
        )
    )
    for i, b in enumerate(robot.model.bodies):
        if b.parent < 0:
            continue
        v = np.zeros((n, 3))
        v[i] = b.axis
        v[b.parent] -= b.rot_const @ b.axis
        v /= np.linalg.norm(v)
        out.append(
            (
                v.reshape(-1),
                f"component of {b.name} along its joint axis ({b.joint_name}): it turns with "
                f"{robot.body_names[b.parent]} only, so only their combination is seen",
            )
        )
    return out


def _sparse_terms(vec: np.ndarray, labels, tol: float = 1e-9) -> list[tuple[str, str, float]]:
    big = np.flatnonzero(np.abs(vec) > tol * np.abs(vec).max())
    big = big[np.argsort(-np.abs(vec[big]), kind="stable")]
    return [(labels[i][0], labels[i][1], float(vec[i])) for i in big]


def _base_combinations(sv, vecs, p, labels, r, cov) -> list[Combination]:
    """Base parameters by QR with column pivoting of S = diag(s) Vᵀ (same structure as Φ)."""
    s_mat = sv[:p, None] * vecs[:, :p].T  # (p, P): S ᵀS = ΦᵀΦ on the identifiable part
    _, rr, piv = scipy.linalg.qr(s_mat, pivoting=True, mode="economic")
    r11, r12 = rr[:p, :p], rr[:p, p:]
    k = scipy.linalg.solve_triangular(r11, r12) if r12.size else np.zeros((p, 0))
    out = []
    vec_r = r.reshape(-1)
    for i in range(p):
        g = np.zeros(vec_r.size)
        g[piv[i]] = 1.0
        g[piv[p:]] = k[i]
        g[np.abs(g) < 1e-10] = 0.0
        value = float(g @ vec_r)
        std = float(np.sqrt(max(g @ cov @ g, 0.0)))
        terms = [(labels[piv[i]][0], labels[piv[i]][1], 1.0)]
        terms += [t for t in _sparse_terms(g, labels) if (t[0], t[1]) != labels[piv[i]]]
        out.append(Combination(terms, value, std))
    return out


def _unidentifiable(robot, basis, labels) -> list[Combination]:
    """Name the null space: structural directions first, then what these poses left out."""
    n_par = basis.shape[0]
    proj = np.eye(n_par) - basis @ basis.T  # projector on the null space
    out = []
    found = np.zeros((n_par, 0))
    for v, reason in structural_null_directions(robot):
        if np.linalg.norm(proj @ v) > 1 - 1e-6:  # v lies in the null space
            out.append(Combination(_sparse_terms(v, labels), reason=reason))
            found = np.column_stack([found, v])
    # Remaining null directions: not seen because these poses do not excite them.
    if found.shape[1]:
        q_found, _ = np.linalg.qr(found)
        rest = proj - q_found @ q_found.T
    else:
        rest = proj
    w, u = np.linalg.eigh(rest)
    for k in np.flatnonzero(w > 0.5):
        out.append(
            Combination(
                _sparse_terms(u[:, k], labels, tol=1e-3),
                reason="not excited by these poses (a joint that barely moves, or too few poses)",
            )
        )
    return out


def _rank(sv: np.ndarray, rtol: float) -> int:
    """Singular values (descending) above rtol × the largest."""
    return int(np.sum(sv > rtol * sv[0])) if sv.size and sv[0] > 0 else 0


def identifiable_eigen(ata: np.ndarray, rtol: float = DEFAULT_RTOL):
    """Eigenvalues λ_p (descending) and orthonormal eigenvectors V_p (P, p) of a normal matrix
    ΦᵀΦ that span the identifiable subspace: √λ > rtol · √λ_max (the rank rule of ``solve``)."""
    lam, vecs = np.linalg.eigh(ata)
    lam, vecs = lam[::-1], vecs[:, ::-1]
    p = _rank(np.sqrt(np.clip(lam, 0, None)), rtol)
    return lam[:p].copy(), np.ascontiguousarray(vecs[:, :p])


def solve(
    robot: Robot,
    ne: NormalEquations,
    *,
    rtol: float = DEFAULT_RTOL,
    r_prior: np.ndarray | None = None,
) -> Fit:
    """Least-squares fit from accumulated normal equations (see the module docstring)."""
    if ne.n_poses == 0:
        raise SescidError("no poses to identify from")
    r0 = robot.sesc_vectors() if r_prior is None else np.asarray(r_prior, dtype=float)
    lam, vecs = np.linalg.eigh(ne.ata)
    lam, vecs = lam[::-1], vecs[:, ::-1]
    sv = np.sqrt(np.clip(lam, 0, None))
    p = _rank(sv, rtol)
    vp, lp = vecs[:, :p], lam[:p]
    x0 = r0.reshape(-1)
    x = x0 + vp @ ((vp.T @ (ne.atb - ne.ata @ x0)) / lp)
    rss = max(ne.yty - 2 * x @ ne.atb + x @ ne.ata @ x, 0.0)
    dof = ne.n_rows - p
    sigma_hat = math.sqrt(rss / dof) if dof > 0 else float("nan")
    cov = (vp / lp) @ vp.T * (sigma_hat**2 if dof > 0 else np.nan)
    labels = _label_columns(robot)
    r = x.reshape(-1, 3)
    min_poses = math.ceil(p / 2)
    notes = []
    if dof <= 0:
        notes.append(
            f"{ne.n_poses} poses give {ne.n_rows} equations for {p} identifiable combinations: "
            f"no residual left to estimate the noise (use ≥ {min_poses + 1} poses)"
        )
    fit = Fit(
        robot=robot,
        r=r,
        r_prior=r0.copy(),
        cov=cov,
        basis=vp,
        singular_values=sv,
        rank=p,
        n_poses=ne.n_poses,
        n_rows=ne.n_rows,
        sigma_hat=sigma_hat,
        rms=math.sqrt(rss / ne.n_rows),
        mae=float("nan"),
        rtol=rtol,
        base=_base_combinations(sv, vecs, p, labels, r, np.nan_to_num(cov)),
        unidentifiable=_unidentifiable(robot, vp, labels),
        notes=notes,
    )
    fit.notes.append(
        f"{len(fit.unidentifiable)} of {x.size} directions are not determined by the data; "
        "they are filled from the prior model (CoP predictions do not depend on them, "
        "CoM height partly does)"
    )
    return fit


def _check_enough(robot: Robot, n: int) -> None:
    # rank of the x/y regressor for generic poses: 3N minus the N structural null directions,
    # i.e. the dimension of the reduced coordinates
    p = robot.reduction.g.shape[0]
    need = math.ceil(p / 2)
    if n < need:
        raise SescidError(
            f"{n} poses are too few for least squares on {robot.name}: its {p} "
            f"identifiable combinations need at least {need} poses (2 equations each)"
        )


def identify(
    robot: Robot,
    q,
    cop,
    *,
    sigma=None,
    rtol: float = DEFAULT_RTOL,
    r_prior: np.ndarray | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> Fit:
    """Identify the SESC vectors from poses q (n, nq) [rad] and measured CoPs (n, 2) [m].

    ``sigma``: optional per-pose CoP standard errors (n,) or (n, 2) [m] → weighted least squares.
    ``r_prior``: SESC vectors that fill the undetermined directions (default: the URDF's).
    """
    q = as_poses(q, robot.nq)
    cop = check_cop(cop, q.shape[0])
    _check_enough(robot, q.shape[0])
    ne = accumulate(robot, [(q, cop, sigma)], progress=progress)
    fit = solve(robot, ne, rtol=rtol, r_prior=r_prior)
    if sigma is not None:
        fit.extra["weighted"] = True
        fit.notes.append(
            "weighted by the given CoP standard errors: sigma_hat is the dimensionless scale "
            "of the normalised residuals (≈ 1 when the standard errors are right)"
        )
    resid = cop - fit.predict_cop(q)
    fit.mae = float(np.mean(np.abs(resid)))
    fit.rms = float(np.sqrt(np.mean(resid**2)))
    return fit


def identify_stream(
    robot: Robot,
    chunks: Iterable[tuple],
    *,
    rtol: float = DEFAULT_RTOL,
    r_prior: np.ndarray | None = None,
) -> Fit:
    """Same fit as ``identify`` from an iterable of chunks ``(q, cop[, sigma])``.

    Φ is never stored: memory stays at one block whatever the number of poses. The residual
    MAE needs a second pass over the data and is left as nan; the RMS is exact.
    """
    ne = accumulate(robot, chunks)
    _check_enough(robot, ne.n_poses)
    return solve(robot, ne, rtol=rtol, r_prior=r_prior)
