"""Regenerate ``src/sescid/robots/op2.urdf`` and ``op2_table1.csv`` from the reference facts.

Usage: ``python tools/make_op2_urdf.py ../shared/reference/op2``. The facts (masses, CoMs, joint
origins/axes, limits, sole geometry) and their sources are documented in that folder's README;
this script only re-formats them. Conventions: all link frames parallel to the torso frame at the
all-zero servo pose (x forward, y left, z up), joint axis = positive servo rotation, SI units.
"""

from __future__ import annotations

import csv
import sys
from pathlib import Path

import numpy as np

# Inertia about the CoM, principal values from the Webots model (kg m^2), old axes (left, up, fwd).
_INERTIA_OLD = {
    "MP_BODY": (3.1081800e-3, 6.3787776e-3, 5.3316425e-3),
    "MP_NECK": (5.1411124e-6, 8.1915737e-6, 1.1379812e-5),
    "MP_HEAD": (1.2396830e-4, 1.1783781e-4, 1.1583601e-4),
    "MP_SHOULDER": (9.7758165e-6, 1.0511104e-5, 5.4767980e-6),
    "MP_ARM_HIGH": (1.2202839e-4, 3.8088441e-5, 1.1340830e-4),
    "MP_ARM_LOW": (8.6855267e-5, 2.1192085e-5, 8.6845450e-5),
    "MP_PELVIS": (1.5019148e-5, 1.1328768e-5, 6.1825529e-6),
    "MP_THIGH1": (1.2259691e-4, 1.1066637e-4, 4.1877668e-5),
    "MP_THIGH2": (9.7950272e-5, 3.2848287e-5, 1.1493509e-4),
    "MP_TIBIA": (9.3369608e-5, 4.6295534e-5, 1.1351516e-4),
    "MP_ANKLE1": (1.2079175e-4, 1.0885465e-4, 4.1871103e-5),
    "MP_ANKLE2": (6.8325629e-5, 8.7890505e-5, 3.5840758e-5),
}
# Sole centre relative to the ankle-roll axes, right foot (fsr.md section 5); left: mirror y.
_SOLE_XYZ_R = (-0.0005, -0.0109, -0.0335)
_SOLE_SIZE = (0.105, 0.066)

# Collision shapes for the self-collision check of pose planning (sescid.design): boxes in each
# link's frame, right side; the left side mirrors y (and the roll angle). Sizes are plausible
# envelopes from the zero-pose geometry of the reference README section 4 (joint points, link
# lengths, sole rectangle) and MX-28 servo bodies (35.6 x 50.6 x 35.5 mm); they are not CAD.
# Checked: no two non-adjacent bodies overlap at the zero pose. (xyz m, rpy rad, box size m or
# a 1-tuple = sphere radius m)
_COLLISION_R = {
    # trunk: x -0.065..0.035, |y| < 0.05, z -0.09..0.005 (shoulder axes z 0, hip yaw at -0.0907)
    "MP_BODY": [((-0.015, 0.0, -0.0425), (0.0, 0.0, 0.0), (0.10, 0.10, 0.095))],
    # neck bracket between the pan horn (z 0.0205) and the tilt axis (0.0505 above the torso)
    "MP_NECK": [((0.0, 0.0, 0.015), (0.0, 0.0, 0.0), (0.03, 0.03, 0.03))],
    # head: sphere r 0.04 on the head CoM (it turns with the 45 deg nose-down zero offset)
    "MP_HEAD": [((0.018548203, 0.00006392, 0.007705965), (0.0, 0.0, 0.0), (0.04,))],
    # shoulder bracket from the pitch horn (y 0.0575) to the roll axis (y 0.082, z -0.016)
    "MP_SHOULDER": [((0.0, -0.012, -0.008), (0.0, 0.0, 0.0), (0.03, 0.024, 0.035))],
    # upper arm: 0.060 to the elbow, abducted 45 deg at servo 0 (box long axis along the arm)
    "MP_ARM_HIGH": [((0.008, -0.02475, -0.02475), (-0.7853981634, 0.0, 0.0), (0.035, 0.04, 0.085))],
    # forearm: points forward at servo 0, elbow to hand tip 0.129
    "MP_ARM_LOW": [((0.06, 0.0, 0.0), (0.0, 0.0, 0.0), (0.13, 0.03, 0.03))],
    # hip-yaw bracket between the yaw horn and the hip roll/pitch block (0.0315 below)
    "MP_PELVIS": [((0.0, 0.0, -0.012), (0.0, 0.0, 0.0), (0.045, 0.025, 0.015))],
    # hip roll/pitch block (servos 9+11) around the hip centre
    "MP_THIGH1": [((-0.012, 0.0, -0.006), (0.0, 0.0, 0.0), (0.06, 0.035, 0.045))],
    # thigh: hip centre to knee 0.093, incl. the knee servo
    "MP_THIGH2": [((0.0, 0.0, -0.055), (0.0, 0.0, 0.0), (0.035, 0.035, 0.07))],
    # shank: knee to ankle 0.093
    "MP_TIBIA": [((0.005, 0.0, -0.045), (0.0, 0.0, 0.0), (0.03, 0.035, 0.06))],
    # ankle block (servos 15+17) around the ankle centre
    "MP_ANKLE1": [((-0.012, 0.0, 0.008), (0.0, 0.0, 0.0), (0.06, 0.035, 0.045))],
    # foot plate: the sole rectangle, 0.01 thick, on the sole (0.0335 below the ankle axes)
    "MP_ANKLE2": [((-0.0005, -0.0109, -0.0285), (0.0, 0.0, 0.0), (0.105, 0.066, 0.01))],
}


