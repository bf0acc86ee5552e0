"""Estimation: from static poses and what was measured there (CoP, joint torques) to the SESC
vectors, sensor offsets, their uncertainty, and physical masses.

- ``identify`` — the one entry: any mix of measurement kinds (``Measurements``) and sources,
  ``method`` = "ls" | "map" | "consistent", options in ``IdentifyOptions`` (robust, weights,
  noise, total mass, cross-validation, joint-noise Monte Carlo, online);
  ``to_consistent`` — masses/CoMs for an existing fit; ``OnlineEstimator`` — pose by pose;
- ``Fit`` (frozen) and its typed records; ``save_fit`` / ``load_fit``;
- identifiability (the rank rule, ``min_poses``), validation (intervals, error against a known
  truth), checks at the data boundary; ``accumulate`` (CoP normal equations, for planning).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from sescid.base.lazy import lazy_exports

if TYPE_CHECKING:  # pragma: no cover - for type checkers; at run time: _EXPORTS
    from sescid.estimation.api import identify, to_consistent
    from sescid.estimation.cad_check import cad_violations
    from sescid.estimation.checks import check_total_mass, fit_warnings, outside_limits
    from sescid.estimation.consistent import body_boxes, fit_inertials
    from sescid.estimation.fit import (
        METHOD_CHOICES,
        METHODS,
        BodyInertials,
        Combination,
        CopOffset,
        CrossValidation,
        Fit,
        JointNoiseEffect,
        KindFit,
        MapInfo,
        NuisanceEstimate,
        OnlineInfo,
        RobustInfo,
    )
    from sescid.estimation.fit_json import MODEL_CHANGED, load_fit, save_fit
    from sescid.estimation.identifiability import (
        DEFAULT_RTOL,
        identifiable_eigen,
        min_poses,
        structural_rank,
    )
    from sescid.estimation.measurements import KINDS, Measurements
    from sescid.estimation.normal_equations import NormalEquations, accumulate
    from sescid.estimation.online import OnlineEstimator
    from sescid.estimation.options import ConsistentOptions, IdentifyOptions, MapOptions
    from sescid.estimation.pooled import BodyFit, StanceRank, for_support
    from sescid.estimation.validation import (
        Interval,
        balance_interval,
        com_interval,
        cop_interval,
        perturbed_sesc,
        truth_error,
    )

__all__ = [
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
    "JointNoiseEffect",
    "KINDS",
    "KindFit",
    "METHOD_CHOICES",
    "METHODS",
    "MapInfo",
    "MapOptions",
    "Measurements",
    "NormalEquations",
    "NuisanceEstimate",
    "OnlineEstimator",
    "OnlineInfo",
    "RobustInfo",
    "StanceRank",
    "accumulate",
    "body_boxes",
    "cad_violations",
    "check_total_mass",
    "balance_interval",
    "com_interval",
    "cop_interval",
    "fit_inertials",
    "fit_warnings",
    "for_support",
    "identifiable_eigen",
    "identify",
    "MODEL_CHANGED",
    "load_fit",
    "min_poses",
    "outside_limits",
    "perturbed_sesc",
    "save_fit",
    "structural_rank",
    "to_consistent",
    "truth_error",
]

#: public name → the module that defines it, imported on first use (``base.lazy``)
_EXPORTS = {
    "BodyInertials": "sescid.estimation.fit",
    "Combination": "sescid.estimation.fit",
    "ConsistentOptions": "sescid.estimation.options",
    "CopOffset": "sescid.estimation.fit",
    "CrossValidation": "sescid.estimation.fit",
    "DEFAULT_RTOL": "sescid.estimation.identifiability",
    "Fit": "sescid.estimation.fit",
    "IdentifyOptions": "sescid.estimation.options",
    "Interval": "sescid.estimation.validation",
    "JointNoiseEffect": "sescid.estimation.fit",
    "KINDS": "sescid.estimation.measurements",
    "KindFit": "sescid.estimation.fit",
    "METHOD_CHOICES": "sescid.estimation.fit",
    "METHODS": "sescid.estimation.fit",
    "MODEL_CHANGED": "sescid.estimation.fit_json",
    "MapInfo": "sescid.estimation.fit",
    "MapOptions": "sescid.estimation.options",
    "Measurements": "sescid.estimation.measurements",
    "NormalEquations": "sescid.estimation.normal_equations",
    "NuisanceEstimate": "sescid.estimation.fit",
    "OnlineEstimator": "sescid.estimation.online",
    "OnlineInfo": "sescid.estimation.fit",
    "RobustInfo": "sescid.estimation.fit",
    "BodyFit": "sescid.estimation.pooled",
    "StanceRank": "sescid.estimation.pooled",
    "for_support": "sescid.estimation.pooled",
    "accumulate": "sescid.estimation.normal_equations",
    "body_boxes": "sescid.estimation.consistent",
    "cad_violations": "sescid.estimation.cad_check",
    "check_total_mass": "sescid.estimation.checks",
    "balance_interval": "sescid.estimation.validation",
    "com_interval": "sescid.estimation.validation",
    "cop_interval": "sescid.estimation.validation",
    "fit_inertials": "sescid.estimation.consistent",
    "fit_warnings": "sescid.estimation.checks",
    "identifiable_eigen": "sescid.estimation.identifiability",
    "identify": "sescid.estimation.api",
    "load_fit": "sescid.estimation.fit_json",
    "min_poses": "sescid.estimation.identifiability",
    "outside_limits": "sescid.estimation.checks",
    "perturbed_sesc": "sescid.estimation.validation",
    "save_fit": "sescid.estimation.fit_json",
    "structural_rank": "sescid.estimation.identifiability",
    "to_consistent": "sescid.estimation.api",
    "truth_error": "sescid.estimation.validation",
}
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
