"""The typed options of ``identify``: what every method shares (``IdentifyOptions``) and one
object per method (``AutoOptions``, ``LeastSquaresOptions``, ``MapOptions``,
``ConsistentOptions``), each naming its method by its type. Each object checks its own values
when it is made (``__post_init__``, also after ``dataclasses.replace``); ``method_options`` is
the one dispatch from a method's name to its options. Their defaults are the API's and the
CLI's alike (a test compares them).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any, ClassVar, Literal

import numpy as np

from sescid.base import G0, SEED_HELP, check_ranges, option
from sescid.errors import OptionError, check_choice
from sescid.estimation.result.fit import Fit, MethodName
from sescid.estimation.result.identifiability import DEFAULT_RTOL, check_rtol
from sescid.estimation.result.records import PriorShape
from sescid.estimation.solvers.consistent import COM_SCALE, FIT_TOL
from sescid.estimation.solvers.consistent.prior import evidence_prior_std, least_squares_view
from sescid.estimation.solvers.robust import HUBER_K
from sescid.estimation.solvers.torque_noise import TorqueNoiseModel
from sescid.estimation.sums.system import RowOptions
from sescid.kinds import COP, TORQUE, Kind

#: how MAP chooses its prior scale τ: by marginal likelihood, or by k-fold cross-validation
PriorSelect = Literal["evidence", "cv"]
#: the MAP prior's shape ("auto": "bodies" for data with joint torques, "sesc" otherwise)
PriorChoice = Literal["auto", PriorShape]
#: the consistent step's path (``ConsistentOptions.via``)
Via = Literal["auto", "prior", "fit"]
#: Huber IRLS: on, off, or "auto" (on for torques without an approach side whose residuals
#: show outliers)
Robust = bool | Literal["auto"]
#: m, the largest prior scale or noise a MAP fit accepts (1 m on a SESC component is already a
#: flat prior; a larger number is not in metres)
MAX_SCALE = 100.0
_SCALE = f"a positive number of metres ≤ {MAX_SCALE:g}"


@dataclass(frozen=True)
class LeastSquaresOptions:
    """Least squares ("ls"): directions the data do not determine come from the prior model
    (``IdentifyOptions.r_prior``). It has no options of its own: what it is told is shared by
    every method (``IdentifyOptions``)."""

    method: ClassVar[MethodName] = "ls"


@dataclass(frozen=True)
class MapOptions:
    """MAP ("map") parameters: prior scale τ and noise σ (None: chosen by the data), how τ is
    chosen (``select``, with ``folds`` for "cv"), whether a constant CoP offset is fitted
    (``bias``), and the prior's shape: "sesc" (each SESC component ±τ m), "bodies" (each body's
    mass ±τ and first moment ±τ·5 cm per unit mass, relative to CAD: τ is then a fraction) or
    "auto" ("bodies": closer to the truth than "sesc" for the CoP and for joint torques alike,
    in every case of docs/defaults.md)."""

    method: ClassVar[MethodName] = "map"

    prior_scale: float | None = option(
        None,
        "map: prior standard deviation of each SESC component [m] (default: evidence).",
        low=0, high=MAX_SCALE, low_open=True, what=_SCALE,
    )  # fmt: skip
    noise: float | None = option(
        None,
        "map/online: known noise scale [m for CoP data] (default: estimated).",
        low=0, high=MAX_SCALE, low_open=True, what=_SCALE,
    )  # fmt: skip
    select: PriorSelect = option(
        "evidence",
        "map: choose the prior scale by marginal likelihood or 5-fold cross-validation.",
        flag="--prior-select",
    )
    folds: int = option(
        5, "map: folds of the cross-validation that chooses τ.", low=2, what="at least 2 folds"
    )
    bias: bool = option(False, "map: estimate constant CoP offsets b_x, b_y [m].")
    prior: PriorChoice = option(
        "auto",
        "map: the CAD prior's shape: each SESC component ±τ m (sesc), or each body's mass ±τ "
        "and first moment ±τ·5 cm per unit mass (bodies, τ relative); auto: bodies for data "
        "with torques, sesc for the CoP alone.",
    )

    def __post_init__(self) -> None:
        check_ranges(self)
        check_choice("select", self.select, PriorSelect)
        check_choice("prior", self.prior, PriorChoice)
        if self.select == "cv" and self.prior_scale is None and self.bias:
            raise OptionError("bias", "choosing the prior scale by cv does not fit a bias")


@dataclass(frozen=True)
class ConsistentOptions:
    """Consistent-mass ("consistent") parameters (see ``consistent_from_fit``): total mass kg
    (None: the identify options', else the model's), mass floor kg, left/right symmetry, CoM-box
    margin m, CAD prior (relative std), closest-to-CAD tuning (m), and per-body boxes
    {body: (lo, hi)} m.

    ``via``: "prior" — one QP, data + a CAD prior on masses/CoMs whose scale the data choose
    (evidence), CAD masses as the target so a weighed total goes where the data put it
    (controller-ready masses); "fit" — reproduce the fit first, then closest to CAD (follows the
    noise of a least-squares fit); "auto" (default) — "fit" for a MAP fit (it already weighs
    data against CAD), "prior" otherwise. With ``prior_std`` given, that scale is used."""

    method: ClassVar[MethodName] = "consistent"

    total_mass: float | None = option(
        None, "consistent: weighed total mass [kg] (default: the model's)."
    )
    mass_floor: float = option(0.0, "consistent: lower bound on every body's mass [kg].")
    symmetric: bool = option(False, "consistent: mirrored bodies (*_R/*_L) equal.")
    box_margin: float | None = option(
        None, "consistent: grow the CoM boxes by this [m] (default 0, fallback boxes 0.02)."
    )
    prior_std: float | None = option(
        None,
        "consistent: trade data fit against a Gaussian prior on the relative deviation from "
        "CAD of this std (e.g. 0.05) instead of fitting the data first.",
        flag="--cad-std",
    )
    com_scale: float = COM_SCALE
    fit_tol: float = FIT_TOL
    boxes: dict[str, tuple] | None = None
    via: Via = option(
        "auto",
        "consistent: 'prior' weighs the data against a CAD prior on masses/CoMs whose scale the "
        "data choose (controller-ready; a weighed total mass goes where the data put it); 'fit' "
        "reproduces the fit first (least squares follows the noise); 'auto': 'fit' for a MAP "
        "fit, else 'prior'. --cad-std fixes the prior scale instead.",
    )

    def __post_init__(self) -> None:
        check_choice("via", self.via, Via)

    def kwargs(self) -> dict:
        """Keyword arguments of ``consistent_from_fit``."""
        out = dataclasses.asdict(self)
        del out["via"]
        return out

    def path_for(self, fit: Fit) -> Literal["prior", "fit"]:
        """The path, "prior" or "fit", that ``via`` means for this source fit."""
        if self.via != "auto":
            return self.via
        return "fit" if fit.method == "map" else "prior"

    def resolved(self, fit: Fit) -> tuple[Fit, dict]:
        """The fit and ``consistent_from_fit`` keywords this choice means for ``fit``; the
        total mass defaults to the one the fit was given (weighed), else the model's."""
        kw = self.kwargs()
        if kw["total_mass"] is None and fit.mass_given and math.isfinite(fit.total_mass):
            kw["total_mass"] = fit.total_mass
        if self.path_for(fit) == "prior" and self.prior_std is None:
            ls = least_squares_view(fit)
            tau, com_std = evidence_prior_std(ls, kw["total_mass"], self.com_scale)
            kw["prior_std"], kw["com_scale"] = tau, com_std / tau
            kw["spread"] = "data"
            return ls, kw
        return fit, kw


