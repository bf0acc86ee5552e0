"""The typed records a method attaches to a ``Fit`` (never a free-form dict): ``MapInfo``,
``CopOffset``, ``BodyInertials``, ``RobustInfo``, ``CrossValidation``, ``JointNoiseEffect``,
``OnlineInfo``, ``MethodChoice``, ``ScaleAnchor``, and per kind ``KindFit``, ``JointNoise``,
``NuisanceEstimate``."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from sescid.kinds import Kind

#: how a kind's noise level was set: estimated from the residuals, given, or not determined (no
#: degrees of freedom left)
NoiseSource = Literal["estimated", "given", "not determined"]
#: a nuisance parameter beside r: a sensor's offset, a torque's friction band, a torque gain
NuisanceWhat = Literal["offset", "friction", "gain"]
#: the shape of a MAP fit's CAD prior: each SESC component ±τ m, or each body's mass and first
#: moment ±τ relative to CAD
PriorShape = Literal["sesc", "bodies"]
METHOD_TITLES = {
    "ls": "least squares",
    "map": "MAP with a CAD prior",
    "consistent": "physically consistent masses",
}


#: ``MapInfo.prior_scale_by`` of a fit whose distinct poses leave no degrees of freedom
#: (``map.repeated_poses``): the prior's scale kept at its smallest, the CAD model as it is —
#: its error is not determined, and predictions the data do not see say so (``Fit.predict_std``)
REPEATED = "kept: too few distinct poses"


def json_ready(x: Any) -> Any:
    """JSON-ready copy: arrays → lists, non-finite floats → None."""
    if isinstance(x, np.ndarray):
        return json_ready(x.tolist())
    if isinstance(x, list | tuple):
        return [json_ready(v) for v in x]
    if isinstance(x, dict):
        return {k: json_ready(v) for k, v in x.items()}
    if isinstance(x, float | np.floating):
        return float(x) if math.isfinite(x) else None
    if isinstance(x, np.integer):
        return int(x)
    return x


@dataclass
class MapInfo:
    """How a MAP fit weighed the CAD prior N(r_prior, τ²) against the data (m)."""

    prior_scale: float  #: τ, m
    prior_scale_by: str  #: "given", "evidence" or "<k>-fold cv"
    noise: float  #: σ, m (a dimensionless scale for a weighted fit)
    noise_by: str  #: "given", "evidence" (a pad calibration: "per-session estimate")
    log_evidence: float
    effective_parameters: float
    cv_curve: list[list[float]] | None = None  #: [[τ/σ, held-out RMSE m], …] when chosen by CV
    at_lower_bound: bool = False  #: evidence largest at the smallest τ searched
    #: directions of vec(r) the prior decided: unseen by the data, or where the data carry less
    #: than half of the posterior information
    prior_decided: int = 0
    #: "sesc" (±τ m per SESC component) or "bodies" (±τ per body, relative)
    prior: PriorShape = "sesc"
    #: "bodies": the first moments' prior std per unit mass, m (τ times the prior's CoM scale)
    prior_com_std: float | None = None
    #: the largest share of the posterior information the prior holds in a direction the data
    #: see (nan: unknown, files of older versions)
    prior_share: float = float("nan")


@dataclass(frozen=True)
class MethodChoice:
    """What ``method="auto"`` chose and why (``Fit.choice``)."""

    chosen: Literal["ls", "map"]
    reason: str

    def note(self) -> str:
        """One line for the fit's summary."""
        return f"method auto chose {METHOD_TITLES[self.chosen]}: {self.reason}"


@dataclass(frozen=True)
class ScaleAnchor:
    """Where the scale of a fit to homogeneous data comes from (``estimation.anchor``).

    Balanced poses on a line or a point have every target 0: the data fix the directions and
    ratios of the first moments but not their scale, which is taken from the prior model
    (``by`` = "prior") or from a known CoM height (``by`` = "com_height")."""

    by: str  #: "prior" or "com_height"
    com_distance: float  #: m, the fit's CoM distance from the support at the zero pose
    prior_distance: float  #: m, the prior model's

    def note(self) -> str:
        """One line for the fit's summary."""
        src = "the prior model's" if self.by == "prior" else "the known CoM height given"
        return (
            "the data carry no scale (every target is the support itself: the model with all "
            "its mass at the support would meet them exactly): the CoM's distance from the "
            f"support, {self.com_distance * 1e3:.1f} mm at the zero pose, is {src}"
            + (
                " (give the known height: com_height / --com-height)"
                if self.by == "prior"
                else f" (the prior model's: {self.prior_distance * 1e3:.1f} mm)"
            )
        )


@dataclass
class CopOffset:
    """A constant CoP offset (sensor bias) estimated beside r: value and std (2,) in m."""

    value: np.ndarray
    std: np.ndarray


