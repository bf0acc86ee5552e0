"""Centre of pressure from other foot sensors: an ankle force/torque sensor or a force plate.

Every function is pure numpy and vectorised over samples: arrays carry a leading sample axis
``(n, ...)`` (a single sample may be given without it and broadcasts). Lengths are in m, forces
in N, torques in N·m. The **sole frame** is the support foot's sole link (URDF): origin on the
sole, x forward, y left, z up, the ground is its plane z = 0. Each function returns
``(cop, fz)``: the CoP ``(n, 2)`` in the sole frame and the normal force ``fz`` ``(n,)`` the
ground (or plate) carries; the CoP is NaN where ``fz <= min_force`` (an unloaded foot has none).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np

from sescid.base import G0
from sescid.base.files import read_document
from sescid.errors import DataError, OptionError

PLATE_FORMAT = "sescid-plate/1"
#: the unit of a logged force, and N per unit
ForceUnit = Literal["N", "mN", "kgf"]
FORCE_UNITS: dict[ForceUnit, float] = {"N": 1.0, "mN": 1e-3, "kgf": G0}


# --- small geometry -----------------------------------------------------------------------
def rpy_matrix(rpy) -> np.ndarray:
    """URDF roll/pitch/yaw (rad) → rotation ``Rz(yaw) Ry(pitch) Rx(roll)``, (..., 3, 3)."""
    rpy = np.asarray(rpy, dtype=float)
    r, p, y = rpy[..., 0], rpy[..., 1], rpy[..., 2]
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    return np.stack(
        [
            np.stack([cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr], -1),
            np.stack([sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr], -1),
            np.stack([-sp, cp * sr, cp * cr], -1),
        ],
        -2,
    )


def plate_to_sole(points, foot_pose) -> np.ndarray:
    """Points (n, 2) in the plate frame → the sole frame, the foot standing at ``foot_pose``.

    ``foot_pose = (x, y, yaw)``: the sole frame's origin (m) and heading (rad, about the plate's
    z) in the plate frame, so ``p_plate = (x, y) + Rz(yaw) p_sole``; ``(n, 3)`` for one per sample.
    """
    pose = np.asarray(foot_pose, dtype=float)
    d = np.asarray(points, dtype=float) - pose[..., :2]
    c, s = np.cos(pose[..., 2]), np.sin(pose[..., 2])
    return np.stack([c * d[..., 0] + s * d[..., 1], -s * d[..., 0] + c * d[..., 1]], axis=-1)


def _finish(px, py, fz, min_force: float) -> tuple[np.ndarray, np.ndarray]:
    fz = np.asarray(fz, dtype=float)
    on = fz > min_force
    with np.errstate(invalid="ignore", divide="ignore"):
        cop = np.stack([px, py], axis=-1) / np.where(on, fz, np.nan)[..., None]
    return cop, fz


# --- ankle force/torque sensor --------------------------------------------------------------
def cop_from_wrench(
    force,
    torque,
    sensor_rot,
    sensor_pos,
    foot_mass: float = 0.0,
    foot_com=None,
    min_force: float = 0.0,
) -> tuple[np.ndarray, np.ndarray]:
    """CoP in the sole plane from a force/torque sensor between the leg and the foot.

    Arguments (n samples; a single sample may drop the leading axis):

    - ``force`` (n, 3) N, ``torque`` (n, 3) N·m: the wrench that the part **below** the sensor
      (foot and ground) exerts on the part above, in the sensor frame, torque about the sensor
      origin. Standing, its z is about +weight in a sensor frame with z up. A sensor reporting
      the opposite (the leg's action on the foot) needs both negated.
    - ``sensor_rot`` (n, 3, 3), ``sensor_pos`` (n, 3) m: the sensor frame in the sole frame
      (``v_sole = sensor_rot @ v_sensor + sensor_pos``).
    - ``foot_mass`` kg and ``foot_com`` (3,) m (sole frame): the rigid body between sensor and
      ground (sole plate, foot board); its weight acts at its CoM and the sensor does not see it.

    Derivation. With the sole on the ground (z = 0, z up), let ``F = R f``, ``T = R t`` be the
    measured wrench in the sole frame and ``s`` the sensor origin. The foot below the sensor is
    in static equilibrium under the ground reaction (force ``F_g`` at the CoP ``p = (px, py, 0)``
    plus a free moment ``τ_n ẑ``, the ground's contact wrench), its weight ``−m g ẑ`` at ``c``
    and the reaction ``(−F, −T)`` of the part above at ``s``:

        forces:   F_g − m g ẑ − F = 0                       → F_g = F + m g ẑ
        moments about the sole origin:
                  p × F_g + τ_n ẑ − m g (c × ẑ) − s × F − T = 0

    The x and y rows of ``p × F_g`` are ``(py F_gz, −px F_gz)``; τ_n ẑ has none, so with
    ``M = s × F + T + m g (c × ẑ)``, ``c × ẑ = (c_y, −c_x, 0)``:

        px = −M_y / F_gz,   py = M_x / F_gz,   F_gz = F_z + m g  (returned as ``fz``).

    Closed form: sensor at height h above the sole origin, axes aligned, ``f = (F_x, 0, W)``,
    ``t = 0``, massless foot → ``px = −h F_x / W``. Returns ``(cop (n, 2), fz (n,))``.
    """
    f = np.asarray(force, dtype=float)
    t = np.asarray(torque, dtype=float)
    rot = np.asarray(sensor_rot, dtype=float)
    s = np.asarray(sensor_pos, dtype=float)
    big_f = np.einsum("...ij,...j->...i", rot, f)
    big_t = np.einsum("...ij,...j->...i", rot, t)
    m = np.cross(s, big_f) + big_t
    fz = big_f[..., 2]
    if foot_mass:
        if foot_com is None:
            raise OptionError("foot_com", "a foot_mass needs its foot_com (sole frame, m)")
        c = np.asarray(foot_com, dtype=float)
        w = foot_mass * G0
        m = m + w * np.stack([c[..., 1], -c[..., 0], np.zeros_like(c[..., 0])], axis=-1)
        fz = fz + w
    return _finish(-m[..., 1], m[..., 0], fz, min_force)


# --- force plates ------------------------------------------------------------------------------
def cop_from_plate(loads, cell_xy, foot_pose=(0.0, 0.0, 0.0), min_force: float = 0.0):
    """CoP of a load-cell board (vertical cells) under the foot, in the sole frame.

    ``loads`` (n, k) N are the vertical forces of the k cells at ``cell_xy`` (k, 2) m in the
    plate frame; the CoP on the plate is their force-weighted centroid ``Σ F_k p_k / Σ F_k``,
    carried into the sole frame with ``foot_pose = (x, y, yaw)`` (the sole frame in the plate
    frame, see ``plate_to_sole``). Returns ``(cop (n, 2), fz (n,))``, ``fz = Σ F_k``.
    """
    loads = np.asarray(loads, dtype=float)
    cells = np.asarray(cell_xy, dtype=float)
    if cells.ndim != 2 or cells.shape[1] != 2 or loads.shape[-1] != cells.shape[0]:
        raise DataError(
            f"cop_from_plate: {loads.shape[-1]} loads per sample for {cells.shape[0]} cells"
        )
    moment = loads @ cells
    c, fz = _finish(moment[..., 0], moment[..., 1], loads.sum(axis=-1), min_force)
    return plate_to_sole(c, foot_pose), fz


def cop_from_force_plate(
    wrench, surface_z: float, foot_pose=(0.0, 0.0, 0.0), min_force: float = 0.0
) -> tuple[np.ndarray, np.ndarray]:
    """CoP of a 6-axis force plate (Fx, Fy, Fz, Mx, My, Mz), in the sole frame.

    ``wrench`` (n, 6): force (N) and moment (N·m) about the plate's measurement origin, in the
    plate's axes; ``surface_z`` (m) is the z coordinate of the plate's top surface in that frame.
    A load ``F`` at the surface point ``(px, py, surface_z)`` with a free moment about z gives
    ``M_x = py F_z − surface_z F_y`` and ``M_y = surface_z F_x − px F_z``, hence

        px = (−M_y + surface_z F_x) / F_z,   py = (M_x + surface_z F_y) / F_z.

    The result is the same whether the plate reports the foot's action on it or the reaction
    (both F and M change sign). Conventions: AMTI/Bertec plates have z **down** with the origin
    ``dz`` below the surface, i.e. ``surface_z = −dz``, giving the manuals'
    ``x = (−M_y − F_x dz)/F_z``, ``y = (M_x − F_y dz)/F_z``; a z-up frame with the origin ``dz``
    below the surface has ``surface_z = +dz``. ``foot_pose`` is the sole frame in the plate's
    x, y axes. Returns ``(cop (n, 2), fz (n,))`` with ``fz = |F_z|``.
    """
    w = np.asarray(wrench, dtype=float)
    if w.shape[-1] != 6:
        raise DataError(f"cop_from_force_plate: expected (n, 6) Fx..Mz, got shape {w.shape}")
    fx, fy, fz, mx, my = (w[..., k] for k in range(5))
    px = -my + surface_z * fx
    py = mx + surface_z * fy
    on = np.abs(fz) > min_force
    with np.errstate(invalid="ignore", divide="ignore"):
        c = np.stack([px, py], axis=-1) / np.where(on, fz, np.nan)[..., None]
    return plate_to_sole(c, foot_pose), np.abs(fz)


# --- plate files ------------------------------------------------------------------------------
@dataclass(frozen=True)
class Plate:
    """A load-cell board: cell positions (k, 2) m in the plate frame and the force unit (N/unit)."""

    cells: np.ndarray
    force_unit: float = 1.0
    source: str = ""


def load_plate(path) -> Plate:
    """Read a plate file (JSON or YAML) ``{"format": "sescid-plate/1", "cells_m": [[x, y], ...],
    "force_unit": "N" | "mN" | "kgf"}``; the cell positions are in the plate frame, m."""
    path = Path(path)
    data = read_document(path)
    if not isinstance(data, dict) or data.get("format") != PLATE_FORMAT:
        raise DataError(f'{path}: not a plate file (expected "format": "{PLATE_FORMAT}")')
    unknown = sorted(set(data) - {"format", "cells_m", "force_unit", "notes"})
    if unknown:
        raise DataError(f"{path}: unknown field '{unknown[0]}'")
    try:
        cells = np.array(data.get("cells_m"), dtype=float)
    except (TypeError, ValueError):
        cells = np.empty((0,))
    if cells.ndim != 2 or cells.shape[1] != 2 or len(cells) < 3 or not np.isfinite(cells).all():
        raise DataError(f"{path}: cells_m: expected at least 3 points [x, y] in metres")
    area = np.linalg.matrix_rank(cells[1:] - cells[0])
    if area < 2:
        raise DataError(f"{path}: cells_m: the cells lie on a line (no CoP across it)")
    unit = data.get("force_unit", "N")
    if unit not in FORCE_UNITS:
        raise DataError(
            f"{path}: force_unit: expected one of {', '.join(FORCE_UNITS)}, got {unit!r}"
        )
    return Plate(cells, FORCE_UNITS[unit], str(path))
