"""sescid: identify a humanoid robot's mass distribution from its CoP and its joint torques.

The user surface, importable as ``import sescid`` (names load on first use, so importing the
package costs nothing until one is used):

- robots: ``load_robot``, ``Robot``;
- data: ``simulate``, ``read_table``, ``write_table``;
- estimation: ``identify`` (any mix of CoP and joint-torque ``Measurements``; ``method`` =
  "ls" | "map" | "consistent"; ``IdentifyOptions``, ``MapOptions``, ``ConsistentOptions``),
  ``to_consistent``, ``OnlineEstimator``, ``Fit``, ``load_fit``, ``save_fit``;
- experiments: ``plan_poses``, ``run_experiment``, ``measure``, ``fsr``, ``load_sensors``,
  ``paper_study``;
- outputs: ``export_model`` (``export_urdf``, ``export_mjcf``), ``write_report``;
- errors: ``SescidError`` and its subclasses.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from sescid.base.lazy import lazy_exports

__version__ = "0.1.0"

#: public name → module that defines it
_EXPORTS: dict[str, str] = {
    "Robot": "sescid.robot",
    "load_robot": "sescid.robot",
    "simulate": "sescid.simulation",
    "read_table": "sescid.io",
    "write_table": "sescid.io",
    "Fit": "sescid.estimation",
    "IdentifyOptions": "sescid.estimation",
    "Measurements": "sescid.estimation",
    "MapOptions": "sescid.estimation",
    "ConsistentOptions": "sescid.estimation",
    "OnlineEstimator": "sescid.estimation",
    "identify": "sescid.api",
    "to_consistent": "sescid.estimation",
    "load_fit": "sescid.estimation",
    "save_fit": "sescid.estimation",
    "plan_poses": "sescid.planning",
    "run_experiment": "sescid.bench",
    "measure": "sescid.sensors",
    "fsr": "sescid.sensors",
    "load_sensors": "sescid.sensors",
    "paper_study": "sescid.study",
    "export_model": "sescid.io",
    "export_mjcf": "sescid.io",
    "export_urdf": "sescid.io",
    "write_report": "sescid.report",
    "SescidError": "sescid.errors",
    "ModelError": "sescid.errors",
    "DataError": "sescid.errors",
    "OptionError": "sescid.errors",
    "SolverError": "sescid.errors",
    "MissingExtraError": "sescid.errors",
}

__all__ = [
    "ConsistentOptions",
    "DataError",
    "Fit",
    "IdentifyOptions",
    "Measurements",
    "MapOptions",
    "MissingExtraError",
    "ModelError",
    "OnlineEstimator",
    "OptionError",
    "Robot",
    "SescidError",
    "SolverError",
    "export_mjcf",
    "export_model",
    "export_urdf",
    "fsr",
    "identify",
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


__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)


if TYPE_CHECKING:  # pragma: no cover - for type checkers and IDEs
    from sescid.api import identify
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
        ConsistentOptions,
        Fit,
        IdentifyOptions,
        MapOptions,
        Measurements,
        OnlineEstimator,
        load_fit,
        save_fit,
        to_consistent,
    )
    from sescid.io import export_mjcf, export_model, export_urdf, read_table, write_table
    from sescid.planning import plan_poses
    from sescid.report import write_report
    from sescid.robot import Robot, load_robot
    from sescid.sensors import fsr, load_sensors, measure
    from sescid.simulation import simulate
    from sescid.study import paper_study