def _collisions(link: str) -> list[str]:
    """<collision> elements of a link (boxes/spheres; left side mirrored from the right)."""
    left = link.endswith("_L")
    key = link[:-2] if link.endswith(("_R", "_L")) else link
    out = []
    for k, (xyz, rpy, size) in enumerate(_COLLISION_R.get(key, [])):
        x, y, z = xyz
        roll, pitch, yaw = rpy
        if left:
            y, roll, yaw = -y, -roll, -yaw
        out += [
            f'    <collision name="{link}_{"sphere" if len(size) == 1 else "box"}{k}">',
            f'      <origin xyz="{_fmt((x, y, z))}" rpy="{_fmt((roll, pitch, yaw))}"/>',
            f'      <geometry><sphere radius="{_fmt(size)}"/></geometry>'
            if len(size) == 1
            else f'      <geometry><box size="{_fmt(size)}"/></geometry>',
            "    </collision>",
        ]
    return out


def _inertia(link: str) -> tuple[float, float, float]:
    key = link[:-2] if link.endswith(("_R", "_L")) else link
    ixx_old, iyy_old, izz_old = _INERTIA_OLD[key]
    return izz_old, ixx_old, iyy_old  # (x, y, z)_torso = (z, x, y)_old


def _fmt(values) -> str:
    return " ".join(f"{float(v):.10g}" for v in values)


