"""Stability that holds on a compliant robot: where the CoP goes when the servos sag, the sole
tilts on soft contacts and the load arrives at once, and how far the backlash can move it.

A statically stable pose (CoM over the sole) can still topple on a real robot: position servos
of stiffness kp sag under gravity, the foot rests on pads (or a sole) of finite stiffness and
tilts toward the loaded side, and the CoM, at height h, follows the tilt. Linearised about the
commanded pose q, with the support foot the base and W = M g the weight:

1. servo sag: δq = −(W / kp) ∂c_z/∂q (the gravity torque on each joint over its stiffness);
   the CoM moves by δc = J_xy δq (J = ∂CoM/∂q, ``com.com_state``);
2. sole tilt: contacts p_i of vertical stiffness k tilt the foot by u (horizontal shift per unit
   height) with K u = W (c' − p̄) + W h u, K = k Σ (p_i − p̄)(p_i − p̄)ᵀ: u = (K − W h)⁻¹ W (c' − p̄)
   and the CoP on the sole goes to e = c' + h u (K − W h must be positive definite, else the
   pose has no stable equilibrium on these contacts);
3. the load arrives at once (a pose is reached and released, the robot settles): an undamped
   step response peaks at twice its static deflection, so the dynamic CoP is
   e_dyn = c + ``DYNAMIC_FACTOR`` (e − c);
4. backlash b per joint (uniform in ±b) moves the CoM by a standard deviation
   b / √3 · |J_x|, b / √3 · |J_y|: ``BACKLASH_SIGMAS`` of it are kept free.

A pose is stable when e_dyn lies inside the contacts' rectangle shrunk by the backlash term
and ``EDGE_MARGIN``. The stiffnesses, contacts and backlash come from the robot profile
(``servo_gains.kp``, ``pad_stiffness``, the support foot's pads in ``sensors_file``,
``servo_backlash``), else generic values scaled by the robot's weight and size, stated in the
output: servos that sag ``GENERIC_SAG`` under the weight at the CoM height, contacts that sink
``GENERIC_SINK`` under the weight — stiffened, on a tall robot with a narrow foot, until the
sole's tilt stiffness is ``GENERIC_TILT`` times the toppling moment W h (a foot that tilts by
its own softness as far as the CoM leans is no real robot's; the MuJoCo bench's contacts stiffen
with the robot's inertia the same way). Without a sole the contacts are the CoP box's rectangle
widened to a sole (1 / ``SOLE_BOX_FRACTION``), so box and margin agree. Measured on the OP2
physics bench
(``bench.mujoco``, 600 candidate poses of the paper's ±23 mm box, 106 of which topple): with
these rules none of those kept topples, 65 % are kept.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sescid.base import G0
from sescid.planning.feasibility.com import ComState
from sescid.planning.feasibility.stability import FALLBACK_COP_BOX, SOLE_BOX_FRACTION
from sescid.robot import Robot

DYNAMIC_FACTOR = 2.0  #: peak / static deflection of an undamped step response
BACKLASH_SIGMAS = 2.0  #: standard deviations of the backlash's CoM shift kept free
EDGE_MARGIN = 0.003  #: m, kept free inside the contacts' rectangle beyond the rest
#: generic servo stiffness: the robot's weight at its zero-pose CoM height sags a joint this much
GENERIC_SAG = 0.02  #: rad
#: generic contact stiffness: the sole's four corners sink this much under the robot's weight
GENERIC_SINK = 0.0005  #: m
GENERIC_BACKLASH = math.radians(0.5)  #: rad
#: generic contacts: the sole's tilt stiffness k Σ (pᵢ − p̄)(pᵢ − p̄)ᵀ at least this many times
#: the toppling moment per unit lean W h (the tilt then adds under 1 / (GENERIC_TILT − 1) of
#: the CoM's lean to the CoP)
GENERIC_TILT = 4.0


@dataclass(frozen=True)
class Compliance:
    """The compliant-stability model of one robot on its support foot (SI units)."""

    kp: float  #: N·m/rad, servo stiffness (every joint)
    contact_stiffness: float  #: N/m, vertical stiffness of each contact
    contacts: np.ndarray  #: (k, 2) contact points in the support frame, m
    floor: float  #: m, height of the contacts in the support frame
    backlash: float  #: rad, per joint (uniform in ±backlash)
    weight: float  #: N
    source: str  #: one line: where each number came from

    @property
    def centre(self) -> np.ndarray:
        """(2,) centre of the contacts' rectangle, m."""
        return (self.contacts.min(axis=0) + self.contacts.max(axis=0)) / 2

    @property
    def half(self) -> np.ndarray:
        """(2,) half-sizes of the contacts' rectangle, m."""
        return (self.contacts.max(axis=0) - self.contacts.min(axis=0)) / 2


def sensor_pads(robot: Robot, frame: str) -> np.ndarray | None:
    """(k, 2) the sensor pads [m] of the foot whose sole frame is ``frame``, in that frame, when
    the profile's sensor layout has that foot."""
    if robot.profile.sensors_file is None:
        return None
    from sescid.sensors.pads import load_sensors

    feet = [f for f in load_sensors(robot.profile.sensors_file).feet]
    for f in feet:
        if f.sole_frame == frame:
            return np.asarray(f.sensors, dtype=float)
    return None