@dataclass(frozen=True)
class AutoOptions:
    """Method "auto" (``identify``'s default): least squares when the data determine every
    direction they see well, else MAP with ``map``'s settings (the CAD prior per body, its scale
    chosen by the data unless given); ``fit.choice`` says which and why."""

    method: ClassVar[MethodName] = "auto"

    map: MapOptions = field(default_factory=MapOptions)

    def resolved(self, chosen: Literal["ls", "map"]) -> LeastSquaresOptions | MapOptions:
        """The method "auto" runs once it has chosen (``MethodChoice.chosen``)."""
        return self.map if chosen == "map" else LeastSquaresOptions()


#: a method's options: the object names the method by its type
MethodOptions = LeastSquaresOptions | MapOptions | ConsistentOptions | AutoOptions
_METHOD_TYPES: tuple[type[MethodOptions], ...] = (
    AutoOptions,
    LeastSquaresOptions,
    MapOptions,
    ConsistentOptions,
)


def method_options(method: MethodName | MethodOptions) -> MethodOptions:
    """The one dispatch of ``identify``'s ``method``: a name ("auto", "ls", "map",
    "consistent") gives that method with its default options; an options object is its own
    method."""
    if isinstance(method, _METHOD_TYPES):
        return method
    check_choice("method", method, MethodName)
    return next(t for t in _METHOD_TYPES if t.method == method)()


def map_settings(method: MethodOptions) -> MapOptions | None:
    """The MAP settings a method fits with (MAP's own, or those "auto" would use), else None."""
    if isinstance(method, MapOptions):
        return method
    return method.map if isinstance(method, AutoOptions) else None


