"""Physically implausible sensor data and settings are refused in one line naming the file,
row and column (issue 18's hostile cases in the sensor path)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from op2_stance import stable_poses

from sescid.bench import ExperimentConfig, run_experiment
from sescid.cli import cli
from sescid.errors import SescidError
from sescid.robots import profile_for
from sescid.sensors import fsr, load_sensors, measure, read_raw, table_from_columns
from sescid.tables import read_table, write_table

OP2_FSR = Path(profile_for("op2").sensors_file)
G = 9.80665


def _ft_log(path, robot, cop, fz, n=6):
    """A raw log of an ankle F/T foot: pose, joints (rad), r_cop_x/y (m), r_fz (N)."""
    cols = {"pose": np.repeat(["0", "1"], n // 2)}
    cols |= {j: np.zeros(n) for j in robot.joint_names}
    cols |= {"r_cop_x": cop[:, 0], "r_cop_y": cop[:, 1], "r_fz": fz}
    write_table(path, cols)
    return path


def _run(robot, path):
    config = load_sensors(None, robot.profile)
    return fsr(robot, read_table(path), config, min_samples=2)


def _one_line(res) -> str:
    assert res.exit_code == 2, res.output
    assert res.output.count("\n") == 1 and "Traceback" not in res.output
    return res.output


def test_reversed_ft_sign_is_one_line_not_nan_cops(op2, tmp_path):
    """Force and torque negated: the normal force pulls; refused naming the column."""
    cop = np.full((6, 2), 0.01)
    path = _ft_log(tmp_path / "rev.csv", op2, cop, np.full(6, -op2.total_mass * G))
    with pytest.raises(SescidError, match=r"rev.csv: column 'r_fz': .*sign is reversed"):
        _run(op2, path)


def test_absurd_normal_force_is_refused(op2, tmp_path):
    """`r_fz 1e30` (or mN in an N column) is not a standing robot."""
    fz = np.full(6, op2.total_mass * G)
    fz[3] = 1e30
    path = _ft_log(tmp_path / "big.csv", op2, np.full((6, 2), 0.01), fz)
    with pytest.raises(SescidError, match=r"big.csv: row 5, column 'r_fz': 1e\+30 N"):
        _run(op2, path)


def test_cop_outside_the_sole_is_refused(op2, tmp_path):
    """An F/T CoP 0.3 m outside the sole: a wrong frame, sign or unit, with row and column."""
    cop = np.full((6, 2), 0.01)
    cop[2, 0] = 0.3 + 0.0425
    path = _ft_log(tmp_path / "out.csv", op2, cop, np.full(6, 30.0))
    with pytest.raises(SescidError, match=r"out.csv: row 4, column 'r_cop_x': .* 300 mm outside"):
        _run(op2, path)
    cop[2, 0] = 0.0425 + 0.04  # 4 cm beyond the pads: still within the sole margin
    _run(op2, _ft_log(tmp_path / "ok.csv", op2, cop, np.full(6, 30.0)))


def _sensor_file(tmp_path, change) -> Path:
    doc = json.loads(OP2_FSR.read_text())
    change(doc)
    path = tmp_path / "s.json"
    path.write_text(json.dumps(doc).replace("Infinity_", "Infinity"))
    return path


def test_saturation_infinity_is_one_line(tmp_path):
    path = _sensor_file(tmp_path, lambda d: d.update(saturation_count="Infinity_"))
    path.write_text(path.read_text().replace('"Infinity"', "Infinity"))
    with pytest.raises(SescidError, match=r"s.json: saturation_count: .*finite number"):
        load_sensors(path)


def test_unknown_sole_frame_names_the_sensor_file(op2, tmp_path):
    path = _sensor_file(tmp_path, lambda d: d["feet"]["right"].update(sole_frame="r_shoe"))
    cfg = load_sensors(path)
    q = stable_poses(op2, 2, seed=1)
    ex = run_experiment(op2, q, load_sensors(None, op2.profile), samples=3, seed=0)
    with pytest.raises(SescidError, match=r"s.json: feet.right.sole_frame: 'r_shoe' is not a link"):
        fsr(op2, table_from_columns(ex.columns), cfg)
    res = CliRunner().invoke(
        cli,
        ["measure", str(_raw(tmp_path, ex)), "--sensors", str(path), "--out", str(tmp_path / "m")],
    )
    assert "s.json" in _one_line(res)


def _raw(tmp_path, ex) -> Path:
    path = tmp_path / "raw.csv"
    write_table(path, ex.columns)
    return path


def _calibrated(tmp_path, offsets, gains=(1.0, 1.0, 1.0, 1.0)) -> Path:
    def change(d):
        d["format"] = "sescid-fsr/2"
        for f in d["feet"].values():
            f["gains"], f["offsets_N"] = list(gains), list(offsets)

    return _sensor_file(tmp_path, change)


def test_offsets_times_1000_and_broken_gains_are_refused(op2, tmp_path):
    """Calibrated offsets ×1000 (0.1 N → 100 N) exceed a quarter of the robot's weight."""
    q = stable_poses(op2, 2, seed=2)
    ex = run_experiment(op2, q, load_sensors(None, op2.profile), samples=3, seed=0)
    table = table_from_columns(ex.columns)
    ok = load_sensors(_calibrated(tmp_path, [0.1, -0.1, 0.05, 0.0]))
    fsr(op2, table, ok, min_samples=2)
    big = load_sensors(_calibrated(tmp_path, [100.0, -100.0, 50.0, 0.0]))
    with pytest.raises(SescidError, match=r"s.json: feet.right.offsets_N: 100 N is more than 25%"):
        fsr(op2, table, big, min_samples=2)
    with pytest.raises(SescidError, match=r"s.json: feet.right.gains: .* must lie in"):
        load_sensors(_calibrated(tmp_path, [0.0] * 4, gains=(1.0, 1.0, 1000.0, 1.0)))


