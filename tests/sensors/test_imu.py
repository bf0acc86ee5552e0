"""Gravity from an IMU's roll/pitch on a named link, through the model, against MuJoCo's."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from sescid.errors import DataError, OptionError
from sescid.sensors.imu import gravity_from_imu, gravity_in_link, read_imu, table_gravity
from sescid.tables import Table


def test_gravity_in_link_is_zyx_euler():
    """(sin θ, −cos θ sin φ, −cos θ cos φ) = R(ψ, θ, φ)ᵀ (0, 0, −1) for Z-Y-X Euler angles."""
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(0)
    ypr = rng.uniform(-1.2, 1.2, size=(20, 3))
    rot = Rotation.from_euler("ZYX", ypr).as_matrix()  # world ← link
    want = np.einsum("nji,j->ni", rot, [0.0, 0.0, -1.0])
    got = gravity_in_link(ypr[:, 2], ypr[:, 1])
    assert np.abs(got - want).max() < 1e-15


def test_gravity_from_imu_level_robot(op2):
    """A level sole: the torso's own roll/pitch at q give −z in the support frame exactly."""
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(1)
    q = rng.uniform(-0.3, 0.3, size=(5, op2.nq))
    rot, _ = op2.link_poses(q, "MP_BODY")  # support ← torso = world ← torso on a level sole
    ypr = Rotation.from_matrix(rot).as_euler("ZYX")
    g = gravity_from_imu(op2, q, ypr[:, 2], ypr[:, 1], "MP_BODY")
    assert np.abs(g - [0.0, 0.0, -1.0]).max() < 1e-14


def test_table_gravity_prefers_grav_columns(op2):
    """grav_x/y/z win over IMU columns; IMU columns need a link; bad angles are errors."""
    q = np.zeros((2, op2.nq))
    cols = {"imu_roll": np.array([0.01, 0.0]), "imu_pitch": np.array([0.0, -0.02])}
    g = table_gravity(op2, Table(Path("t.csv"), dict(cols), {}), q)  # profile link MP_BODY
    assert np.allclose(g[1], [np.sin(-0.02), 0.0, -np.cos(-0.02)], atol=1e-15)
    grav = {"grav_x": np.zeros(2), "grav_y": np.zeros(2), "grav_z": -np.ones(2)}
    g2 = table_gravity(op2, Table(Path("t.csv"), cols | grav, {}), q)
    assert np.array_equal(g2, np.tile([0.0, 0.0, -1.0], (2, 1)))
    with pytest.raises(OptionError, match="nope"):
        table_gravity(op2, Table(Path("t.csv"), dict(cols), {}), q, link="nope")
    with pytest.raises(DataError, match="imu_pitch"):
        read_imu(
            Table(Path("t.csv"), {"imu_roll": np.zeros(2), "imu_pitch": np.array([0, 30])}, {})
        )


@pytest.fixture(scope="module")
def bench_runs(op2):
    """Three free-standing MuJoCo poses, without and with backlash (10 samples each)."""
    pytest.importorskip("mujoco")
    from sescid.bench import ExperimentConfig
    from sescid.bench.mujoco import MujocoBenchConfig, run_mujoco_experiment
    from sescid.planning import candidates
    from sescid.sensors import load_sensors

    sensors = load_sensors(None, op2.profile)
    q = candidates(op2, 40, seed=3).q[:4]
    bench = MujocoBenchConfig(settle_time=6.0)
    return sensors, {
        b: run_mujoco_experiment(
            op2, q, sensors, samples=10, bench=bench, config=ExperimentConfig(backlash_deg=b)
        )
        for b in (0.0, 1.0)
    }


def test_imu_gravity_equals_bench_gravity(op2, bench_runs):
    """IMU roll/pitch through the model at the actual angles = the bench's gravity (< 1 µrad)."""
    _, runs = bench_runs
    t, c = runs[0.0].truth, runs[0.0].columns
    k = len(t.pose)
    roll, pitch = (
        np.asarray(c[n], dtype=float).reshape(k, -1)[:, 0] for n in ("imu_roll", "imu_pitch")
    )
    g = gravity_from_imu(op2, np.array(t.q_actual), roll, pitch, "MP_BODY")
    assert np.abs(g - np.array(t.grav)).max() < 1e-6  # measured 1.9e-7 (settling motion)
    assert np.array(t.physics.foot_tilt).max() > 1e-3  # the bench tilts, so this is a real check


def test_fsr_uses_imu_without_grav_columns(op2, bench_runs):
    """fsr without grav_* columns takes gravity from the IMU at the read-backs (ticks only)."""
    from sescid.sensors import fsr

    sensors, runs = bench_runs
    err = {}
    for b, ex in runs.items():
        c, t = ex.columns, ex.truth
        cols = {k: np.asarray(v, dtype=float) for k, v in c.items() if k != "pose"}
        cols = {k: v for k, v in cols.items() if not k.startswith("grav_")}
        table = Table(Path("raw"), cols, {"pose": [str(p) for p in c["pose"]]})
        res, _ = fsr(op2, table, sensors)
        keep = [list(t.pose).index(p) for p in res.pose]
        err[b] = np.linalg.norm(res.data.gravity - np.array(t.grav)[keep], axis=1).max()
    # read-back quantisation (MX-28 ticks, 1.5 mrad) over the leg chain: measured ≤ 1.2 mrad
    assert err[0.0] < 3e-3
    # unseen backlash (half of ±1° per joint) on the six leg joints: measured 7–12 mrad
    assert err[1.0] > err[0.0]
