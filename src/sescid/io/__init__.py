"""Files in and out: pose/CoP tables (CSV, Parquet), the fit file, model export.

``read_table``/``write_table`` (CSV or Parquet by suffix, atomic), ``read_poses``/``read_cop``/
``read_cop_se`` (column conventions of ``sescid.table``), ``save_fit``/``load_fit`` (the fit
JSON), ``export_urdf`` (a URDF with identified masses and CoMs).
"""

from __future__ import annotations

from ..estimation.fit_json import FIT_FORMAT, load_fit, save_fit
from ..files import atomic_open, atomic_path, read_json
from ..table import Table, read_cop, read_cop_se, read_gravity, read_joint_columns, read_poses
from .export import export_urdf
from .tables import read_table, write_table

__all__ = [
    "FIT_FORMAT",
    "Table",
    "atomic_open",
    "atomic_path",
    "export_urdf",
    "load_fit",
    "read_cop",
    "read_cop_se",
    "read_gravity",
    "read_joint_columns",
    "read_json",
    "read_poses",
    "read_table",
    "save_fit",
    "write_table",
]
