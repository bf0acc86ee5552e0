"""Humanoids that used to be refused or planned wrong, each reproduced by a generator: a
motion-capture model (capsules overlapping at split joints, a lifted free foot, a narrow sole
on a tall body, toes below the sole plane), a 33 kg robot on a narrow sole, a small robot whose
collision geometry is meshes only (and the same with its foot meshes missing), a chain robot
(two legs hanging from a trunk that carries nothing else). Checked against MuJoCo's and
Pinocchio's kinematics and on the MuJoCo bench."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from humanoid_gen import NARROW_33KG
from mesh_robot_gen import ANKLE, FOOT, write_mesh_robot
from mocap_gen import SUPPORT, mocap_mjcf
from refs import mj_body_lowest, write_humanoid

import sescid
from sescid import planning as design
from sescid.bench.standing import stands
from sescid.planning.feasibility.com import com_state
from sescid.planning.feasibility.compliance import GENERIC_SINK, compliant_margin
from sescid.planning.feasibility.stability import DEFAULT_CLEARANCE

CLEAR = DEFAULT_CLEARANCE


def test_mocap_humanoid_plans_clear_and_stands(tmp_path):
    """The mocap-style humanoid on its right foot's touch site: the free foot is the supporting
    leg's mirror (the zero pose lifts it); the planned poses keep the free foot and its toes
    ≥ 5 mm above the floor and every other body (but the support foot's toes, below the sole at
    rest) above it, by MuJoCo's kinematics of the file; the poses nearest the margin's edge
    stand on the MuJoCo bench."""
    path = tmp_path / "mocap.xml"
    path.write_text(mocap_mjcf())
    robot = sescid.load_robot(path, SUPPORT)
    free = robot.free_sole
    assert free is not None and free.link == "lfoot" and "mirror" in free.note
    model = design.compliance(robot)
    assert "tilt stiffness" in model.source  # a tall robot on a 44 mm wide sole
    plan = design.plan_poses(robot, 25, seed=0, n_candidates=150, n_test=40)
    per = mj_body_lowest(path, SUPPORT, robot.joint_names, plan.q, skip_body="rfoot")
    floor = robot.floor
    assert np.all(per["lfoot"] > floor + CLEAR) and np.all(per["ltoes"] > floor + CLEAR)
    others = [v for k, v in per.items() if k not in ("lfoot", "ltoes", "rtoes", "world")]
    assert np.min(others) > floor
    margin = compliant_margin(model, com_state(robot, plan.q))
    res = stands(robot, plan.q[np.argsort(margin)[:3]])
    assert res.mask.all(), res.reasons


def test_a_33kg_robot_on_a_narrow_sole_is_not_refused(tmp_path):
    """33 kg, a 120 × 36 mm sole, the CoM 0.66 m up: contacts sinking a fixed 0.5 mm (the old
    generic rule) keep no candidate; the generic contacts stiffened to the sole's tilt
    stiffness keep most, and the kept poses nearest the edge stand on the MuJoCo bench."""
    robot = sescid.load_robot(write_humanoid(tmp_path, NARROW_33KG, "h33"), "legA_sole")
    assert robot.total_mass == pytest.approx(33.16)
    model = design.compliance(robot)
    old = dataclasses.replace(model, contact_stiffness=model.weight / (4 * GENERIC_SINK))
    q = design.candidates(robot, 300, 0, design.CandidateOptions(compliance=None)).q
    st = com_state(robot, q)
    assert not np.any(compliant_margin(old, st) > 0)
    margin = compliant_margin(model, st)
    assert np.mean(margin > 0) > 0.5
    kept = np.flatnonzero(margin > 0)
    res = stands(robot, q[kept[np.argsort(margin[kept])[:3]]])
    assert res.mask.all(), res.reasons


def test_a_small_mesh_only_robot(tmp_path):
    """~3 kg, collision meshes only: the sole comes from the foot mesh; planned poses keep the
    free foot's mesh ≥ 5 mm up (its box corners placed by Pinocchio) and stand on the bench.
    With the foot meshes missing there is no sole: the compliant margin's contacts come from
    the CoP box (said) and poses are planned, not refused."""
    from oracle import PinOracle

    path = write_mesh_robot(tmp_path / "bot")
    robot = sescid.load_robot(path, "r_sole")
    assert robot.sole is not None and robot.sole.size == pytest.approx(FOOT[:2], abs=1e-6)
    plan = design.plan_poses(robot, 20, seed=0, n_candidates=150, n_test=40)
    pin = PinOracle(path, "r_sole", robot.joint_names)
    import pinocchio as pino

    h = np.asarray(FOOT) / 2
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * h
    corners += [0.01, 0, -ANKLE + FOOT[2] / 2]
    fid = pin.model.getFrameId("l_foot")
    for qk in plan.q:
        pino.framesForwardKinematics(pin.model, pin.data, pin.q_pin(qk))
        foot = pin.data.oMf[pin.frame].actInv(pin.data.oMf[fid])
        z = (corners @ foot.rotation.T + foot.translation)[:, 2]
        assert z.min() > CLEAR
    res = stands(robot, plan.q[:3])
    assert res.mask.all(), res.reasons
    (tmp_path / "bot" / "meshes" / "foot.stl").unlink()
    bare = sescid.load_robot(path, "r_sole")
    assert bare.sole is None
    assert "no sole known" in design.compliance(bare).source
    assert len(design.plan_poses(bare, 20, seed=0, n_candidates=100, n_test=30).q) == 20


CHAIN = """<mujoco model="chain_biped">
  <compiler angle="radian"/>
  <worldbody>
    <body name="trunk" pos="0 0 0.75">
      <freejoint/>
      <inertial pos="0 0 0.12" mass="6" diaginertia="0.1 0.1 0.05"/>
      <geom type="box" size="0.08 0.12 0.12" pos="0 0 0.12"/>
      {legs}
    </body>
  </worldbody>
