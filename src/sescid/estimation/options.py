"""The typed options of ``identify``: one object per method family, their defaults the API's and the
CLI's alike (a test compares them)."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from sescid.errors import OptionError
from sescid.estimation.consistent import COM_SCALE, FIT_TOL
from sescid.estimation.consistent.prior import evidence_prior_std, least_squares_view
from sescid.estimation.fit import METHOD_CHOICES, Fit
from sescid.estimation.identifiability import DEFAULT_RTOL, check_rtol
from sescid.estimation.measurements import COP, KINDS, TORQUE
from sescid.estimation.robust import HUBER_K
from sescid.estimation.system import RowOptions
from sescid.sesc import STANDARD_GRAVITY


@dataclass(frozen=True)
class MapOptions:
    """MAP parameters: prior scale τ and noise σ (m; None = chosen by the data), how τ is
    chosen ("evidence" or "cv" with ``folds``), whether a constant CoP offset is fitted, and the
    prior's shape: "sesc" (each SESC component ±τ m), "bodies" (each body's mass ±τ and first
    moment ±τ·5 cm per unit mass, relative to CAD: τ is then a fraction) or "auto" ("bodies":
    closer to the truth than "sesc" for the CoP and for joint torques alike, in every case of
    docs/defaults.md)."""

    prior_scale: float | None = None
    noise: float | None = None
    select: str = "evidence"
    folds: int = 5
    bias: bool = False
    prior: str = "auto"


@dataclass(frozen=True)
class ConsistentOptions:
    """Consistent-mass parameters (see ``consistent_from_fit``): total mass kg (None: the
    identify options', else the model's), mass floor kg, left/right symmetry, CoM-box margin m,
    CAD prior (relative std), closest-to-CAD tuning (m), and per-body boxes {body: (lo, hi)} m.

    ``via``: "prior" — one QP, data + a CAD prior on masses/CoMs whose scale the data choose
    (evidence), CAD masses as the target so a weighed total goes where the data put it
    (controller-ready masses); "fit" — reproduce the fit first, then closest to CAD (follows the
    noise of a least-squares fit); "auto" (default) — "fit" for a MAP fit (it already weighs
    data against CAD), "prior" otherwise. With ``prior_std`` given, that scale is used."""

    total_mass: float | None = None
    mass_floor: float = 0.0
    symmetric: bool = False
    box_margin: float | None = None
    prior_std: float | None = None
    com_scale: float = COM_SCALE
    fit_tol: float = FIT_TOL
    boxes: dict[str, tuple] | None = None
    via: str = "auto"

    def kwargs(self) -> dict:
        """Keyword arguments of ``consistent_from_fit``."""
        out = dataclasses.asdict(self)
        del out["via"]
        return out

    def check(self) -> None:
        """OptionError for a value outside its range."""
        if self.via not in ("auto", "prior", "fit"):
            raise OptionError("via", f"must be 'auto', 'prior' or 'fit', got {self.via!r}")

    def path_for(self, fit: Fit) -> str:
        """The path, "prior" or "fit", that ``via`` means for this source fit."""
        if self.via != "auto":
            return self.via
        return "fit" if fit.method == "map" else "prior"

    def resolved(self, fit: Fit) -> tuple[Fit, dict]:
        """The fit and ``consistent_from_fit`` keywords this choice means for ``fit``."""
        kw = self.kwargs()
        if self.path_for(fit) == "prior" and self.prior_std is None:
            ls = least_squares_view(fit)
            tau, com_std = evidence_prior_std(ls, self.total_mass, self.com_scale)
            kw["prior_std"], kw["com_scale"] = tau, com_std / tau
            kw["spread"] = "data"
            return ls, kw
        return fit, kw


@dataclass(frozen=True)
class IdentifyOptions:
    """Everything ``identify`` can be told, with the defaults the CLI shows.

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
    these measurement kinds of the data ("cop", "tau"; None: all it has). Files only
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
    robust: bool | str = "auto"
    huber_k: float = HUBER_K
    seed: int = 0
    cv: int | None = None
    joint_noise: float | None = None
    mc_draws: int = 30
    online_step: int | None = None
    r_prior: np.ndarray | None = None
    tau_gains: bool = False
    gain_prior: float = 0.1
    kinds: tuple[str, ...] | None = None
    imu_link: str | None = None
    allow_outside_limits: bool = False
    com_height: float | None = None
    map: MapOptions = field(default_factory=MapOptions)
    consistent: ConsistentOptions = field(default_factory=ConsistentOptions)

    def with_overrides(self, **overrides: Any) -> IdentifyOptions:
        """A copy with fields replaced by keyword (None keeps a field; ``map_options=`` and
        ``consistent_options=`` name ``map`` and ``consistent``); OptionError for an unknown
        name."""
        renamed = {"map_options": "map", "consistent_options": "consistent"}
        changes = {renamed.get(k, k): v for k, v in overrides.items() if v is not None}
        unknown = set(changes) - {f.name for f in dataclasses.fields(IdentifyOptions)}
        if unknown:
            raise OptionError(sorted(unknown)[0], "is not an option of identify")
        return dataclasses.replace(self, **changes)

    def check(self, method: str) -> None:
        """OptionError for a value out of range or an option another method owns."""
        if method not in METHOD_CHOICES:
            raise OptionError(
                "method", f"must be one of {', '.join(METHOD_CHOICES)}, got {method!r}"
            )
        check_rtol(self.rtol)
        self.consistent.check()
        for name, value in (("cop_noise", self.cop_noise), ("tau_noise", self.tau_noise)):
            if value is not None and not (math.isfinite(value) and value > 0):
                raise OptionError(name, f"must be a positive noise level, got {value}")
        if not (math.isfinite(self.gravity_accel) and 1.0 <= self.gravity_accel <= 30.0):
            raise OptionError(
                "gravity_accel", f"must be |g| in m/s² (1–30), got {self.gravity_accel}"
            )
        if self.robust not in (True, False, "auto"):
            raise OptionError("robust", f"must be True, False or 'auto', got {self.robust!r}")
        if not (math.isfinite(self.huber_k) and self.huber_k > 0):
            raise OptionError("huber_k", f"must be > 0, got {self.huber_k}")
        if self.cv is not None and self.cv < 2:
            raise OptionError("cv", f"needs at least 2 folds, got {self.cv}")
        if self.joint_noise is not None and not (
            math.isfinite(self.joint_noise) and 0 < self.joint_noise <= math.pi / 2
        ):
            raise OptionError(
                "joint_noise", f"must be an angle in (0, π/2] rad, got {self.joint_noise}"
            )
        if self.mc_draws < 2:
            raise OptionError(
                "mc_draws", f"Monte Carlo needs at least 2 draws, got {self.mc_draws}"
            )
        if self.online_step is not None:
            self._check_online(method)
        if self.com_height is not None and not (
            math.isfinite(self.com_height) and 0 < self.com_height <= 10
        ):
            raise OptionError(
                "com_height", f"must be a distance in m (0–10), got {self.com_height}"
            )
        if self.kinds is not None and (not self.kinds or set(self.kinds) - set(KINDS)):
            raise OptionError("kinds", f"must name some of {', '.join(KINDS)}, got {self.kinds!r}")
        if not (math.isfinite(self.gain_prior) and 0 < self.gain_prior <= 1):
            raise OptionError(
                "gain_prior", f"must be a relative std in (0, 1], got {self.gain_prior}"
            )
        if method not in ("map", "auto") and self.map != MapOptions():
            raise OptionError("map_options", f"apply to method 'map' (or auto), not {method!r}")
        if method != "consistent" and self.consistent != ConsistentOptions():
            raise OptionError(
                "consistent_options", f"apply to method 'consistent' only, not {method!r}"
            )

    def _check_online(self, method: str) -> None:
        if self.online_step < 1:  # type: ignore[operator]
            raise OptionError("online_step", f"must be ≥ 1 pose, got {self.online_step}")
        if method not in ("ls", "map", "auto"):
            raise OptionError("online", f"the recursive fit supports ls or map, not {method}")
        if self.robust is True or self.map.bias:
            raise OptionError("online", "the recursive fit cannot be robust or fit a bias")
        if method == "map" and (self.map.prior_scale is None or self.map.noise is None):
            raise OptionError(
                "online",
                "a recursive MAP fit needs --prior-scale and --noise (m): its prior and noise",
            )

    def rows(self) -> RowOptions:
        """How rows are made from the data."""
        return RowOptions(
            weighted=self.weighted,
            total_mass=self.total_mass,
            cop_offset=self.map.bias,
            gravity_accel=self.gravity_accel,
        )

    def noise(self) -> dict[str, float]:
        """The kinds' given noise levels."""
        out = {}
        if self.cop_noise is not None:
            out[COP] = self.cop_noise
        if self.tau_noise is not None:
            out[TORQUE] = self.tau_noise
        return out
