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
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from sescid.errors import DataError
from sescid.kinds import BALANCE, COP, KINDS, TORQUE, Kind, Kinds
from sescid.kinematics import as_poses
from sescid.robot import Robot
from sescid.stance import Stance, data_stance
from sescid.tables.columns import MAX_ANGLE_RAD, MAX_COP_M, TORQUE_REACH_M, torque_bound

#: poses a torque column's sign is checked on at most (spread over the data), and at least
SIGN_POSES, SIGN_MIN_POSES = 256, 10
#: a column whose torques correlate below −SIGN_CORR with the model's has the opposite sign
SIGN_CORR = 0.8
#: share of the columns the model explains (|correlation| > SIGN_CORR) that must look
#: reversed for the data to be refused
SIGN_SHARE = 0.75
#: N·m, RMS variation of the model's torque below which a column's sign is not judged
SIGN_SPREAD_NM = 0.02


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
    poses were measured in: a ``sescid.stance.Stance``; or its text (any ``parse_stance``
    spelling: a frame of the model, "double", "gantry:<link>") or None (the robot's own
    support), made a ``Stance`` by ``checked`` where the data meet the reference robot
    (``identify``, the readers); ``source`` names the data (a file) in error messages.
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
    support: Stance | str | None = None
    source: str = "data"
    #: pose i → where a file holds it ("row 7"; None: arrays, named "pose i" in errors)
    row_of: Callable[[int], str] | None = None

    def at(self, i: int) -> str:
        """Pose ``i`` as an error names it: the file's row ("row 7"), or "pose i" of arrays."""
        return self.row_of(int(i)) if self.row_of is not None else f"pose {int(i)}"

    def cell(self, i: int, column: str) -> str:
        """Pose ``i``'s value of ``column`` as an error names it: the file's row and column,
        or the pose index of arrays."""
        if self.row_of is not None:
            return f"{self.row_of(int(i))}, column '{column}'"
        return f"pose {int(i)}, {column}"

    def stance_on(self, reference: Robot) -> Stance:
        """The stance of these poses: ``support`` as checked data hold it, else resolved on
        ``reference`` by the one stance check (``sescid.stance.data_stance``)."""
        if isinstance(self.support, Stance):
            return self.support
        return data_stance(reference, self.support, self.kinds, self._first_row)[0]

    @property
    def n(self) -> int:
        """Number of poses."""
        return int(np.shape(self.q)[0])

    @property
    def kinds(self) -> Kinds:
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

    def checked(self, reference: Robot) -> Measurements:
        """A validated copy: its stance resolved on ``reference`` by the one stance check
        (``sescid.stance.data_stance``; ``support`` then a ``Stance``) and, on the robot rooted
        there, float64 C-contiguous arrays of the right shapes, finite values, positive
        standard errors, known joints, ±1 approach sides (DataError naming the source, the row
        and the column otherwise)."""
        where = self.source
        stance, robot = data_stance(reference, self.support, self.kinds, self._first_row)
        if robot.nq == 0:
            raise DataError(
                f"{where}: {robot.name} has no joints: every pose is the same rigid body, and its "
                "data repeat one measurement (sescid fits robots with joints)"
            )
        q = as_poses(self.q, robot.nq, f"{where}: q")
        n = q.shape[0]
        if n == 0:
            raise DataError(f"{where}: no poses")
        names = list(robot.joint_names)
        if q.size and (q.max() > MAX_ANGLE_RAD or q.min() < -MAX_ANGLE_RAD):  # no |q| temporary
            row, col = np.argwhere(np.abs(q) > MAX_ANGLE_RAD)[0]
            raise DataError(
                f"{where}: {self.cell(row, names[col])}: {q[row, col]:g} rad looks like degrees; "
                "joint angles are in radians"
            )
        cop = self._array(self.cop, (n, 2), "cop", ["cop_x", "cop_y"], "m", missing=True)
        if cop is not None and np.any(np.abs(cop) > MAX_COP_M):  # nan compares False
            row, col = np.argwhere(np.abs(cop) > MAX_COP_M)[0]
            raise DataError(
                f"{where}: {self.cell(row, f'cop_{chr(120 + col)}')} = {cop[row, col]:g} m is "
                "not a plausible CoP (millimetres for metres?)"
            )
        cop_se = self._array(self.cop_se, (n, 2), "cop_se", ["cop_se_x", "cop_se_y"], "m")
        self._positive(cop_se, ["cop_se_x", "cop_se_y"], "m")
        joints = tuple(str(j) for j in self.tau_joints)
        if self.tau is not None and not joints:
            raise DataError(f"{where}: torques given without the names of their joints")
        if len(set(joints)) != len(joints):
            raise DataError(f"{where}: a joint's torque is given twice ({', '.join(joints)})")
        if joints:
            robot.joint_columns(joints)  # ModelError naming an unknown joint
        tau_cols = [f"tau_{j}" for j in joints]
        tau = self._array(self.tau, (n, len(joints)), "tau", tau_cols, "N·m")
        bound = torque_bound(robot.total_mass)
        if tau is not None and np.any(np.abs(tau) > bound):
            row, col = np.argwhere(np.abs(tau) > bound)[0]
            raise DataError(
                f"{where}: {self.cell(row, tau_cols[col])} = {tau[row, col]:g} N·m is more than "
                f"the robot's weight at {TORQUE_REACH_M:g} m ({bound:.3g} N·m): not a torque in "
                "N·m (mN·m?)"
            )
        if tau is not None:
            self._check_sign(robot, q, tau, joints, self.gravity)
        se_cols = [f"tau_se_{j}" for j in joints]
        tau_se = self._array(self.tau_se, (n, len(joints)), "tau_se", se_cols, "N·m")
        self._positive(tau_se, se_cols, "N·m")
        approach = None
        if self.approach is not None:
            approach = self._array(self.approach, (n,), "approach", ["approach"], "±1")
            assert approach is not None
            bad = np.flatnonzero(np.abs(approach) != 1.0)
            if bad.size:
                raise DataError(
                    f"{where}: {self.cell(bad[0], 'approach')} = {approach[bad[0]]:g}: must be "
                    "+1 (reached moving up) or −1 (moving down)"
                )
        grav = ["grav_x", "grav_y", "grav_z"]
        gravity = self._array(self.gravity, (n, 3), "gravity", grav, "direction")
        cop_true = self._array(self.cop_true, (n, 2), "cop_true", ["cop_x_true", "cop_y_true"], "m")
        balance = self._array(self.balance, (n,), "balance", ["balance"], "m")
        if balance is not None:
            _check_balance(robot, balance, gravity, where, self.at)
        if cop is None and tau is None and balance is None:
            raise DataError(
                f"{where}: nothing measured: give cop_x, cop_y (centre of pressure) and/or "
                "tau_<joint> columns (joint torques)"
            )
        if cop is not None:
            _check_cop_rows(cop, tau is not None or balance is not None, where, self.at)
        return dataclasses.replace(
            self,
            support=stance,
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

    def _first_row(self) -> str:
        """Where the data start, as a stance's error names it (a row number scans the file)."""
        return self.source if self.row_of is None else f"{self.source}: {self.at(0)}"

    def _array(
        self,
        value,
        shape: tuple[int, ...],
        what: str,
        columns: list[str],
        unit: str,
        missing: bool = False,
    ) -> np.ndarray | None:
        """``value`` as a float array of ``shape``; DataError naming the first non-finite cell
        (its ``columns`` name, row or pose; nan marks a value not measured where ``missing``
        allows it)."""
        if value is None:
            return None
        arr = np.asarray(value, dtype=float)
        if shape[1:] == (2,) and arr.ndim == 1 and arr.shape == (shape[0] * 2,):
            arr = arr.reshape(shape)
        if arr.shape != shape:
            raise DataError(
                f"{self.source}: {what}: expected shape {shape} ({unit}), got {arr.shape}"
            )
        if arr.size and not math.isfinite(float(np.sum(arr))):
            bad = np.argwhere(np.isinf(arr) if missing else ~np.isfinite(arr))
            if bad.size:
                i = int(bad[0][0])
                col = columns[int(bad[0][1])] if arr.ndim > 1 else columns[0]
                raise DataError(f"{self.source}: {self.cell(i, col)}: {arr[tuple(bad[0])]} is "
                                "not a finite number")  # fmt: skip
        return np.ascontiguousarray(arr)

    def _check_sign(self, robot: Robot, q, tau, joints: tuple[str, ...], gravity) -> None:
        """DataError when the torques are the model's with the opposite sign at most joints (a
        reversed sign convention: every friction band would come out negative), judged on up
        to ``SIGN_POSES`` poses spread over the data; one joint alone may be a CAD model's
        error, left to the fit (``fit_warnings``: a negative friction band)."""
        n = tau.shape[0]
        if n < SIGN_MIN_POSES:
            return
        idx = np.unique(np.linspace(0, n - 1, min(n, SIGN_POSES)).astype(int))
        g = None if gravity is None else np.asarray(gravity, dtype=float)[idx]
        try:
            model = robot.torques(q[idx], joints=list(joints), gravity=g)
        except Exception:  # the model cannot say: leave the data to the fit
            return
        t = tau[idx] - tau[idx].mean(axis=0)
        m = model - model.mean(axis=0)
        mm = np.sum(m * m, axis=0)
        tt = np.sum(t * t, axis=0)
        with np.errstate(invalid="ignore", divide="ignore"):
            slope = np.sum(t * m, axis=0) / mm
            corr = np.sum(t * m, axis=0) / np.sqrt(mm * tt)
        spread = np.sqrt(mm / len(idx))
        judged = (spread > SIGN_SPREAD_NM) & (np.abs(corr) > SIGN_CORR)  # the model explains
        bad = np.flatnonzero((corr < -SIGN_CORR) & (slope < -0.5) & judged)
        if bad.size and bad.size >= SIGN_SHARE * judged.sum():
            k = int(bad[0])
            others = ", ".join(f"tau_{joints[int(i)]}" for i in bad[1:4])
            more = f" (also {others}{' …' if bad.size > 4 else ''})" if bad.size > 1 else ""
            raise DataError(
                f"{self.source}: column 'tau_{joints[k]}': the torques are the model's with the "
                f"opposite sign (slope {slope[k]:.2f}, correlation {corr[k]:.2f} over "
                f"{len(idx)} poses){more}: a sensor of reversed sign (tau_<joint> is the torque "
                "the actuator applies about the joint's axis, as in the model), or data measured "
                f"on another support than '{robot.support}'?"
            )

    def _positive(self, arr: np.ndarray | None, columns: list[str], unit: str) -> None:
        """DataError naming the first standard error that is not > 0."""
        if arr is not None and np.any(arr <= 0):
            i, k = (int(v) for v in np.argwhere(arr <= 0)[0])
            raise DataError(
                f"{self.source}: {self.cell(i, columns[k])} = {arr[i, k]:g} {unit}: a standard "
                "error must be > 0"
            )

    def take(self, rows: slice | np.ndarray) -> Measurements:
        """The poses ``rows`` (a slice or index array) of every array."""
        taken: dict[str, Any] = {}
        for f in ARRAYS:
            a = getattr(self, f)
            taken[f] = None if a is None else a[rows]
        where = self.row_of
        if where is not None:
            index = np.arange(self.n)[rows]
            taken["row_of"] = lambda i: where(int(index[i]))
        return dataclasses.replace(self, **taken)

    def only(self, kinds: Kinds | None) -> Measurements:
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

    def without(self, kind: Kind) -> Measurements:
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


#: the per-pose array fields of ``Measurements``, in a fixed order (``take``, ``concatenate``,
#: the spill of ``sources.StreamSource``)
ARRAYS = ("q", "cop", "cop_se", "balance", "tau", "tau_se", "approach", "gravity", "cop_true")


#: a balance offset beyond this many times the model's CoM distance from the support (the zero
#: pose) is taken for a unit mistake (mm for m), as ``MAX_COP_M`` is for a CoP
BALANCE_REACH = 2.0
#: a support line must not point closer to gravity than this (rad): the CoM's offset across it
#: would be undefined
MIN_LINE_GRAVITY_ANGLE = 0.1


def _check_balance(
    robot: Robot, balance: np.ndarray, gravity: np.ndarray | None, where: str, at=str
) -> None:
    """A balance measurement needs a line support, the gravity direction of every pose and
    offsets [m] within ``BALANCE_REACH`` × the model's CoM distance (``at(i)`` names pose i:
    "row 7")."""
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
    reach = BALANCE_REACH * float(np.linalg.norm(robot.com(np.zeros((1, robot.nq)))[0]))
    big = np.flatnonzero(np.abs(balance) > reach)
    if big.size:
        raise DataError(
            f"{where}: {at(big[0])}, column 'balance': {balance[big[0]]:g} m is not a plausible "
            f"offset of the CoM from the support line (beyond {reach:.3g} m, {BALANCE_REACH:g} × "
            "the model's CoM distance from the support): millimetres for metres?"
        )
    g = gravity / np.linalg.norm(gravity, axis=1, keepdims=True)
    bad = np.flatnonzero(np.abs(g @ robot.line) > math.cos(MIN_LINE_GRAVITY_ANGLE))
    if bad.size:
        raise DataError(
            f"{where}: {at(bad[0])}: gravity {gravity[bad[0]].round(4).tolist()} runs along the "
            "support line: the CoM's offset across it is not defined (check the line's "
            "direction or the IMU columns)"
        )


def _check_cop_rows(cop: np.ndarray, other_kinds: bool, where: str, at=str) -> None:
    """Each pose must measure something: a CoP row with both coordinates missing needs
    another kind in the same data (``at(i)`` names pose i: "row 7")."""
    if other_kinds:
        return
    empty = np.flatnonzero(np.all(np.isnan(cop), axis=1))
    if empty.size:
        raise DataError(
            f"{where}: {at(empty[0])}: neither cop_x nor cop_y was measured (drop the row or "
            "fill one of them)"
        )


def concatenate(parts: Sequence[Measurements]) -> Measurements:
    """One set from consecutive parts of the same data (same kinds, joints and columns)."""
    first = parts[0]
    if len(parts) == 1:
        return first
    for p in parts[1:]:
        if p.support != first.support:
            raise DataError(
                f"{p.source}: its parts were measured in different stances "
                f"({first.support!r}, {p.support!r}); cannot be joined"
            )
        if p.kinds != first.kinds or p.tau_joints != first.tau_joints:
            raise DataError(f"{p.source}: its parts measure different things; cannot be joined")
    arrays: dict[str, Any] = {}
    for f in ARRAYS:
        vals = [getattr(p, f) for p in parts]
        if any(v is None for v in vals) and not all(v is None for v in vals):
            raise DataError(f"{first.source}: column {f} is missing in some parts")
        arrays[f] = None if vals[0] is None else np.concatenate(vals)
    if all(p.row_of is not None for p in parts):
        starts = np.cumsum([0] + [p.n for p in parts])
        funcs = [p.row_of for p in parts]

        def rows(i: int) -> str:
            k = int(np.searchsorted(starts, i, side="right")) - 1
            return funcs[k](i - int(starts[k]))  # type: ignore[misc]

        arrays["row_of"] = rows
    else:
        arrays["row_of"] = None
    return dataclasses.replace(first, **arrays)
