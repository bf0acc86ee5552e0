"""The calibration's inputs (sessions of per-pose pad readings), options and results."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from sescid.base import check_ranges, option
from sescid.estimation.result.fit import Fit
from sescid.estimation.result.identifiability import DEFAULT_RTOL, check_rtol

#: default prior standard deviations: relative gain, offset (N)
GAIN_PRIOR = 0.2
OFFSET_PRIOR = 0.2
#: starting noise levels of the iteration: force rows N, moment rows m
START_NOISE_FORCE = 0.5
START_NOISE_COP = 0.001
#: smallest estimated noise levels (resolution: 1 mN counts; 1 µm), N and m
NOISE_FLOOR_FORCE = 1e-3
NOISE_FLOOR_COP = 1e-6

#: a pad parameter: a sensor set's gain, or a session's offset
ParameterKind = Literal["gain", "offset"]
#: why a sensor direction is not determined (``SensorDirection.kind``; the package docstring)
SensorUnseen = Literal[
    "unloaded-foot", "offset-twist", "support-confounded", "scale", "not-excited"
]
UNLOADED_FOOT: SensorUnseen = "unloaded-foot"
OFFSET_TWIST: SensorUnseen = "offset-twist"
SUPPORT_CONFOUNDED: SensorUnseen = "support-confounded"
SCALE: SensorUnseen = "scale"
PAD_NOT_EXCITED: SensorUnseen = "not-excited"


@dataclass(frozen=True)
class CalibrationOptions:
    """How ``calibrate_sensors`` weighs the data against the priors (SI units)."""

    total_mass: float | None = option(
        None,
        "Weighed mass of the robot [kg]: fixes the gains' scale (default: the model's, "
        "reported as unidentifiable).",
    )
    prior_scale: float | None = option(
        None, "SESC prior τ [m] (default: evidence).", low=0, low_open=True
    )
    gain_prior: float = option(
        GAIN_PRIOR, "Prior std of each gain (relative).", low=0, low_open=True
    )
    offset_prior: float = option(
        OFFSET_PRIOR,
        "Prior std of each offset [N]; the offset twist comes from it.",
        low=0, low_open=True,
    )  # fmt: skip
    rtol: float = DEFAULT_RTOL  #: rank tolerance of the identifiability analysis
    max_iter: int = option(30, "Noise-level iterations at most.", low=1)
    tol: float = option(
        1e-4, "Convergence of the noise levels (largest change of log σ²).", low=0, low_open=True
    )

    def check(self) -> None:
        """OptionError naming the first setting outside its range."""
        check_rtol(self.rtol)
        check_ranges(self)


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

    kind: ParameterKind
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
    kind: SensorUnseen
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
    noise_by: Literal["given", "estimated"]
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
    total_mass_by: Literal["given", "model"]
    prior_scale: float  #: τ of the SESC prior, m
    prior_scale_by: Literal["given", "evidence"]
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
