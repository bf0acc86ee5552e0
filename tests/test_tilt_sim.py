"""Tilted support in the simulations: simulate --tilt-deg and the kinematic bench's tilt_deg."""

from __future__ import annotations

import math

import numpy as np
from click.testing import CliRunner

import sescid
from sescid.cli import cli
from sescid.tables import read_table


def test_simulate_tilt_draws_gravity(op2):
    """simulate(tilt=σ): unit gravity with tilt angles of std σ; CoP = tilted statics; σ=0 level."""
    sim = sescid.simulate(op2, n=2000, noise=0.0, seed=0, tilt=math.radians(1.0))
    g = sim.gravity
    assert g is not None and np.allclose(np.linalg.norm(g, axis=1), 1.0, atol=1e-15)
    pitch = np.arcsin(g[:, 0])
    assert abs(np.std(pitch) - math.radians(1.0)) < 0.05 * math.radians(1.0)
    assert np.abs(sim.cop_true - op2.cop(sim.q, None, g)).max() < 1e-15
    assert np.abs(sim.cop_true - op2.cop(sim.q)).max() > 1e-3  # the tilt moves the CoP
    level = sescid.simulate(op2, n=50, seed=4)
    same = sescid.simulate(op2, n=50, seed=4, tilt=0.0)
    assert level.gravity is None and np.array_equal(level.cop, same.cop)


def test_cli_simulate_tilt_identify_truth(tmp_path):
    """`simulate --tilt-deg` writes grav_*; identify's truth line uses them (≈ 0 noise-free)."""
    data, fit = tmp_path / "sim.csv", tmp_path / "fit.json"
    args = ["simulate", "--count", "300", "--noise", "0", "--tilt-deg", "1", "--out", str(data)]
    res = CliRunner().invoke(cli, args)
    assert res.exit_code == 0, res.output
    assert {"grav_x", "grav_y", "grav_z"} <= set(read_table(data).names())
    res = CliRunner().invoke(cli, ["identify", str(data), "--out", str(fit)])
    assert res.exit_code == 0, res.output
    line = next(x for x in res.output.splitlines() if x.startswith("truth:"))
    assert float(line.split("poses ")[1].split(" mm")[0]) < 1e-6  # flat predictions: ~mm


def test_kinematic_bench_tilt(op2, tmp_path):
    """Kinematic bench with tilt_deg: grav_* logged; gravity-aware fit beats the flat one."""
    from sescid.bench import ExperimentConfig, run_experiment
    from sescid.planning import candidates
    from sescid.sensors import fsr, load_sensors
    from sescid.session.samples import raw_table

    sensors = load_sensors(None, op2.profile)
    q = candidates(op2, 60, seed=2).q
    cfg = ExperimentConfig(tilt_deg=1.0, backlash_deg=0.0)
    ex = run_experiment(op2, q, sensors, samples=20, seed=1, config=cfg)
    res, _ = fsr(op2, raw_table(ex.columns), sensors)
    t = ex.truth
    g = np.array(t.grav)
    d = res.data
    assert d.gravity is not None and np.abs(d.gravity - g).max() < 1e-12
    # the pads' centroid is the tilted CoP (pads on the sole plane)
    assert np.abs(np.array(t.cop_expected) - np.array(t.cop_true)).max() < 2e-3
    qa = np.array(t.q_actual)
    err = {}
    for label, grav in (("flat", None), ("gravity", d.gravity)):
        fit = sescid.identify(op2, d.q, d.cop, sigma=d.cop_se, gravity=grav, method="map")
        err[label] = np.sqrt(np.mean((fit.predict_cop(qa, g) - np.array(t.cop_true)) ** 2))
    assert err["gravity"] < 0.7 * err["flat"], err


def test_cli_predict_and_report_use_gravity(tmp_path):
    """predict and report on tilted data project along grav_*: report's RMS is the tilted one."""

    data, fit, pred = tmp_path / "sim.csv", tmp_path / "fit.json", tmp_path / "p.csv"
    run = CliRunner().invoke
    sim = ["simulate", "--count", "60", "--noise", "0.001", "--tilt-deg", "2", "--out", str(data)]
    assert run(cli, sim).exit_code == 0
    res = run(cli, ["identify", str(data), "--method", "map", "--out", str(fit)])
    assert res.exit_code == 0, res.output
    res = run(cli, ["predict", str(fit), str(data), "--level", "0.95", "--out", str(pred)])
    assert res.exit_code == 0, res.output
    p, d = read_table(pred).columns, read_table(data).columns
    f = sescid.load_fit(fit)
    q = np.column_stack([d[j] for j in f.robot.joint_names])
    g = np.column_stack([d["grav_x"], d["grav_y"], d["grav_z"]])
    assert np.abs(p["cop_x"] - f.predict_cop(q, g)[:, 0]).max() < 1e-12
    inside = (p["cop_x_lower"] <= d["cop_x_true"]) & (d["cop_x_true"] <= p["cop_x_upper"])
    assert inside.mean() > 0.85  # the tilted noise-free CoP is covered
    res = run(cli, ["report", str(fit), str(data), "--out-dir", str(tmp_path / "rep")])
    assert res.exit_code == 0, res.output
    rms = np.sqrt(np.mean((np.column_stack([d["cop_x"], d["cop_y"]]) - f.predict_cop(q, g)) ** 2))
    assert "identified mean" in res.output and f"RMS {rms * 1e3:.3f} mm" in res.output
