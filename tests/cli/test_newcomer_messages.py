"""What a user sees on a robot sescid ships nothing for: messages that name the way on."""

from __future__ import annotations

from cli_run import STICK_URDF
from cli_run import outcome as run


def test_a_robot_without_a_layout_is_told_how_to_measure(tmp_path):
    """No sensor layout ships: the error names --sensors and --torques all (not a clone's
    path); with --torques all the log's line names no foot-pad noise it never applied."""
    urdf = tmp_path / "stick.urdf"
    urdf.write_text(STICK_URDF)
    r = ("--robot", urdf, "--support", "foot")
    poses = tmp_path / "poses.csv"
    code, text = run("simulate", *r, "--count", 5, "--range-deg", 10, "--out", poses)
    assert code == 0, text
    assert "real robot: the model (3.0000 kg) plus 0.2100 kg it lacks" in text
    raw = tmp_path / "raw.csv"
    code, text = run("experiment", *r, "--poses", poses, "--out", raw)
    assert code == 2 and "--sensors FILE" in text and "--torques all" in text, text
    assert "src/sescid" not in text and not raw.exists()
    code, text = run("experiment", *r, "--torques", "all", "--poses", poses, "--out", raw)
    assert code == 0, text
    assert "torques on 1 joints" in text and "FSR" not in text, text


def test_simulate_extra_mass_zero_is_the_model_itself(tmp_path):
    urdf = tmp_path / "stick.urdf"
    urdf.write_text(STICK_URDF)
    out = tmp_path / "s.csv"
    code, text = run("simulate", "--robot", urdf, "--support", "foot", "--count", 5,
                     "--extra-mass", 0, "--out", out)  # fmt: skip
    assert code == 0 and "the robot simulated is the model itself (3.0000 kg" in text, text


def test_simulate_balance_is_of_a_robot_that_differs_from_its_model(tmp_path):
    """--measure balance simulates the real robot too (it refused --extra-mass and balanced the
    model itself, so a fit could only keep it): its true tilts are not the model's, and with
    --extra-mass 0 they are, to rounding."""
    import numpy as np

    import sescid
    from sescid.sesc import balance_tilt
    from sescid.tables import read_table

    robot = sescid.load_robot("wheeled_humanoid", support="axle", line="y")
    tilts = []
    for extra in ("0.07", "0"):
        out = tmp_path / f"b{extra}.csv"
        code, text = run("simulate", "--robot", "wheeled_humanoid", "--support", "axle",
                         "--line", "y", "--count", 30, "--extra-mass", extra,
                         "--out", out)  # fmt: skip
        assert code == 0, text
        t = read_table(out)
        q = np.column_stack([t.get(j) for j in robot.joint_names])
        model, _ = balance_tilt(robot.tree, robot.line, q, robot.sesc_vectors())
        tilts.append((t.get("balance_tilt_true"), model))
    (real, model), (itself, model0) = tilts
    assert np.max(np.abs(real - model)) > 1e-3  # rad: the unmodelled masses tilt it
    np.testing.assert_allclose(itself, model0, atol=1e-12)