@dataclass
class BodyInertials:
    """Physically consistent body masses (kg) and CoMs (m, body frames) behind a fit's r."""

    masses: np.ndarray  #: (N,) kg
    coms: np.ndarray  #: (N, 3) m, sescid body frames
    coms_link: np.ndarray  #: (N, 3) m, each body's main model link frame
    box_lo: np.ndarray  #: (N, 3) m, CoM box used
    box_hi: np.ndarray  #: (N, 3) m
    box_source: list[str]
    total_mass: float  #: kg
    mass_floor: float  #: kg
    symmetric: bool
    com_scale: float  #: m
    fit_tol: float  #: m
    prior_std: float | None  #: relative CAD prior std (None: lexicographic)
    active_constraints: list[str]
    mirror_pairs: list[list[str]]
    source_method: str  #: method of the fit the masses were made from
    source_rms: float  #: m, CoP residual RMS of that fit
    cop_rss_increase: float  #: m², extra CoP residual sum of squares vs that fit
    solver_status: list[str] = field(default_factory=list)
    solver_iterations: list[int] = field(default_factory=list)
    solve_time: float = 0.0  #: s
    cad_masses: np.ndarray | None = None  #: (N,) kg, the model's
    grown_boxes: list[str] = field(default_factory=list)  #: bodies whose box was grown to CAD
    #: the fit's SESC vectors reproduced exactly (a MAP fit's, ``consistent.exact``)
    exact: bool = False
    #: bodies the data carry no information on: CAD's mass and CoM kept
    undetermined: list[str] = field(default_factory=list)
    #: what the step could not do as asked (CoMs outside their boxes, masses far from CAD)
    notes: list[str] = field(default_factory=list)

    def worst_mass_change(self) -> tuple[int, float] | None:
        """(body index, relative change) of the body whose mass moved most from CAD."""
        if self.cad_masses is None:
            return None
        cad = np.asarray(self.cad_masses)
        ok = cad > 0
        if not ok.any():
            return None
        rel = np.where(ok, np.abs(self.masses - cad) / np.where(ok, cad, 1.0), 0.0)
        i = int(np.argmax(rel))
        return i, float(rel[i])


@dataclass
class RobustInfo:
    """Huber IRLS: threshold, robust scale, iterations and the down-weighted poses."""

    k: float
    scale: float  #: robust noise scale, m (dimensionless with given standard errors)
    iterations: int
    downweighted: list[tuple[int, float]]  #: (pose index, weight), lowest weight first
    weighted_input: bool  #: standard errors were given (scale is then dimensionless)
    scales: dict[str, float] = field(default_factory=dict)  #: robust scale per kind


@dataclass
class CrossValidation:
    """k-fold cross-validated CoP error (m, or units of the given errors for weighted fits)."""

    k: int
    rmse: float  #: RMS of held-out measured − predicted CoP (includes the noise)
    rmse_folds: list[float]
    noise: float  #: pooled σ̂ of the training fits, in the same units as rmse
    model_rmse: float  #: √max(rmse² − σ̂², 0): the model's share of the held-out error
    kind: Kind = "cop"  #: the measurement kind scored: "cop" (m) or "tau" (N·m)


@dataclass
class JointNoiseEffect:
    """Monte-Carlo effect of joint-angle errors beside that of the CoP noise (all in m)."""

    joint_noise_rad: float
    draws: int
    r_std_joint: np.ndarray  #: (N, 3) spread of r over the draws
    cop_std_joint: float  #: RMS over reference poses of the CoP prediction spread
    cop_std_noise: float  #: the same from the CoP noise (fit.cov)
    share_joint: float  #: joint part of the prediction variance, var_j / (var_j + var_cop)


@dataclass(frozen=True)
class KindFit:
    """How one measurement kind fitted: its rows, noise and residuals (in its own unit)."""

    kind: Kind
    n_rows: int
    n_poses: int
    sigma: float  #: noise standard deviation (m, N·m; a dimensionless scale when weighted)
    sigma_by: NoiseSource
    dof: float  #: this kind's share of the residual degrees of freedom
    rms: float  #: residual RMS per row (nan when unknown)
    mae: float  #: mean absolute residual per row (nan when unknown)
    weighted: bool  #: rows weighted by the given standard errors
    unit: str  #: "m" or "N·m"


@dataclass(frozen=True)
class JointNoise:
    """One torque sensor's noise level under a per-joint noise model
    (``estimation.torque_noise``): σ_j in ``unit`` (N·m, or "1": a scale on the row's given
    standard errors), its residual degrees of freedom, its residual RMS in the same unit."""

    joint: str
    sigma: float
    dof: float  #: rows − own nuisance columns − its share of the parameters of r
    rms: float  #: residual RMS per row
    by: Literal["estimated", "pooled"]  #: pooled: too few degrees of freedom of its own
    rows: float
    #: its rows' share of the fit's parameters of vec(r) (the hat matrix's trace over them,
    #: its own offset and friction band excluded): near 0, the fit is decided elsewhere
    params: float = float("nan")
    unit: str = "N·m"


@dataclass(frozen=True)
class NuisanceEstimate:
    """A nuisance parameter's estimate (a sensor offset, a friction band): value and standard
    error in ``unit``; both nan when the data do not determine it (``reason`` says why)."""

    kind: Kind
    what: NuisanceWhat
    name: str  #: the axis of a CoP offset or the joint of a torque sensor
    unit: str
    value: float
    std: float
    determined: bool
    reason: str = ""

    @property
    def label(self) -> str:
        """``tau.offset[knee]`` style name."""
        return f"{self.kind}.{self.what}[{self.name}]"


@dataclass
class OnlineInfo:
    """Convergence history of the recursive estimator."""

    window: int
    tol: float
    converged_at: int | None
    cop_std: list[float]  #: predicted RMS CoP standard error after each update, m
    n_poses: list[int]