</mujoco>"""
LEG = """
      <body name="{s}_hip" pos="0 {y} 0">
        <joint name="{s}_hip_roll" axis="1 0 0" range="-0.5 0.5"/>
        <inertial pos="0 0 -0.05" mass="0.8" diaginertia="0.002 0.002 0.001"/>
        <body name="{s}_thigh" pos="0 0 -0.06">
          <joint name="{s}_hip_pitch" axis="0 1 0" range="-1.5 0.5"/>
          <inertial pos="0 0 -0.15" mass="2.5" diaginertia="0.02 0.02 0.005"/>
          <geom type="capsule" fromto="0 0 -0.04 0 0 -0.26" size="0.04"/>
          <body name="{s}_shin" pos="0 0 -0.3">
            <joint name="{s}_knee" axis="0 1 0" range="0 2"/>
            <inertial pos="0 0 -0.15" mass="0.4" diaginertia="0.005 0.005 0.001"/>
            <geom type="capsule" fromto="0 0 -0.04 0 0 -0.26" size="0.025"/>
            <body name="{s}_foot" pos="0 0 -0.34">
              <joint name="{s}_ankle_pitch" axis="0 1 0" range="-0.6 0.6"/>
              <joint name="{s}_ankle_roll" axis="1 0 0" range="-0.5 0.5"/>
              <inertial pos="0.02 0 -0.03" mass="0.5" diaginertia="0.001 0.001 0.001"/>
              <geom name="{s}_sole_box" type="box" size="0.08 0.03 0.006" pos="0.02 0 -0.054"/>
              <site name="{s}_sole" pos="0.02 0 -0.06"/>
            </body>
          </body>
        </body>
      </body>"""


def test_a_chain_robot_finds_its_free_foot(tmp_path):
    """Two legs hanging from a trunk that carries nothing else (the tree is a chain from foot to
    foot, as the Berkeley Humanoid's): the trunk ends the supporting leg, the other foot is free
    and planned poses keep its box ≥ 5 mm above the floor (MuJoCo's kinematics)."""
    legs = LEG.format(s="r", y=-0.07) + LEG.format(s="l", y=0.07)
    path = tmp_path / "chain.xml"
    path.write_text(CHAIN.format(legs=legs))
    robot = sescid.load_robot(path, "r_sole")
    free = robot.free_sole
    assert free is not None and free.link == "l_foot"
    plan = design.plan_poses(robot, 20, seed=0, n_candidates=150, n_test=40)
    per = mj_body_lowest(path, "r_sole", robot.joint_names, plan.q, skip_body="r_foot")
    assert np.all(per["l_foot"] > robot.floor + CLEAR)
