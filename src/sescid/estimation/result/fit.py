"""The typed result of an identification: ``Fit`` and the records that methods attach to it.

A ``Fit`` holds the identified SESC vectors ``r`` (N, 3) [m], their covariance, the identifiable
subspace and its named base combinations, the unidentifiable directions with their reason, and
residual statistics. What a method adds beside that is a typed record, never a free-form dict:
``MapInfo`` (prior scale and noise, how they were chosen), ``CopOffset`` (estimated CoP bias),
``BodyInertials`` (physically consistent masses/CoMs), ``RobustInfo`` (Huber weights),
``CrossValidation``, ``JointNoiseEffect``, ``OnlineInfo``. The prose ``notes`` are generated from
those fields, so nothing reads prose to decide anything.

The records live in ``records``.

``method`` is one of ``METHODS`` ("ls", "map", "consistent"): the same words as the CLI's
``--method`` and the fit JSON. ``method_label`` adds the modifiers ("map+huber", "online-ls").
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal, cast, get_args

import numpy as np
from numpy.typing import ArrayLike

from sescid.base import G0
from sescid.errors import DataError
from sescid.estimation.result.payload_record import PayloadFit
from sescid.estimation.result.records import (
    REPEATED,
    BodyInertials,
    CopOffset,
    CrossValidation,
    JointNoise,
    JointNoiseEffect,
    KindFit,
    MapInfo,
    MethodChoice,
    NuisanceEstimate,
    OnlineInfo,
    RobustInfo,
    ScaleAnchor,
)
from sescid.kinematics import as_poses, regressor
from sescid.sesc import balance_tilt

if TYPE_CHECKING:  # pragma: no cover
    from sescid.robot import Robot

#: an estimation method, as named everywhere (CLI --method, Fit.method, fit JSON, docs)
Method = Literal["ls", "map", "consistent"]
METHODS: tuple[Method, ...] = get_args(Method)
#: what ``identify`` can be asked for: a method, or "auto" (the data and the model choose one)
MethodName = Literal["auto", Method]
METHOD_CHOICES: tuple[MethodName, ...] = get_args(MethodName)
#: why a direction of vec(r) is not identified (``Combination.kind``; "" for a base combination)
Unseen = Literal["", "support-vertical", "support-horizontal", "joint-axis", "not-excited"]
AXES = "xyz"


def _nan(x: float | None) -> float:
    return float("nan") if x is None else float(x)


@dataclass(frozen=True)
class Combination:
    """A named linear combination of SESC components: Σ coef · r[body][axis] (m).

    ``kind`` says why an unidentifiable direction is not seen (machine-readable, ``Unseen``;
    ``reason`` is the prose); "" for a base combination.
    """

    terms: list[tuple[str, str, float]]  #: (body, axis, coefficient)
    value: float = float("nan")  #: estimate, m
    std: float = float("nan")  #: standard error, m
    reason: str = ""
    kind: Unseen = ""

    def label(self, digits: int = 3) -> str:
        """``r[A].x - 0.5·r[B].y`` style text."""
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
        """JSON-ready dict (terms, label, value, std, reason, kind)."""
        return {
            "terms": [[b, a, c] for b, a, c in self.terms],
            "label": self.label(),
            "value": None if math.isnan(self.value) else self.value,
            "std": None if math.isnan(self.std) else self.std,
            "reason": self.reason,
            "kind": self.kind,
        }

    @classmethod
    def from_json(cls, d: dict) -> Combination:
        """The combination from its ``to_json`` dict."""
        return cls(
            terms=[(str(b), str(a), float(c)) for b, a, c in d["terms"]],
            value=_nan(d.get("value")),
            std=_nan(d.get("std")),
            reason=str(d.get("reason", "")),
            kind=cast(Unseen, str(d.get("kind", ""))),
        )


@dataclass(frozen=True)
class Fit:
    """An identified model: SESC vectors, their uncertainty and what the data could determine.

    Frozen: a method that refines a fit (MAP, robust weights, consistent masses) makes a new one
    (``dataclasses.replace``)."""

    robot: Robot
    r: np.ndarray  #: (N, 3) identified SESC vectors, m (undetermined directions from r_prior)
    r_prior: np.ndarray  #: (N, 3) the prior model's SESC vectors, m
    cov: np.ndarray  #: (3N, 3N) covariance of vec(r), m² (zero along undetermined directions)
    basis: np.ndarray  #: (3N, p) orthonormal basis of the identifiable subspace
    singular_values: np.ndarray  #: (3N,) √eig(ΦᵀWΦ), descending
    rank: int
    n_poses: int
    n_rows: int
    sigma_hat: float  #: residual standard deviation, m (dimensionless scale when weighted)
    rms: float  #: residual RMS per CoP component, m (nan when unknown)
    mae: float  #: mean absolute residual per CoP component, m (nan when unknown)
    rtol: float
    method: Method = "ls"
    base: tuple[Combination, ...] = ()
    unidentifiable: tuple[Combination, ...] = ()
    #: directions the data barely excite, taken from the prior (least squares) or left to it
    weak: tuple[Combination, ...] = ()
    weighted: bool = False  #: fitted with per-pose CoP standard errors (σ̂ is then a scale)
    sigma_dof: float | None = None  #: dof of σ̂ (None: n_rows − rank; inf: σ was given)
    map: MapInfo | None = None
    cop_offset: CopOffset | None = None
    scale: ScaleAnchor | None = None  #: homogeneous data: where the scale came from
    choice: MethodChoice | None = None  #: method "auto": what it chose and why
    #: stances pooled: the body parameters every stance shares (``estimation.pooled``)
    bodies: Any = None
    inertials: BodyInertials | None = None
    robust: RobustInfo | None = None
    online: OnlineInfo | None = None
    cv: CrossValidation | None = None
    joint_noise: JointNoiseEffect | None = None
    truth_cop_rmse: float | None = None  #: m, vs the noise-free CoP (simulated data)
    warnings: tuple[str, ...] = ()  #: data-quality warnings (stored, printed)
    kinds: tuple[KindFit, ...] = ()  #: per measurement kind: rows, noise, residuals
    nuisance: tuple[NuisanceEstimate, ...] = ()  #: sensor offsets, friction bands
    #: each torque sensor's noise level when it was estimated per joint (``torque_noise``)
    torque_noise: tuple[JointNoise, ...] = ()
    total_mass: float = float("nan")  #: kg: the scale of torque rows (M·r); nan without torques
    mass_given: bool = False  #: the total mass was weighed (else the model's)
    gravity_accel: float = G0  #: m/s², the magnitude of g behind torque rows
    #: a payload identified on a base model (``estimation.payload``): r and total_mass include it
    payload: PayloadFit | None = None

    # --- predictions ------------------------------------------------------------------
    def predict_cop(self, q: ArrayLike, gravity: ArrayLike | None = None) -> np.ndarray:
        """CoP (n, 2) in m at poses q (n, nq) [rad], under gravity (n, 3) when given."""
        return self.robot.cop(q, self.r, gravity)

    def predict_com(self, q: ArrayLike) -> np.ndarray:
        """CoM (n, 3) in m; its z partly comes from the prior (see ``com_z_from_prior``)."""
        return self.robot.com(q, self.r)

    def predict_torque(
        self,
        q: ArrayLike,
        joints=None,
        gravity: ArrayLike | None = None,
        reading: bool = False,
    ) -> np.ndarray:
        """Holding torques (n, J) [N·m] of ``joints`` (names; None: all) with the support fixed,
        for the fit's r and total mass; ``reading=True`` adds the estimated sensor offsets (what
        the robot's torque sensors would report, friction aside) and their gains."""
        mass = self.total_mass if math.isfinite(self.total_mass) else self.robot.total_mass
        names = self.robot.joint_names if joints is None else list(joints)
        tau = self.robot.torques(
            q, self.r, joints=names, gravity=gravity, total_mass=mass, g0=self.gravity_accel
        )
        if reading:
            est = {(e.what, e.name): e.value for e in self.nuisance if e.kind == "tau"}
            off = np.array([est.get(("offset", j), 0.0) for j in names])
            gain = np.array([est.get(("gain", j), 0.0) for j in names])
            tau = (tau + off) * (1.0 + gain)
        return tau

    def predict_balance(self, q: ArrayLike) -> np.ndarray:
        """(n,) tilt [rad] about the support line that balances a robot on a line at poses q
        (``balance_rows.balance_tilt``: the IMU's pitch for an axle along y)."""
        line = self._line()
        return balance_tilt(self.robot.tree, line, q, self.r)[0]

    def predict_balance_std(self, q: ArrayLike) -> np.ndarray:
        """(n,) standard error [rad] of ``predict_balance`` (first order, from ``cov``)."""
        std = balance_tilt(self.robot.tree, self._line(), q, self.r, self.cov)[1]
        assert std is not None
        return std

    def _line(self) -> np.ndarray:
        if self.robot.line is None:
            raise DataError(
                f"{self.robot.name}: the support '{self.robot.support}' is not a line (a wheel "
                "axle, an edge): no balance tilt to predict"
            )
        return self.robot.line

    def kind(self, name: str) -> KindFit | None:
        """The record of one measurement kind ("cop", "tau"), None when it had no rows."""
        for k in self.kinds:
            if k.kind == name:
                return k
        return None

    def torque_nuisance(self, what: str, joints) -> np.ndarray:
        """(J,) each joint's estimated torque ``what`` ("offset" N·m, "friction" N·m, "gain"):
        0 where none was estimated or the data do not determine it."""
        est: dict[tuple[str, str], float] = {
            (e.what, e.name): (e.value if e.determined else 0.0) for e in self.nuisance
            if e.kind == "tau"
        }  # fmt: skip
        return np.array([est.get((what, j), 0.0) for j in joints])

    def predict_std(self, q: ArrayLike, rows: tuple[int, ...] = (0, 1, 2)) -> np.ndarray:
        """Standard error (n, len(rows)) in m of the predicted CoM components ``rows``.

        Counts the uncertainty of the identified directions only; the prior-filled part of the
        CoM height is taken as exact here. An x/y row that the data do not determine (it leaves
        the subspace the data excite: too few distinct poses) is nan, "not determined", never 0
        (a MAP fit's prior determines every direction, unless it kept the CAD model for too few
        distinct poses: ``REPEATED``).
        """
        qq = as_poses(q, self.robot.nq)
        out = np.empty((qq.shape[0], len(rows)))
        prior_decides = self.map is not None and self.map.prior_scale_by != REPEATED
        xy = np.array([r in (0, 1) for r in rows]) & (not prior_decides)
        for s in range(0, qq.shape[0], 4096):
            phi = regressor(self.robot.tree, qq[s : s + 4096], rows)
            var = np.einsum("nri,ij,nrj->nr", phi, self.cov, phi)
            out[s : s + 4096] = np.sqrt(np.clip(var, 0, None))
            outside = phi - (phi @ self.basis) @ self.basis.T
            lost = np.linalg.norm(outside, axis=2) > 1e-6 * np.linalg.norm(phi, axis=2)
            out[s : s + 4096][lost & xy] = np.nan
        return out

    def com_z_from_prior(self, q: ArrayLike) -> np.ndarray:
        """(n,) part of the predicted CoM height (m) that comes from the prior model r_prior.

        The z row of the regressor has components outside the identifiable subspace; along
        those, r̂ equals r_prior, so this part of CoM_z is the prior's, not the data's.
        """
        _, outside = self._z_rows(q)
        return outside @ self.r_prior.reshape(-1)

    def com_z_prior_fraction(self, q: ArrayLike) -> np.ndarray:
        """(n,) fraction of the z regressor row's norm outside the identifiable subspace."""
        phi_z, outside = self._z_rows(q)
        return np.linalg.norm(outside, axis=1) / np.linalg.norm(phi_z, axis=1)

    def _z_rows(self, q: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """The z regressor rows (n, 3N) and their part outside the identifiable subspace."""
        qq = as_poses(q, self.robot.nq)
        phi_z = regressor(self.robot.tree, qq, (2,))[:, 0, :]
        return phi_z, phi_z - (phi_z @ self.basis) @ self.basis.T

    # --- summaries --------------------------------------------------------------------
    @property
    def method_label(self) -> str:
        """The method with its modifiers: "ls", "map+huber", "online-map", …"""
        label = f"online-{self.method}" if self.online is not None else self.method
        return f"{label}+huber" if self.robust is not None else label

    @property
    def residual_dof(self) -> float:
        """Degrees of freedom of σ̂ (inf when σ was given or none is left)."""
        dof = self.n_rows - self.rank if self.sigma_dof is None else self.sigma_dof
        return float(dof) if dof > 0 else math.inf

    @property
    def r_magnitudes(self) -> np.ndarray:
        """R_i = |r_i| (N,) in m (the paper's Fig. 3a)."""
        return np.linalg.norm(self.r, axis=1)

    @property
    def r_std(self) -> np.ndarray:
        """(N, 3) standard errors of r (m); 0 along directions filled from the prior."""
        return np.sqrt(np.clip(np.diag(self.cov), 0, None)).reshape(-1, 3)

    @property
    def cop_bias(self) -> np.ndarray:
        """(2,) estimated constant CoP offset (m); zeros when none was estimated."""
        return np.zeros(2) if self.cop_offset is None else np.asarray(self.cop_offset.value)
