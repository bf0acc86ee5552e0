"""What was measured at a set of static poses: the data every measurement kind reads.

``Measurements`` holds the joint angles and, per kind, what a robot measured there (SI units, in
the support frame): the CoP under the support foot, joint torques of any subset of joints, and
the gravity direction when the support is not level. One object may carry several kinds (a CoP
and torques in the same file); ``kinds`` names those present. Everything is validated once, by
``checked``, with errors that name the source (a file) and the row or column.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from sescid.base.columns import MAX_ANGLE_RAD, MAX_COP_M, MAX_TORQUE_NM
from sescid.errors import DataError
from sescid.kinematics import as_poses
from sescid.robot import Robot

#: the measurement kinds, as named in fits, files and options
COP = "cop"
TORQUE = "tau"
BALANCE = "balance"
KINDS = (COP, TORQUE, BALANCE)


@dataclass(frozen=True)
class Measurements:
    """Poses and what was measured at them; every array has the poses first.

    ``q`` (n, nq) rad in ``Robot.joint_names`` order; ``cop`` (n, 2) m (nan where a coordinate
    was not measured: each row fits the coordinates it has) and ``cop_se`` (n, 2) m its
    standard errors; ``balance`` (n,) m: the CoM's measured horizontal offset from the robot's
    support line (``Robot.line``; 0 for a pose balanced on it), which needs ``gravity``;
    ``tau`` (n, J) N·m, the torque each actuator of ``tau_joints`` applies to hold the pose
    (model sign convention) and ``tau_se`` (n, J) N·m; ``approach`` (n,) ±1:
    each pose was reached with the joints moving in their positive (+1) or negative (−1)
    direction last (static friction holds the torque on that side of the gravity torque);
    ``gravity`` (n, 3) the gravity direction in the support frame (None: level);
    ``cop_true`` (n, 2) m the noise-free CoP of simulated data; ``support`` the stance these
    poses were measured in (a frame of the model: the other foot, a held link; "double": both
    feet, the CoP of the whole robot in the robot's support frame; None: the robot's own
    support); ``source`` names the data (a file) in error messages.
    """

    q: np.ndarray
    cop: np.ndarray | None = None
    cop_se: np.ndarray | None = None
    balance: np.ndarray | None = None
    tau: np.ndarray | None = None
    tau_joints: tuple[str, ...] = ()
    tau_se: np.ndarray | None = None
    approach: np.ndarray | None = None
    gravity: np.ndarray | None = None
    cop_true: np.ndarray | None = None
    support: str | None = None
    source: str = "data"

    @property
    def n(self) -> int:
        """Number of poses."""
        return int(np.shape(self.q)[0])

    @property
    def kinds(self) -> tuple[str, ...]:
        """The measurement kinds present, in ``KINDS`` order."""
        out = []
        if self.cop is not None:
            out.append(COP)
        if self.tau is not None and len(self.tau_joints):
            out.append(TORQUE)
        if self.balance is not None:
            out.append(BALANCE)
        return tuple(out)

    def rows(self) -> int:
        """Equations these poses give: 1 per measured CoP coordinate, 1 per measured torque,
        1 per balance."""
        cop = 0 if self.cop is None else int(np.count_nonzero(~np.isnan(self.cop)))
        tau = len(self.tau_joints) * (self.tau is not None) * self.n
        return cop + tau + self.n * (self.balance is not None)

    def checked(self, robot: Robot) -> Measurements:
        """A validated copy: float64 C-contiguous arrays of the right shapes, finite values,
        positive standard errors, known joints, ±1 approach sides (DataError naming the source,
        the row and the column otherwise)."""
        where = self.source
        q = as_poses(self.q, robot.nq, f"{where}: q")
        n = q.shape[0]
        if n == 0:
            raise DataError(f"{where}: no poses")
        if q.max() > MAX_ANGLE_RAD or q.min() < -MAX_ANGLE_RAD:  # no |q| temporary
            row, col = np.argwhere(np.abs(q) > MAX_ANGLE_RAD)[0]
            raise DataError(
                f"{where}: pose {row}, joint {robot.joint_names[col]}: {q[row, col]:g} rad looks "
                "like degrees; joint angles are in radians"
            )
        cop = _array(self.cop, (n, 2), f"{where}: cop", "m", missing=True)
        if cop is not None and np.any(np.abs(cop) > MAX_COP_M):  # nan compares False
            row, col = np.argwhere(np.abs(cop) > MAX_COP_M)[0]
            raise DataError(
                f"{where}: pose {row}, cop_{'xy'[col]} = {cop[row, col]:g} m is not a plausible "
                "CoP (millimetres for metres?)"
            )
        cop_se = _positive(_array(self.cop_se, (n, 2), f"{where}: cop_se", "m"), where, "cop_se")
        joints = tuple(str(j) for j in self.tau_joints)
        if self.tau is not None and not joints:
            raise DataError(f"{where}: torques given without the names of their joints")
        if len(set(joints)) != len(joints):
            raise DataError(f"{where}: a joint's torque is given twice ({', '.join(joints)})")
        if joints:
            robot.joint_columns(joints)  # ModelError naming an unknown joint
        tau = _array(self.tau, (n, len(joints)), f"{where}: tau", "N·m")
        if tau is not None and np.any(np.abs(tau) > MAX_TORQUE_NM):
            row, col = np.argwhere(np.abs(tau) > MAX_TORQUE_NM)[0]
            raise DataError(
                f"{where}: row {row}, tau_{joints[col]} = {tau[row, col]:g} N·m: beyond "
                f"{MAX_TORQUE_NM:g} N·m (a unit slip: mN·m?)"
            )
        tau_se = _array(self.tau_se, (n, len(joints)), f"{where}: tau_se", "N·m")
        tau_se = _positive(tau_se, where, "tau_se")
        approach = None
        if self.approach is not None:
            approach = _array(self.approach, (n,), f"{where}: approach", "±1")
            assert approach is not None
            bad = np.flatnonzero(np.abs(approach) != 1.0)
            if bad.size:
                raise DataError(
                    f"{where}: row {bad[0]}, approach = {approach[bad[0]]:g}: must be +1 "
                    "(reached moving up) or −1 (moving down)"
                )
        gravity = _array(self.gravity, (n, 3), f"{where}: gravity", "direction")
        cop_true = _array(self.cop_true, (n, 2), f"{where}: cop_true", "m")
        balance = _array(self.balance, (n,), f"{where}: balance", "m")
        if balance is not None:
            _check_balance(robot, balance, gravity, where)
        if cop is None and tau is None and balance is None:
            raise DataError(
                f"{where}: nothing measured: give cop_x, cop_y (centre of pressure) and/or "
                "tau_<joint> columns (joint torques)"
            )
        if cop is not None:
            _check_cop_rows(cop, tau is not None or balance is not None, where)
        return dataclasses.replace(
            self,
            q=q,
            cop=cop,
            cop_se=cop_se,
            tau=tau,
            tau_joints=joints,
            tau_se=tau_se,
            approach=approach,
            gravity=gravity,
            cop_true=cop_true,
            balance=balance,
        )

    def take(self, rows: slice | np.ndarray) -> Measurements:
        """The poses ``rows`` (a slice or index array) of every array."""
        taken: dict[str, Any] = {}
        for f in _ARRAYS:
            a = getattr(self, f)
            taken[f] = None if a is None else a[rows]
        return dataclasses.replace(self, **taken)

    def only(self, kinds: tuple[str, ...] | None) -> Measurements:
        """The same poses with only the measurement ``kinds`` kept (None: all); DataError when
        none of them is in the data."""
        if kinds is None:
            return self
        out = self
        for k in KINDS:
            if k not in kinds and k in out.kinds:
                out = out.without(k)
        if not out.kinds:
            raise DataError(
                f"{self.source}: no {' or '.join(kinds)} data (it has: "
                f"{', '.join(self.kinds) or 'nothing'})"
            )
        return out

    def without(self, kind: str) -> Measurements:
        """The same poses with one kind of measurement dropped."""
        if kind == COP:
            return dataclasses.replace(self, cop=None, cop_se=None, cop_true=None)
        if kind == BALANCE:
            return dataclasses.replace(self, balance=None)
        return dataclasses.replace(self, tau=None, tau_joints=(), tau_se=None, approach=None)

    @property
    def cop_missing(self) -> int:
        """CoP coordinates not measured (nan) in these poses."""
        return 0 if self.cop is None else int(np.count_nonzero(np.isnan(self.cop)))


_ARRAYS = ("q", "cop", "cop_se", "balance", "tau", "tau_se", "approach", "gravity", "cop_true")


#: a support line must not point closer to gravity than this (rad): the CoM's offset across it
#: would be undefined
MIN_LINE_GRAVITY_ANGLE = 0.1


def _check_balance(robot: Robot, balance: np.ndarray, gravity: np.ndarray | None, where: str):
    """A balance measurement needs a line support and the gravity direction of every pose."""
    if robot.line is None:
        raise DataError(
            f"{where}: balance rows need a support line (a wheel axle, an edge): give its "
            "direction (load_robot(…, line=…) / --line)"
        )
    if gravity is None:
        raise DataError(
            f"{where}: balance rows need the gravity direction of every pose (grav_x/y/z, or "
            "the IMU's imu_roll/imu_pitch)"
        )
    g = gravity / np.linalg.norm(gravity, axis=1, keepdims=True)
    bad = np.flatnonzero(np.abs(g @ robot.line) > math.cos(MIN_LINE_GRAVITY_ANGLE))
    if bad.size:
        raise DataError(
            f"{where}: row {bad[0]}: gravity {gravity[bad[0]].round(4).tolist()} runs along the "
            "support line: the CoM's offset across it is not defined (check the line's "
            "direction or the IMU columns)"
        )


def _check_cop_rows(cop: np.ndarray, other_kinds: bool, where: str) -> None:
    """Each pose must measure something: a CoP row with both coordinates missing needs
    another kind in the same data."""
    if other_kinds:
        return
    empty = np.flatnonzero(np.all(np.isnan(cop), axis=1))
    if empty.size:
        raise DataError(
            f"{where}: row {empty[0]}: neither cop_x nor cop_y was measured (drop the row or "
            "fill one of them)"
        )


def concatenate(parts: Sequence[Measurements]) -> Measurements:
    """One set from consecutive parts of the same data (same kinds, joints and columns)."""
    first = parts[0]
    if len(parts) == 1:
        return first
    for p in parts[1:]:
        if p.kinds != first.kinds or p.tau_joints != first.tau_joints:
            raise DataError(f"{p.source}: its parts measure different things; cannot be joined")
    arrays: dict[str, Any] = {}
    for f in _ARRAYS:
        vals = [getattr(p, f) for p in parts]
        if any(v is None for v in vals) and not all(v is None for v in vals):
            raise DataError(f"{first.source}: column {f} is missing in some parts")
        arrays[f] = None if vals[0] is None else np.concatenate(vals)
    return dataclasses.replace(first, **arrays)


def _array(
    value, shape: tuple[int, ...], what: str, unit: str, missing: bool = False
) -> np.ndarray | None:
    """A float64 C-contiguous copy of ``value`` shaped ``shape``; DataError for a wrong shape
    or a non-finite value (nan marks a value not measured where ``missing`` allows it)."""
    if value is None:
        return None
    arr = np.asarray(value, dtype=float)
    if shape[1:] == (2,) and arr.ndim == 1 and arr.shape == (shape[0] * 2,):
        arr = arr.reshape(shape)
    if arr.shape != shape:
        raise DataError(f"{what}: expected shape {shape} ({unit}), got {arr.shape}")
    if arr.size and not math.isfinite(float(np.sum(arr))):
        bad = np.argwhere(np.isinf(arr) if missing else ~np.isfinite(arr))
        if bad.size:
            idx = tuple(int(i) for i in bad[0])
            raise DataError(
                f"{what}: non-finite value at row {idx[0]}"
                + (f", column {idx[1]}" if len(idx) > 1 else "")
            )
    return np.ascontiguousarray(arr)


def _positive(arr: np.ndarray | None, where: str, name: str) -> np.ndarray | None:
    if arr is not None and np.any(arr <= 0):
        row = int(np.argwhere(arr <= 0)[0, 0])
        raise DataError(f"{where}: {name} at row {row} must be > 0 (a standard error)")
    return arr