def compliance(robot: Robot) -> Compliance:
    """The robot's compliance model: profile values, else the generic defaults (stated)."""
    weight = robot.total_mass * G0
    said = []
    pads = sensor_pads(robot, robot.support)
    sole = robot.sole
    if pads is not None:
        contacts = pads
        said.append(f"contacts: the {len(pads)} support-foot pads of the sensor layout")
    elif sole is not None and min(sole.size) > 0:
        corners = sole.corners @ robot.model.root_rotation.T + robot.model.root_origin
        contacts = corners[:, :2]
        said.append("contacts: the support sole's corners")
    else:
        box = np.broadcast_to(np.asarray(robot.profile.cop_box or FALLBACK_COP_BOX, float), (2,))
        half = box / SOLE_BOX_FRACTION
        contacts = robot.sole_centre + np.array([[1, 1], [1, -1], [-1, 1], [-1, -1]]) * half
        said.append(f"contacts: no sole known, the corners of a {2e3 * half[0]:.0f} x "
                    f"{2e3 * half[1]:.0f} mm sole around the CoP box")  # fmt: skip
    h = max(float(robot.com(np.zeros(robot.nq))[0, 2]) - robot.floor, 0.0)
    gains = robot.profile.servo_gains
    if gains is not None:
        kp = gains.kp
        said.append(f"servo {kp:g} N·m/rad (profile)")
    else:
        kp = max(weight * h, 1e-6) / GENERIC_SAG
        said.append(f"servo {kp:.3g} N·m/rad (generic: the weight at the CoM height sags "
                    f"{GENERIC_SAG:g} rad)")  # fmt: skip
    k = robot.profile.pad_stiffness
    if k is not None:
        said.append(f"contacts {k:g} N/m each (profile)")
    else:
        k, how = generic_contact_stiffness(contacts, weight, h)
        said.append(f"contacts {k:.3g} N/m each (generic: {how})")
    b = robot.profile.servo_backlash
    if b is not None:
        said.append(f"backlash ±{math.degrees(b):g}° (profile)")
    else:
        b = GENERIC_BACKLASH
        said.append(f"backlash ±{math.degrees(b):g}° (generic)")
    return Compliance(float(kp), float(k), contacts, robot.floor, float(b), weight,
                      "; ".join(said))  # fmt: skip


def generic_contact_stiffness(contacts: np.ndarray, weight: float, h: float) -> tuple[float, str]:
    """(N/m per contact, how it was set): the contacts (k, 2) [m] sink ``GENERIC_SINK`` under
    the weight [N], or, when that leaves the sole's tilt stiffness under ``GENERIC_TILT`` W h
    (h [m]: the CoM height at the zero pose), stiff enough to reach it."""
    k = weight / (len(contacts) * GENERIC_SINK)
    how = f"they sink {GENERIC_SINK * 1e3:g} mm under the weight"
    d = contacts - contacts.mean(axis=0)
    low = float(np.linalg.eigvalsh(d.T @ d)[0])
    if low > 0 and k * low < GENERIC_TILT * weight * h:
        k = GENERIC_TILT * weight * h / low
        how = (
            f"the sole's tilt stiffness {GENERIC_TILT:g} × weight × CoM height: they sink "
            f"{weight / (len(contacts) * k) * 1e3:.2g} mm under the weight"
        )
    return k, how


def dynamic_cop(model: Compliance, st: ComState, contacts: np.ndarray | None = None) -> np.ndarray:
    """(n, 2) the dynamic CoP e_dyn [m] (see the module docstring) on ``contacts`` (n, k, 2)
    [m] (default ``model.contacts``); nan where the pose has no stable equilibrium on the
    contacts (K − W h not positive definite)."""
    c, jac, w = st.com, st.jac, model.weight
    dq = jac[:, 2, :] * (-w / model.kp)  # (n, nq) sag
    cs = c[:, :2] + np.stack([np.sum(jac[:, i, :] * dq, axis=1) for i in range(2)], axis=1)
    p = model.contacts[None] if contacts is None else contacts
    mean = p.mean(axis=1)
    d = p - mean[:, None, :]
    k = model.contact_stiffness
    kxx = k * np.sum(d[..., 0] ** 2, axis=1)
    kxy = k * np.sum(d[..., 0] * d[..., 1], axis=1)
    kyy = k * np.sum(d[..., 1] ** 2, axis=1)
    h = c[:, 2] - model.floor
    a, bb, cc = kxx - w * h, kxy, kyy - w * h  # K − W h, symmetric 2 × 2
    det = a * cc - bb * bb
    rx, ry = ((cs - mean) * w).T
    with np.errstate(divide="ignore", invalid="ignore"):
        ux = (cc * rx - bb * ry) / det
        uy = (a * ry - bb * rx) / det
    e = cs + np.stack([ux, uy], axis=1) * h[:, None]
    e[~((a > 0) & (det > 0))] = np.nan
    return c[:, :2] + DYNAMIC_FACTOR * (e - c[:, :2])


def compliant_margin(model: Compliance, st: ComState) -> np.ndarray:
    """(n,) how far [m] the dynamic CoP stays inside the contacts' rectangle shrunk by the
    backlash term and ``EDGE_MARGIN`` (> 0: stable; −inf: no stable equilibrium)."""
    e = dynamic_cop(model, st)
    jn = np.sqrt(np.stack([np.sum(st.jac[:, i, :] ** 2, axis=1) for i in range(2)], axis=1))
    room = (
        model.half - np.abs(e - model.centre) - BACKLASH_SIGMAS * model.backlash / math.sqrt(3) * jn
    )
    out = room.min(axis=1) - EDGE_MARGIN
    return np.where(np.isfinite(out), out, -np.inf)
