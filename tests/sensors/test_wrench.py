"""CoP from an ankle force/torque sensor and from force plates (sescid.sensors.wrench)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from bag_gen import sensor_wrench
from hypothesis import given, settings
from hypothesis import strategies as st

from sescid.base import G0
from sescid.errors import SescidError
from sescid.sensors.wrench import (
    cop_from_force_plate,
    cop_from_plate,
    cop_from_wrench,
    load_plate,
    plate_to_sole,
    rpy_matrix,
)


def _rot(axis: int, a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    i, j = (axis + 1) % 3, (axis + 2) % 3
    r = np.eye(3)
    r[i, i], r[i, j], r[j, i], r[j, j] = c, -s, s, c
    return r


def _random_rot(rng, n):
    q = rng.normal(size=(n, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    w, x, y, z = q.T
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], -1),
            np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], -1),
            np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], -1),
        ],
        -2,
    )


def test_closed_form_horizontal_force_above_the_sole():
    """Sensor h above the sole origin, force (Fx, 0, W): the CoP is at x = −h Fx / W."""
    h, fx, w = 0.03, 4.0, 30.0
    cop, fz = cop_from_wrench([fx, 0, w], [0, 0, 0], np.eye(3), [0, 0, h])
    assert cop == pytest.approx([-h * fx / w, 0.0], abs=1e-15)
    assert fz == pytest.approx(w)


def test_pure_torque_shifts_the_cop():
    """An aligned sensor at the origin reading torque (Tx, Ty) gives CoP (−Ty/W, Tx/W)."""
    cop, _ = cop_from_wrench([0, 0, 20.0], [0.2, -0.4, 0.1], np.eye(3), [0, 0, 0.04])
    assert cop == pytest.approx([0.4 / 20, 0.2 / 20])


def test_random_point_loads_come_back_through_the_sensor():
    """A point load on the sole, seen by a tilted sensor above a heavy foot, comes back."""
    rng = np.random.default_rng(1)
    n = 500
    p = rng.uniform(-0.05, 0.05, size=(n, 2))
    f_ground = np.column_stack([rng.normal(0, 3, size=(n, 2)), rng.uniform(5, 40, n)])
    tau_n = rng.normal(0, 0.5, n)
    rot = _random_rot(rng, n)
    s = np.column_stack([rng.normal(0, 0.02, size=(n, 2)), rng.uniform(0.02, 0.06, n)])
    com = np.array([0.01, -0.004, 0.012])
    f, t = sensor_wrench(p, f_ground, tau_n, rot, s, foot_mass=0.25, foot_com=com)
    cop, fz = cop_from_wrench(f, t, rot, s, foot_mass=0.25, foot_com=com)
    assert np.abs(cop - p).max() < 1e-12
    assert np.abs(fz - f_ground[:, 2]).max() < 1e-12


@settings(max_examples=50, deadline=None)
@given(
    st.floats(-0.06, 0.06),
    st.floats(-0.04, 0.04),
    st.floats(0.5, 80.0),
    st.floats(-np.pi, np.pi),
    st.floats(-0.5, 0.5),
    st.floats(0.0, 0.6),
)
def test_statics_property(px, py, w, yaw, roll, mass):
    """Any loaded point under any sensor orientation and foot mass is recovered (property)."""
    rot = (_rot(2, yaw) @ _rot(0, roll))[None]
    s = np.array([[0.005, -0.01, 0.035]])
    com = np.array([0.0, 0.002, 0.01])
    f, t = sensor_wrench(
        np.array([[px, py]]), np.array([[1.0, -2.0, w]]), np.array([0.1]), rot, s, mass, com
    )
    cop, fz = cop_from_wrench(f, t, rot, s, foot_mass=mass, foot_com=com)
    assert cop[0] == pytest.approx([px, py], abs=1e-12)
    assert fz[0] == pytest.approx(w, rel=1e-12)


def test_foot_alone_puts_the_cop_under_its_com():
    """With nothing above the sensor the CoP is the foot's CoM and fz its weight."""
    cop, fz = cop_from_wrench(
        [0, 0, 0], [0, 0, 0], np.eye(3), [0, 0, 0.03], foot_mass=0.2, foot_com=[0.01, 0.02, 0.01]
    )
    assert cop == pytest.approx([0.01, 0.02])
    assert fz == pytest.approx(0.2 * G0)


def test_unloaded_samples_have_no_cop():
    """Samples with fz at or below min_force give a NaN CoP but keep their fz."""
    f = np.array([[0, 0, 10.0], [0, 0, 0.5], [0, 0, -3.0]])
    cop, fz = cop_from_wrench(f, np.zeros((3, 3)), np.eye(3), [0, 0, 0.03], min_force=1.0)
    assert np.isfinite(cop[0]).all() and np.isnan(cop[1:]).all()
    assert fz.tolist() == [10.0, 0.5, -3.0]


def test_foot_mass_without_com_is_an_error():
    """A foot mass without its CoM is rejected with a message naming foot_com."""
    with pytest.raises(SescidError, match="foot_com"):
        cop_from_wrench([0, 0, 1.0], [0, 0, 0], np.eye(3), [0, 0, 0], foot_mass=0.1)


