"""Files in and out: the fit file, measurement files, a session's files, model export, ROS bags.

Tables themselves (CSV, Parquet) and their columns are ``sescid.tables``'s. ``save_fit``/
``load_fit`` (the fit JSON), ``rows_estimate`` (a measurement file's rows), ``export_model``
(the fit's model file with identified masses and CoMs: ``export_urdf``, ``export_mjcf``;
``sescid.io.export``), ``pose_table`` (the pose list a bench reads), ``read_bag``
(a ROS bag and a mapping file → the raw log: joints, joint torques, foot forces;
``sescid.io.bags``, the ``bags`` extra). Outputs are never written over an input nor inside an
input folder (``sescid.base.files``).
"""

from sescid.estimation.result.fit_json import FIT_FORMAT, load_fit, save_fit
from sescid.io.bags import (
    MAPPING_FORMAT,
    BagMapping,
    FootSource,
    JointSource,
    PoseSource,
    RawLogTable,
    Segment,
    TorqueSource,
    load_mapping,
    parse_mapping,
    read_bag,
)
from sescid.io.export.assets import model_files
from sescid.io.export.inertia import check_inertias, repairs_summarised
from sescid.io.export.mjcf import export_mjcf
from sescid.io.export.model import FORMATS, export_model
from sescid.io.export.urdf import export_urdf
from sescid.io.export.usd import USD_SUFFIXES, export_usd
from sescid.io.measurements import rows_estimate
from sescid.io.pose_table import PoseTable, pose_table, required_paper_convention
from sescid.io.session_files import SESSION_FILES, read_session_reasons, write_session

__all__ = [
    "FIT_FORMAT",
    "FORMATS",
    "MAPPING_FORMAT",
    "SESSION_FILES",
    "BagMapping",
    "FootSource",
    "JointSource",
    "PoseSource",
    "PoseTable",
    "RawLogTable",
    "Segment",
    "TorqueSource",
    "check_inertias",
    "export_mjcf",
    "export_model",
    "export_urdf",
    "export_usd",
    "USD_SUFFIXES",
    "load_fit",
    "load_mapping",
    "model_files",
    "parse_mapping",
    "pose_table",
    "read_bag",
    "read_session_reasons",
    "repairs_summarised",
    "required_paper_convention",
    "rows_estimate",
    "save_fit",
    "write_session",
]
