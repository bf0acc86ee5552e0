"""Joint torques in a raw log: ``tau_<joint>`` samples and the ``approach`` side of each pose
(read by ``tables.columns.read_torques``/``read_approach``, the one reader of those columns).

Columns (the data contract): ``tau_<joint>`` [N·m], the torque the actuator applies to hold the
pose, about the joint's axis with the model's sign, for any subset of the model's joints (named
as in the model file); ``approach`` (+1 / −1 per pose: the joints last moved in the positive /
negative direction before the pose was held, i.e. it was reached from below / above). A raw log
has many samples per pose; the reduction (``sensors.reduce``) averages them into ``tau_<joint>``
and ``tau_se_<joint>`` per pose and carries ``approach``.

Plausibility: a holding torque cannot exceed the whole robot's weight acting at
``TORQUE_REACH_M`` from the joint; a larger value is not in N·m (N·mm?) and is refused with the
row and column named.
"""

from __future__ import annotations

import numpy as np

from sescid.errors import DataError
from sescid.tables.columns import APPROACH_COLUMN, TAU_PREFIX, TORQUE_REACH_M, torque_bound

#: N·m, smallest robust scale of a torque in the outlier rule
TORQUE_OUTLIER_FLOOR = 1e-3
#: N·m, smallest standard error of a pose's mean torque (identical samples: a resolution)
TORQUE_SE_FLOOR = 1e-6


def check_torque_scale(log, mass: float) -> None:
    """DataError naming the row and column of a torque of the raw log ``log`` beyond
    ``mass``·g·TORQUE_REACH_M."""
    limit = torque_bound(mass)
    with np.errstate(invalid="ignore"):
        bad = np.argwhere(np.abs(log.tau) > limit)
    if bad.size:
        i, k = bad[0]
        raise DataError(
            f"{log.path}: {log.where(i)}, column '{TAU_PREFIX}{log.tau_joints[k]}': "
            f"{log.tau[i, k]:g} N·m is "
            f"more than the robot's weight at {TORQUE_REACH_M:g} m ({limit:.3g} N·m): not a "
            "torque in N·m"
        )


def pose_approach(approach: np.ndarray, g: np.ndarray, k: int, path, where=None):
    """(k,) the approach side of each pose; DataError when a pose's samples disagree
    (``where(i)`` names sample i: "row 7")."""
    out = np.full(k, np.nan)
    ok = ~np.isnan(approach)
    lo = np.full(k, np.inf)
    hi = np.full(k, -np.inf)
    np.minimum.at(lo, g[ok], approach[ok])
    np.maximum.at(hi, g[ok], approach[ok])
    mixed = np.flatnonzero(lo < hi)
    if mixed.size:
        i = int(np.flatnonzero(g == mixed[0])[0])
        at = where(i) if where is not None else f"row {i + 2}"
        raise DataError(
            f"{path}: column '{APPROACH_COLUMN}': the samples of one pose (from {at}) give "
            "both +1 and -1 (one approach side per pose id)"
        )
    has = np.isfinite(lo)
    out[has] = lo[has]
    return out