def test_rpy_matrix_is_urdf_order():
    """rpy_matrix is Rz(yaw) Ry(pitch) Rx(roll), also for stacked angles."""
    a = np.array([[0.3, -0.2, 1.1], [0.0, 0.5, -2.0]])
    want = np.stack([_rot(2, y) @ _rot(1, p) @ _rot(0, r) for r, p, y in a])
    assert np.allclose(rpy_matrix(a), want, atol=1e-15)


def test_plate_centroid_and_foot_pose():
    """A sole point load spread bilinearly over four plate cells comes back (sole frame)."""
    cells = np.array([[0.0, 0.0], [0.4, 0.0], [0.0, 0.3], [0.4, 0.3]])
    rng = np.random.default_rng(2)
    n = 100
    pose = np.array([0.2, 0.15, 0.7])
    p_sole = rng.uniform(-0.04, 0.04, size=(n, 2))
    c, s = np.cos(pose[2]), np.sin(pose[2])
    p_plate = pose[:2] + p_sole @ np.array([[c, s], [-s, c]])
    u, v = p_plate[:, 0] / 0.4, p_plate[:, 1] / 0.3
    w = rng.uniform(10, 40, n)
    loads = w[:, None] * np.stack([(1 - u) * (1 - v), u * (1 - v), (1 - u) * v, u * v], 1)
    cop, fz = cop_from_plate(loads, cells, pose)
    assert np.abs(cop - p_sole).max() < 1e-14
    assert np.allclose(fz, w)
    assert np.allclose(plate_to_sole(p_plate, pose), p_sole)


def test_plate_shape_mismatch():
    """More loads than cells is an error naming both counts."""
    with pytest.raises(SescidError, match="5 loads per sample for 4 cells"):
        cop_from_plate(np.ones((2, 5)), np.zeros((4, 2)))


@pytest.mark.parametrize("surface_z", [0.04, -0.04, 0.0])
def test_force_plate_point_load(surface_z):
    """A load with shear and a free moment at a surface point gives back that point."""
    rng = np.random.default_rng(3)
    n = 50
    p = np.column_stack([rng.uniform(-0.2, 0.2, size=(n, 2)), np.full(n, surface_z)])
    f = np.column_stack([rng.normal(0, 5, size=(n, 2)), rng.uniform(50, 300, n)])
    m = np.cross(p, f) + rng.normal(0, 1, n)[:, None] * [0, 0, 1.0]
    cop, fz = cop_from_force_plate(np.hstack([f, m]), surface_z)
    assert np.abs(cop - p[:, :2]).max() < 1e-13
    cop2, fz2 = cop_from_force_plate(-np.hstack([f, m]), surface_z)  # action instead of reaction
    assert np.abs(cop2 - p[:, :2]).max() < 1e-13 and np.allclose(fz2, fz)


def test_force_plate_amti_textbook_formula():
    """With surface_z = −dz (z down, origin dz below the surface) it is the manuals' formula."""
    fx, fy, fz, mx, my, dz = 3.0, -2.0, 200.0, 5.0, -7.0, 0.041
    cop, _ = cop_from_force_plate([fx, fy, fz, mx, my, 0.3], -dz)
    assert cop == pytest.approx([(-my - fx * dz) / fz, (mx - fy * dz) / fz])


def test_load_plate_json_and_yaml(tmp_path):
    """Plate files load from JSON and YAML with their unit."""
    j = tmp_path / "p.json"
    j.write_text(json.dumps({"format": "sescid-plate/1", "cells_m": [[0, 0], [1, 0], [0, 1]]}))
    assert load_plate(j).cells.shape == (3, 2)
    y = tmp_path / "p.yaml"
    y.write_text(
        "format: sescid-plate/1\nforce_unit: kgf\ncells_m:\n- [0, 0]\n- [0.4, 0]\n- [0, 0.3]\n"
    )
    plate = load_plate(y)
    assert plate.force_unit == G0 and plate.cells[1].tolist() == [0.4, 0.0]


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("format: other\n", "not a plate file"),
        ("format: sescid-plate/1\ncells_m: [[0, 0], [1, 1], [2, 2]]\n", "on a line"),
        ("format: sescid-plate/1\ncells_m: [[0, 0], [1]]\n", "cells_m"),
        ("format: sescid-plate/1\ncells_m: [[0,0],[1,0],[0,1]]\nforce_unit: lb\n", "force_unit"),
        ("format: sescid-plate/1\ncells_m: [[0,0],[1,0],[0,1]]\ncels: 1\n", "unknown field"),
        ("format: [unclosed\n", "not a YAML file"),
    ],
)
def test_load_plate_errors(tmp_path, text, match):
    """Each bad plate file gives one line naming the file and the field."""
    p = tmp_path / "plate.yaml"
    p.write_text(text)
    with pytest.raises(SescidError, match=match) as exc:
        load_plate(p)
    assert str(p) in str(exc.value) and "\n" not in str(exc.value)
