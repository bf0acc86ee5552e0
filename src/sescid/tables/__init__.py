"""Tables of named columns: files read and written (CSV, Parquet), and the one reader of each
measurement column.

``read_table``/``iter_table``/``write_table`` (``read``, ``write``: CSV or Parquet by suffix,
streamed in chunks, written atomically with floats in their shortest exact form: ``float_text``)
give and take a ``Table`` (``table``: named float columns, text apart, every error naming the
file's row; ``rows``); ``columns`` holds the conventions of a measurement file and their
readers: joint angles (rad, degrees or servo ticks), CoP and its standard errors, joint torques,
gravity directions, approach sides, the support. A file that is no table is named for what it
is (``file_kinds``). Above the compile policy of ``kinematics`` (the formatter is a kernel),
below every layer that reads data.
"""

from sescid.tables.columns import (
    APPROACH_COLUMN,
    GRAVITY_COLUMNS,
    MODEL_COP_COLUMNS,
    SUPPORT_COLUMN,
    TAU_PREFIX,
    TAU_SE_PREFIX,
    Torques,
    read_approach,
    read_cop,
    read_cop_se,
    read_gravity,
    read_joint_columns,
    read_poses,
    read_torques,
    refuse_plan,
    refuse_raw_log,
    torque_bound,
)
from sescid.tables.read import iter_table, read_ahead, read_table
from sescid.tables.table import Table, column_with_missing, pose_ids
from sescid.tables.write import write_table

__all__ = [
    "APPROACH_COLUMN",
    "GRAVITY_COLUMNS",
    "MODEL_COP_COLUMNS",
    "SUPPORT_COLUMN",
    "TAU_PREFIX",
    "TAU_SE_PREFIX",
    "Table",
    "Torques",
    "column_with_missing",
    "iter_table",
    "pose_ids",
    "read_ahead",
    "read_approach",
    "read_cop",
    "read_cop_se",
    "read_gravity",
    "read_joint_columns",
    "read_poses",
    "read_table",
    "read_torques",
    "refuse_plan",
    "refuse_raw_log",
    "torque_bound",
    "write_table",
]