def main(ref: Path, out_dir: Path) -> None:
    links = list(csv.DictReader((ref / "links.csv").open()))
    limits = {row["servo_id"]: row for row in csv.DictReader((ref / "joint_limits.csv").open())}
    lines = [
        '<?xml version="1.0"?>',
        "<!-- ROBOTIS OP2 / DARwIn-OP for sescid. Generated by tools/make_op2_urdf.py from the",
        "     reference facts (masses/CoMs: original Cyberbotics Webots model = manufacturer values;",
        "     joint origins/axes: ROBOTIS-OP2-Common; limits: Webots). All link frames are parallel",
        "     to the torso frame at the all-zero servo pose (x forward, y left, z up); a positive",
        "     joint angle is a positive servo angle. Inertias are principal values, approximate",
        "     (not used by the static SESC problem). r_sole / l_sole: massless sole-centre frames. -->",
        '<robot name="robotis_op2">',
    ]
    for row in links:
        name = row["manufacturer_link"]
        ixx, iyy, izz = _inertia(name)
        lines += [
            f'  <link name="{name}">',
            f"    <!-- paper Table 1 body {row['paper_index']}: {row['paper_name']} -->",
            "    <inertial>",
            f'      <origin xyz="{_fmt(row["com_xyz_m"].split())}" rpy="0 0 0"/>',
            f'      <mass value="{float(row["mass_kg"]):.10g}"/>',
            f'      <inertia ixx="{ixx:.8g}" ixy="0" ixz="0" iyy="{iyy:.8g}" iyz="0" izz="{izz:.8g}"/>',
            "    </inertial>",
            *_collisions(name),
            "  </link>",
        ]
    for side in ("r", "l"):
        lx, ly = _SOLE_SIZE
        lines += [
            f'  <link name="{side}_sole">',
            f"    <!-- sole centre, massless; sole rectangle {lx} x {ly} m (Webots foot mesh) -->",
            "  </link>",
        ]
    # Movable joints in servo-ID order, so Robot.joint_names follows the ROBOTIS IDs 1..20.
    by_id = sorted((row for row in links if row["servo_id"]), key=lambda r: int(r["servo_id"]))
    for row in by_id:
        lim = limits[row["servo_id"]]
        lo, hi = float(lim["webots_min_rad"]), float(lim["webots_max_rad"])
        lines += [
            f'  <joint name="{row["ros_joint_name"]}" type="revolute">',
            f"    <!-- servo ID {row['servo_id']} ({row['joint_name']}) -->",
            f'    <parent link="{row["parent_link"]}"/>',
            f'    <child link="{row["manufacturer_link"]}"/>',
            f'    <origin xyz="{_fmt(row["joint_origin_xyz_m"].split())}" rpy="0 0 0"/>',
            f'    <axis xyz="{_fmt(row["joint_axis"].split())}"/>',
            f'    <limit lower="{lo:.6g}" upper="{hi:.6g}" effort="2.5" velocity="5.6"/>',
            "  </joint>",
        ]
    for side, foot, ysign in (("r", "MP_ANKLE2_R", 1.0), ("l", "MP_ANKLE2_L", -1.0)):
        x, y, z = _SOLE_XYZ_R
        lines += [
            f'  <joint name="{side}_sole_joint" type="fixed">',
            f'    <parent link="{foot}"/>',
            f'    <child link="{side}_sole"/>',
            f'    <origin xyz="{_fmt((x, ysign * y, z))}" rpy="0 0 0"/>',
            "  </joint>",
        ]
    lines.append("</robot>")
    (out_dir / "op2.urdf").write_text("\n".join(lines) + "\n")

    with (out_dir / "op2_table1.csv").open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["paper_index", "paper_name", "link", "servo_id", "joint"])
        for row in links:
            w.writerow(
                [
                    row["paper_index"],
                    row["paper_name"],
                    row["manufacturer_link"],
                    row["servo_id"],
                    row["ros_joint_name"],
                ]
            )
    # The paper's Table 2 limits, and the same converted to servo angles (the model's convention):
    # paper = sign * servo + offset (blank sign/offset in the reference = identity).
    with (out_dir / "op2_paper_limits.csv").open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(
            [
                "joint",
                "servo_id",
                "paper_min_deg",
                "paper_max_deg",
                "paper_sign_vs_servo",
                "paper_offset_deg",
                "servo_min_deg",
                "servo_max_deg",
                "paper_convention_confidence",
            ]
        )
        for sid in sorted(limits, key=int):
            lim = limits[sid]
            sign = float(lim["paper_sign_vs_servo"] or 1.0)
            off = float(lim["paper_offset_deg"] or 0.0)
            a = (float(lim["min_deg"]) - off) / sign
            b = (float(lim["max_deg"]) - off) / sign
            w.writerow(
                [
                    lim["ros_joint_name"],
                    sid,
                    lim["min_deg"],
                    lim["max_deg"],
                    f"{sign:+g}",
                    f"{off:+g}",
                    f"{min(a, b) + 0.0:g}",
                    f"{max(a, b) + 0.0:g}",
                    lim["paper_convention_confidence"],
                ]
            )
    np.set_printoptions(precision=4)
    print(
        f"wrote {out_dir / 'op2.urdf'}, op2_table1.csv, op2_paper_limits.csv ({len(links)} links)"
    )


if __name__ == "__main__":
    ref_dir = Path(sys.argv[1] if len(sys.argv) > 1 else "../shared/reference/op2")
    main(ref_dir, Path(__file__).resolve().parents[1] / "src" / "sescid" / "robots")