def test_nan_joints_are_missing_samples_not_poses(op2, tmp_path):
    """NaN read-backs drop those samples (counted as missing); the pose keeps the rest."""
    q = stable_poses(op2, 2, seed=3)
    ex = run_experiment(op2, q, load_sensors(None, op2.profile), samples=6, seed=0)
    cols = dict(ex.columns)
    ticks = cols["r_knee_ticks"].astype(float)
    ticks[[1, 2]] = np.nan
    cols["r_knee_ticks"] = ticks
    res, _ = fsr(op2, table_from_columns(cols), load_sensors(None, op2.profile), min_samples=2)
    assert res.n_used.tolist() == [4, 6] and res.reasons()[0] == "missing=2"
    assert np.all(np.isfinite(res.data.q))


def test_torque_columns_in_other_units_or_joints(op2, tmp_path):
    """tau in N·mm, a tau column of no joint, or an approach of 2: one line each."""
    q = stable_poses(op2, 2, seed=4)
    ex = run_experiment(op2, q, load_sensors(None, op2.profile), samples=4, seed=0)
    base = dict(ex.columns)
    n = len(base["pose"])
    cases = (
        ({"tau_r_knee": np.full(n, 1500.0)}, r"row 2, column 'tau_r_knee': 1500 N·m"),
        ({"tau_r_kne": np.zeros(n)}, r"column 'tau_r_kne': 'r_kne' is not a joint of the model"),
        ({"tau_r_knee": np.zeros(n), "approach": np.full(n, 2)}, r"column 'approach': 2 is not"),
    )
    config = load_sensors(None, op2.profile)
    for extra, match in cases:
        with pytest.raises(SescidError, match=match):
            fsr(op2, table_from_columns(base | extra), config)


def test_calibrate_bad_numbers_are_one_line(op2, tmp_path):
    """`calibrate --noise-force abc`, `--total-mass 1e-300`; --force exists and is honoured."""
    q = stable_poses(op2, 12, seed=5)
    ex = run_experiment(op2, q, load_sensors(None, op2.profile), samples=20, seed=0)
    raw = _raw(tmp_path, ex)
    out = tmp_path / "cal.json"
    run = CliRunner().invoke
    res = run(cli, ["calibrate", str(raw), "--noise-force", "raw=abc", "--out", str(out)])
    assert "--noise-force: raw=abc: expected a number" in _one_line(res)
    res = run(cli, ["calibrate", str(raw), "--total-mass", "1e-300", "--out", str(out)])
    assert "--total-mass: 1e-300 kg is not this robot's mass" in _one_line(res)
    assert not out.exists()
    res = run(cli, ["calibrate", str(raw), "--total-mass", "3.2", "--out", str(out)])
    assert res.exit_code == 0, res.output
    out.chmod(0o444)
    res = run(cli, ["calibrate", str(raw), "--total-mass", "3.2", "--out", str(out)])
    assert "write-protected (--force replaces it)" in _one_line(res)
    res = run(cli, ["calibrate", str(raw), "--total-mass", "3.2", "--out", str(out), "--force"])
    assert res.exit_code == 0, res.output


def test_measure_is_fsr(op2, tmp_path):
    """`sescid measure` is the reduction; `fsr` stays as its former name, same output."""
    q = stable_poses(op2, 3, seed=6)
    raw = _raw(tmp_path, run_experiment(op2, q, load_sensors(None, op2.profile), samples=5))
    run = CliRunner().invoke
    for cmd in ("measure", "fsr"):
        res = run(cli, [cmd, str(raw), "--out", str(tmp_path / f"{cmd}.csv")])
        assert res.exit_code == 0, res.output
    assert (tmp_path / "measure.csv").read_text() == (tmp_path / "fsr.csv").read_text()


def test_measure_and_read_raw_agree(op2, tmp_path):
    """``fsr`` is ``read_raw`` + ``measure`` (the table path and the array path)."""
    q = stable_poses(op2, 3, seed=7)
    ex = run_experiment(
        op2, q, load_sensors(None, op2.profile), samples=5, config=ExperimentConfig()
    )
    config = load_sensors(None, op2.profile)
    table = table_from_columns(ex.columns)
    a, _ = fsr(op2, table, config)
    b = measure(op2, read_raw(table, op2.joint_names, config, op2.profile.servo), config)
    assert np.array_equal(a.data.cop, b.data.cop) and np.array_equal(a.data.q, b.data.q)
