"""Estimation: from poses and CoPs to SESC vectors, their uncertainty and physical masses.

- ``identify`` (one entry, ``method`` = "ls" | "map" | "consistent", ``robust=True`` for Huber),
  ``identify_ls`` / ``identify_map`` / ``identify_consistent``, ``identify_stream`` (chunks),
  ``identify_chunks`` (a streamed file's chunks, with MAE),
  ``to_consistent`` (masses/CoMs from an existing fit), ``OnlineEstimator`` (pose by pose);
- ``Fit`` and its typed records; ``save_fit`` / ``load_fit``;
- identifiability (the rank rule, ``min_poses``), validation (intervals, cross-validation,
  error against a known truth), the joint-noise Monte Carlo.
"""

from __future__ import annotations

from sescid.estimation.api import (
    ConsistentOptions,
    MapOptions,
    identify,
    make_fitter,
    to_consistent,
)
from sescid.estimation.checks import check_total_mass, fit_warnings, outside_limits
from sescid.estimation.consistent import (
    body_boxes,
    consistent_from_fit,
    fit_inertials,
    identify_consistent,
)
from sescid.estimation.fit import (
    METHODS,
    BodyInertials,
    Combination,
    CopOffset,
    CrossValidation,
    Fit,
    JointNoiseEffect,
    MapInfo,
    OnlineInfo,
    RobustInfo,
)
from sescid.estimation.fit_json import load_fit, save_fit
from sescid.estimation.identifiability import (
    DEFAULT_RTOL,
    identifiable_eigen,
    min_poses,
    structural_rank,
)
from sescid.estimation.least_squares import identify_chunks, identify_ls, identify_stream, solve
from sescid.estimation.map import identify_map
from sescid.estimation.normal_equations import NormalEquations, accumulate
from sescid.estimation.one_pass import identify_once
from sescid.estimation.online import OnlineEstimator
from sescid.estimation.robust import huber, joint_noise_mc
from sescid.estimation.validation import (
    Interval,
    com_interval,
    cop_interval,
    cross_validate,
    perturbed_sesc,
    truth_error,
)

__all__ = [
    "check_total_mass",
    "fit_warnings",
    "outside_limits",
    "identify_once",
    "DEFAULT_RTOL",
    "METHODS",
    "BodyInertials",
    "Combination",
    "ConsistentOptions",
    "CopOffset",
    "CrossValidation",
    "Fit",
    "Interval",
    "JointNoiseEffect",
    "MapInfo",
    "MapOptions",
    "NormalEquations",
    "OnlineEstimator",
    "OnlineInfo",
    "RobustInfo",
    "accumulate",
    "body_boxes",
    "com_interval",
    "consistent_from_fit",
    "cop_interval",
    "cross_validate",
    "fit_inertials",
    "huber",
    "identifiable_eigen",
    "identify",
    "identify_consistent",
    "identify_ls",
    "identify_map",
    "identify_stream",
    "identify_chunks",
    "joint_noise_mc",
    "load_fit",
    "make_fitter",
    "min_poses",
    "perturbed_sesc",
    "save_fit",
    "solve",
    "structural_rank",
    "to_consistent",
    "truth_error",
]