@dataclass(frozen=True)
class IdentifyOptions:
    """What every method of ``identify`` is told: each field's help says what it means (the
    CLI's flags are these fields). Not on the command line: ``huber_k``, the Huber threshold;
    ``joint_noise`` [rad] (the CLI takes degrees); ``online_step`` (None: not online);
    ``r_prior`` (N, 3) [m], SESC vectors that fill what the data do not determine and centre
    the MAP prior (None: the model's); ``kinds`` (None: every kind the data have). ``imu_link``
    and ``allow_outside_limits`` apply to files (``sescid.identify`` on paths).
    """

    rtol: float = option(
        DEFAULT_RTOL, "Rank tolerance on singular values, relative to the largest (0 < rtol < 1)."
    )
    weighted: bool = option(
        False, "Weight rows by their standard errors (cop_se_x/cop_se_y, tau_se_<joint>)."
    )
    cop_noise: float | None = option(
        None,
        "Known CoP noise standard deviation [m] (default: estimated from the data).",
        low=0, low_open=True, what="a positive noise level",
    )  # fmt: skip
    tau_noise: float | None = option(
        None,
        "Known joint-torque noise standard deviation [N·m], one level shared by every joint "
        "(default: estimated per joint, see --tau-noise-model).",
        low=0, low_open=True, what="a positive noise level",
    )  # fmt: skip
    tau_noise_model: TorqueNoiseModel = option(
        "joint",
        "Joint-torque noise: one level per joint, estimated from its own residuals by a few "
        "reweighting passes (joint; a scale on tau_se_<joint> with --weighted), or one level "
        "shared by every joint (shared).",
    )
    #: the torque rows weighted by their tau_se columns (None: as ``weighted``): set by the
    #: per-joint noise model on the data it rescales, not a flag
    tau_weighted: bool | None = None
    total_mass: float | None = option(
        None,
        "Weighed total mass [kg]: the scale of the joint-torque rows and of the consistent "
        "masses (default: the model's, with a warning when torques are fitted).",
    )
    gravity_accel: float = option(
        G0, "|g| behind the torque rows [m/s²] (local gravity).",
        low=1, high=30, what="|g| in m/s² (1–30)",
    )  # fmt: skip
    allow_exact: bool = option(
        False,
        "Fit even when no degrees of freedom are left (σ̂ and standard errors: not determined).",
    )
    robust: Robust = option(
        "auto",
        "Huber IRLS, naming the down-weighted poses (default: on for torques without an "
        "approach column whose residuals show outliers, each joint against its own scale; off "
        "otherwise).",
    )
    huber_k: float = option(HUBER_K, "Huber threshold [σ].", low=0, low_open=True)
    seed: int = option(0, SEED_HELP, low=0)
    cv: int | None = option(None, "Print the k-fold cross-validated error.", low=2)
    joint_noise: float | None = option(
        None,
        "Monte-Carlo effect of joint-angle errors of this standard deviation [rad].",
        low=0, high=math.pi / 2, low_open=True, what="an angle in (0, π/2] rad",
    )  # fmt: skip
    mc_draws: int = option(30, "MC draws.", low=2)
    online_step: int | None = option(None, "Poses per online update.", low=1)
    r_prior: np.ndarray | None = None
    tau_gains: bool = option(
        False,
        "Also estimate a gain error per torque sensor (only their ratios come from the data).",
    )
    gain_prior: float = option(
        0.1, "Prior std of each torque gain error (relative), with --tau-gains.",
        low=0, high=1, low_open=True, what="a relative std in (0, 1]",
    )  # fmt: skip
    kinds: tuple[Kind, ...] | None = None
    imu_link: str | None = option(
        None,
        "Link carrying the IMU of the imu_roll/imu_pitch columns; they give the gravity "
        "direction when there are no grav_x/y/z columns (default: the profile's).",
    )
    allow_outside_limits: bool = option(
        False,
        "Accept poses outside the model's joint limits (a warning stored in the fit); "
        "simulated data (cop_x_true columns) get the warning without the flag.",
    )
    com_height: float | None = option(
        None,
        "Balance data (a robot on a line) carry no scale: the CoM's known distance from the "
        "support line at the zero pose [m] (default: the model's).",
        low=0, high=10, low_open=True, what="a distance in m (0–10)",
    )  # fmt: skip

    def __post_init__(self) -> None:
        check_rtol(self.rtol)
        check_ranges(self)
        check_choice("robust", self.robust, Robust)
        check_choice("tau_noise_model", self.tau_noise_model, TorqueNoiseModel)
        if self.kinds is not None:
            if not self.kinds:
                raise OptionError("kinds", "must name some measurement kinds, got none")
            for k in self.kinds:
                check_choice("kinds", k, Kind)

    def with_overrides(self, **overrides: Any) -> IdentifyOptions:
        """A copy with fields replaced by keyword (None keeps a field; the copy checks its
        values); OptionError for a name that is not a field."""
        changes = {k: v for k, v in overrides.items() if v is not None}
        unknown = set(changes) - {f.name for f in dataclasses.fields(IdentifyOptions)}
        if unknown:
            raise OptionError(sorted(unknown)[0], "is not an option of identify")
        return dataclasses.replace(self, **changes)

    def rows(self, method: MethodOptions) -> RowOptions:
        """How rows are made from the data (a CoP offset column for MAP with ``bias``)."""
        settings = map_settings(method)
        return RowOptions(
            weighted=self.weighted,
            total_mass=self.total_mass,
            cop_offset=settings is not None and settings.bias,
            gravity_accel=self.gravity_accel,
            tau_weighted=self.tau_weighted,
        )

    def noise(self) -> dict[Kind, float]:
        """The kinds' given noise levels."""
        out: dict[Kind, float] = {}
        if self.cop_noise is not None:
            out[COP] = self.cop_noise
        if self.tau_noise is not None:
            out[TORQUE] = self.tau_noise
        return out
