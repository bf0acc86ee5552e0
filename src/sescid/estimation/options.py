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

from sescid.errors import OptionError, check_choice
from sescid.estimation.consistent import COM_SCALE, FIT_TOL
from sescid.estimation.consistent.prior import evidence_prior_std, least_squares_view
from sescid.estimation.fit import Fit, MethodName, PriorShape
from sescid.estimation.identifiability import DEFAULT_RTOL, check_rtol
from sescid.estimation.measurements import COP, TORQUE, Kind
from sescid.estimation.robust import HUBER_K
from sescid.estimation.system import RowOptions
from sescid.sesc import STANDARD_GRAVITY

#: how MAP chooses its prior scale τ: by marginal likelihood, or by k-fold cross-validation
PriorSelect = Literal["evidence", "cv"]
#: the MAP prior's shape ("auto": "bodies" for data with joint torques, "sesc" otherwise)
PriorChoice = Literal["auto", PriorShape]
#: the consistent step's path (``ConsistentOptions.via``)
Via = Literal["auto", "prior", "fit"]
#: Huber IRLS: on, off, or "auto" (on for torques without an approach side)
Robust = bool | Literal["auto"]
#: m, the largest prior scale or noise a MAP fit accepts (1 m on a SESC component is already a
#: flat prior; a larger number is not in metres)
MAX_SCALE = 100.0


def _positive(name: str, value: float | None, what: str, upper: float = math.inf) -> None:
    """OptionError ("must be <what>") unless ``value`` is None or a finite number in
    (0, upper]."""
    if value is not None and not (math.isfinite(value) and 0 < value <= upper):
        raise OptionError(name, f"must be {what}, got {value}")


@dataclass(frozen=True)
class LeastSquaresOptions:
    """Least squares ("ls"): directions the data do not determine come from the prior model
    (``IdentifyOptions.r_prior``). It has no options of its own: what it is told is shared by
    every method (``IdentifyOptions``)."""

    method: ClassVar[MethodName] = "ls"


