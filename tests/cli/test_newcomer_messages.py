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
