"""sescid: identify a humanoid robot's mass distribution from its CoP and its joint torques.

The user surface, importable as ``import sescid`` (heavy libraries — scipy, matplotlib, MuJoCo,
the compiled kernels — load inside the functions that need them):

- robots: ``load_robot``, ``Robot``;
- data: ``simulate``, ``read_table``, ``write_table``;
- estimation: ``identify`` (files or arrays, any mix of CoP and joint-torque ``Measurements``;
  ``method`` = "auto" (the default) | "ls" | "map" | "consistent" or that method's options —
  ``AutoOptions``, ``LeastSquaresOptions``, ``MapOptions``, ``ConsistentOptions``; what every
  method shares: ``IdentifyOptions``),
  ``to_consistent``, ``OnlineEstimator``, ``Fit``, ``load_fit``, ``save_fit``, ``fit_summary``
  and ``fit_notes`` (a fit's lines for a reader, made outside the record);
  ``identify_payload`` (a payload's mass and CoM on a calibrated robot);
- experiments: ``plan_poses``, ``run_experiment``, ``measure``, ``fsr``, ``load_sensors``,
  ``paper_study``;
- model files and fits: ``audit`` (score candidate model files against measurements),
  ``compare`` (what changed between fits);
- outputs: ``export_model`` (``export_urdf``, ``export_mjcf``), ``write_report``;
- errors: ``SescidError`` and its subclasses.
"""

from sescid.api import identify, identify_payload
from sescid.audit import audit, compare
from sescid.bench import run_experiment
from sescid.errors import (
    DataError,
    MissingExtraError,
    ModelError,
    OptionError,
    SescidError,
    SolverError,
)
from sescid.estimation import (
    AutoOptions,
    ConsistentOptions,
    Fit,
    IdentifyOptions,
    LeastSquaresOptions,
    MapOptions,
    Measurements,
    OnlineEstimator,
    fit_notes,
    fit_summary,
    load_fit,
    save_fit,
    to_consistent,
)
from sescid.io import export_mjcf, export_model, export_urdf
from sescid.planning import plan_poses
from sescid.report import write_report
from sescid.robot import Robot, load_robot
from sescid.sensors import fsr, load_sensors, measure
from sescid.simulation import simulate
from sescid.study import paper_study
from sescid.tables import read_table, write_table

__version__ = "0.1.0"

__all__ = [
    "AutoOptions",
    "ConsistentOptions",
    "DataError",
    "Fit",
    "IdentifyOptions",
    "LeastSquaresOptions",
    "Measurements",
    "MapOptions",
    "MissingExtraError",
    "ModelError",
    "OnlineEstimator",
    "OptionError",
    "Robot",
    "SescidError",
    "audit",
    "compare",
    "SolverError",
    "export_mjcf",
    "export_model",
    "export_urdf",
    "fit_notes",
    "fit_summary",
    "fsr",
    "identify",
    "identify_payload",
    "load_fit",
    "load_robot",
    "load_sensors",
    "measure",
    "paper_study",
    "plan_poses",
    "read_table",
    "run_experiment",
    "save_fit",
    "simulate",
    "to_consistent",
    "write_report",
    "write_table",
]
