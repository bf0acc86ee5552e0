"""Estimation: from static poses and what was measured there (CoP, joint torques) to the SESC
vectors, sensor offsets, their uncertainty, and physical masses.

- ``fit_measurements`` — the estimation behind ``sescid.identify``: any mix of measurement
  kinds (``Measurements``) and sources; ``method`` = "auto" | "ls" | "map" | "consistent"
  (``MethodName``) or that method's options (``AutoOptions``, ``LeastSquaresOptions``,
  ``MapOptions``, ``ConsistentOptions``),
  what every method shares in ``IdentifyOptions`` (robust, weights, noise, total mass,
  cross-validation, joint-noise Monte Carlo, online); ``to_consistent`` — masses/CoMs for an
  existing fit; ``OnlineEstimator`` — pose by pose;
- ``Fit`` (frozen) and its typed records; ``save_fit`` / ``load_fit``;
- identifiability (the rank rule, ``min_poses``), validation (intervals, error against a known
  truth), checks at the data boundary; ``accumulate`` (CoP normal equations from arrays, by
  the one accumulator ``identify`` uses: for planning and the online estimator).
"""

from sescid.estimation.data.checks import (
    COP_ON_TRUNK,
    check_com_height,
    check_total_mass,
    fit_warnings,
    outside_limits,
)
from sescid.estimation.data.measurements import Measurements
from sescid.estimation.result.cad_check import cad_violations
from sescid.estimation.result.fit import (
    METHOD_CHOICES,
    METHODS,
    Combination,
    Fit,
    Method,
    MethodName,
)
from sescid.estimation.result.fit_json import MODEL_CHANGED, OLD_FORMAT, load_fit, save_fit
from sescid.estimation.result.identifiability import (
    DEFAULT_RTOL,
    identifiable_eigen,
    min_poses,
    structural_rank,
)
from sescid.estimation.result.notes import fit_notes
from sescid.estimation.result.payload_record import PayloadFit, PayloadKind
from sescid.estimation.result.records import (
    BodyInertials,
    CopOffset,
    CrossValidation,
    JointNoise,
    JointNoiseEffect,
    KindFit,
    MapInfo,
    NuisanceEstimate,
    OnlineInfo,
    RobustInfo,
)
from sescid.estimation.result.summary import fit_summary
from sescid.estimation.result.validation import (
    Interval,
    balance_interval,
    com_interval,
    cop_interval,
    perturbed_sesc,
    truth_error,
)
from sescid.estimation.solvers.api import fit_measurements, to_consistent
from sescid.estimation.solvers.consistent import body_boxes, fit_inertials
from sescid.estimation.solvers.online import OnlineEstimator
from sescid.estimation.solvers.options import (
    AutoOptions,
    ConsistentOptions,
    IdentifyOptions,
    LeastSquaresOptions,
    MapOptions,
    MethodOptions,
    PriorChoice,
    PriorSelect,
    Robust,
    Via,
    method_options,
)
from sescid.estimation.solvers.payload import PayloadOptions, check_base, check_payload, payload_fit
from sescid.estimation.sums.normal_equations import NormalEquations
from sescid.estimation.sums.pooled import BodyFit, StanceRank, for_support
from sescid.estimation.sums.system import accumulate
from sescid.kinds import KINDS, Kind

__all__ = [
    "AutoOptions",
    "BodyFit",
    "BodyInertials",
    "Combination",
    "ConsistentOptions",
    "CopOffset",
    "CrossValidation",
    "DEFAULT_RTOL",
    "Fit",
    "IdentifyOptions",
    "Interval",
    "LeastSquaresOptions",
    "JointNoise",
    "JointNoiseEffect",
    "KINDS",
    "Kind",
    "KindFit",
    "METHOD_CHOICES",
    "METHODS",
    "MapInfo",
    "MapOptions",
    "Method",
    "MethodName",
    "MethodOptions",
    "Measurements",
    "NormalEquations",
    "NuisanceEstimate",
    "PriorChoice",
    "PriorSelect",
    "OnlineEstimator",
    "OnlineInfo",
    "PayloadFit",
    "PayloadKind",
    "PayloadOptions",
    "Robust",
    "RobustInfo",
    "StanceRank",
    "Via",
    "accumulate",
    "body_boxes",
    "cad_violations",
    "check_com_height",
    "check_total_mass",
    "balance_interval",
    "com_interval",
    "cop_interval",
    "fit_inertials",
    "fit_warnings",
    "for_support",
    "identifiable_eigen",
    "fit_measurements",
    "fit_notes",
    "fit_summary",
    "MODEL_CHANGED",
    "OLD_FORMAT",
    "COP_ON_TRUNK",
    "load_fit",
    "method_options",
    "min_poses",
    "outside_limits",
    "payload_fit",
    "check_base",
    "check_payload",
    "perturbed_sesc",
    "save_fit",
    "structural_rank",
    "to_consistent",
    "truth_error",
]