@dataclass(frozen=True)
class MapOptions:
    """MAP ("map") parameters: prior scale τ and noise σ (m; None = chosen by the data, each ≤
    ``MAX_SCALE``), how τ is chosen (``select``, with ``folds`` for "cv"), whether a constant
    CoP offset is fitted (``bias``), and the prior's shape: "sesc" (each SESC component ±τ m),
    "bodies" (each body's mass ±τ and first moment ±τ·5 cm per unit mass, relative to CAD: τ is
    then a fraction) or "auto" ("bodies": closer to the truth than "sesc" for the CoP and for
    joint torques alike, in every case of docs/defaults.md)."""

    method: ClassVar[MethodName] = "map"

    prior_scale: float | None = None
    noise: float | None = None
    select: PriorSelect = "evidence"
    folds: int = 5
    bias: bool = False
    prior: PriorChoice = "auto"

    def __post_init__(self) -> None:
        what = f"a positive number of metres ≤ {MAX_SCALE:g}"
        _positive("prior_scale", self.prior_scale, what, MAX_SCALE)
        _positive("noise", self.noise, what, MAX_SCALE)
        check_choice("select", self.select, PriorSelect)
        check_choice("prior", self.prior, PriorChoice)
        if self.folds < 2:
            raise OptionError("folds", f"cross-validation needs at least 2 folds, got {self.folds}")
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

    total_mass: float | None = None
    mass_floor: float = 0.0
    symmetric: bool = False
    box_margin: float | None = None
    prior_std: float | None = None
    com_scale: float = COM_SCALE
    fit_tol: float = FIT_TOL
    boxes: dict[str, tuple] | None = None
    via: Via = "auto"

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
    """What every method of ``identify`` is told, with the defaults the CLI shows.

    ``rtol``: rank tolerance; ``weighted``: weigh rows by the data's standard-error columns;
    ``cop_noise`` [m] / ``tau_noise`` [N·m]: known noise of a kind (None: estimated);
    ``total_mass`` [kg]: weighed mass, the scale of torque rows (None: the model's, with a
    warning when torques are fitted) and of the consistent masses; ``gravity_accel`` [m/s²]:
    |g| behind torque rows; ``allow_exact``: fit even with no residual degrees of freedom (σ̂
    and every standard error are then "not determined"); ``robust``: Huber IRLS ("auto": on for
    torques without an approach side, whose static friction acts as bounded errors);
    ``huber_k``: its threshold in σ; ``seed``: for cross-validation folds and Monte Carlo;
    ``cv``: also score the method by k-fold cross-validation (``fit.cv``); ``joint_noise``
    [rad]: also propagate joint-angle errors of this std by ``mc_draws`` refits
    (``fit.joint_noise``); ``online_step``: fit recursively, this many poses per update
    (``fit.online`` keeps the convergence history; ls, or map with prior scale and noise);
    ``r_prior`` (N, 3) [m]: SESC vectors that fill what the data do not determine and centre
    the MAP prior (None: the model's); ``tau_gains``: also a gain error per torque sensor, with
    a prior N(0, ``gain_prior``²) (only their ratios come from the data); ``kinds``: use only
    these measurement kinds of the data (``Kind``; None: all it has). Files only
    (``sescid.identify`` on paths): ``imu_link``, the link whose ``imu_roll``/``imu_pitch``
    columns give gravity (None: the profile's); ``allow_outside_limits``, accept poses outside
    the model's joint limits with a warning (else an error names the first). ``com_height``
    [m]: for balance data, which carry no scale (``estimation.anchor``), the CoM's known
    distance from the support (its line) at the zero pose (None: the prior model's).
    """

    rtol: float = DEFAULT_RTOL
    weighted: bool = False
    cop_noise: float | None = None
    tau_noise: float | None = None
    total_mass: float | None = None
    gravity_accel: float = STANDARD_GRAVITY
    allow_exact: bool = False
    robust: Robust = "auto"
    huber_k: float = HUBER_K
    seed: int = 0
    cv: int | None = None
    joint_noise: float | None = None
    mc_draws: int = 30
    online_step: int | None = None
    r_prior: np.ndarray | None = None
    tau_gains: bool = False
    gain_prior: float = 0.1
    kinds: tuple[Kind, ...] | None = None
    imu_link: str | None = None
    allow_outside_limits: bool = False
    com_height: float | None = None

    def __post_init__(self) -> None:
        check_rtol(self.rtol)
        _positive("cop_noise", self.cop_noise, "a positive noise level")
        _positive("tau_noise", self.tau_noise, "a positive noise level")
        if not (math.isfinite(self.gravity_accel) and 1.0 <= self.gravity_accel <= 30.0):
            raise OptionError(
                "gravity_accel", f"must be |g| in m/s² (1–30), got {self.gravity_accel}"
            )
        check_choice("robust", self.robust, Robust)
        _positive("huber_k", self.huber_k, "> 0 (a threshold in σ)")
        if self.cv is not None and self.cv < 2:
            raise OptionError("cv", f"needs at least 2 folds, got {self.cv}")
        _positive("joint_noise", self.joint_noise, "an angle in (0, π/2] rad", math.pi / 2)
        if self.mc_draws < 2:
            raise OptionError(
                "mc_draws", f"Monte Carlo needs at least 2 draws, got {self.mc_draws}"
            )
        if self.online_step is not None and self.online_step < 1:
            raise OptionError("online_step", f"must be ≥ 1 pose, got {self.online_step}")
        if self.com_height is not None and not (
            math.isfinite(self.com_height) and 0 < self.com_height <= 10
        ):
            raise OptionError(
                "com_height", f"must be a distance in m (0–10), got {self.com_height}"
            )
        if self.kinds is not None:
            if not self.kinds:
                raise OptionError("kinds", "must name some measurement kinds, got none")
            for k in self.kinds:
                check_choice("kinds", k, Kind)
        _positive("gain_prior", self.gain_prior, "a relative std in (0, 1]", 1.0)

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
        )

    def noise(self) -> dict[Kind, float]:
        """The kinds' given noise levels."""
        out: dict[Kind, float] = {}
        if self.cop_noise is not None:
            out[COP] = self.cop_noise
        if self.tau_noise is not None:
            out[TORQUE] = self.tau_noise
        return out
