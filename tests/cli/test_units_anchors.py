"""Units and anchors at the data boundary (issue 35): a balance column in millimetres, a known
CoM height in inches, and a simulated file that identify cannot read are refused in one line."""

from __future__ import annotations

import numpy as np
import pytest
from cli_run import outcome as run

import sescid
from sescid.errors import DataError, OptionError
from sescid.estimation import Measurements, check_com_height
from sescid.estimation.data.anchor import com_distance
from sescid.robots import example_path
from sescid.simulation import simulate_balance
from sescid.tables import read_table, write_table

WHEELED = example_path("wheeled_humanoid")
ROBOT = ["--robot", str(WHEELED), "--support", "axle", "--line", "y"]


@pytest.fixture(scope="module")
def wheeled():
    return sescid.load_robot(WHEELED, "axle", line="y")


def test_balance_offsets_in_millimetres_are_refused(wheeled, tmp_path):
    """5 (mm meant: 0.005 m) in a balance column is refused naming the row; 5 mm is read."""
    sim = simulate_balance(wheeled, 30, seed=1)
    good = Measurements(q=sim.q, balance=np.full(30, 0.005), gravity=sim.gravity)
    sescid.identify(wheeled, good, method="map")
    with pytest.raises(DataError, match=r"pose 0, column 'balance': 5 m is not a plausible"):
        sescid.identify(wheeled, Measurements(q=sim.q, balance=np.full(30, 5.0),
                                              gravity=sim.gravity))  # fmt: skip
    code, out = run("simulate", *ROBOT, "--poses", 30, "--seed", 1, "--out", tmp_path / "w.csv")
    assert code == 0, out
    t = read_table(tmp_path / "w.csv")
    cols = {c: t.get(c) for c in t.columns} | {"balance": np.full(t.n, 5.0)}
    write_table(tmp_path / "mm.csv", cols)
    code, out = run("identify", tmp_path / "mm.csv", *ROBOT, "--out", tmp_path / "f.json")
    assert code == 2 and "mm.csv: row 2, column 'balance': 5 m" in out, out
    assert "millimetres for metres?" in out and not (tmp_path / "f.json").exists()


def test_a_com_height_in_inches_is_refused(wheeled, tmp_path):
    """--com-height 8.6 (inches) is refused against the model's height, as --total-mass is;
    a height within the range anchors the fit."""
    model = com_distance(wheeled, wheeled.sesc_vectors())
    check_com_height(wheeled, 1.2 * model)
    with pytest.raises(OptionError, match=r"com_height: 8.6 m .* \(inches\? the unit is m\)"):
        check_com_height(wheeled, 8.6)
    code, out = run("simulate", *ROBOT, "--poses", 30, "--seed", 1, "--out", tmp_path / "w.csv")
    assert code == 0, out
    code, out = run("identify", tmp_path / "w.csv", *ROBOT, "--com-height", 8.6,
                    "--out", tmp_path / "f.json")  # fmt: skip
    assert code == 2 and "--com-height: 8.6 m is not this robot's CoM height" in out, out
    code, out = run("identify", tmp_path / "w.csv", *ROBOT, "--com-height", round(model, 3),
                    "--out", tmp_path / "f.json")  # fmt: skip
    assert code == 0, out


def test_simulate_on_a_line_writes_only_what_identify_reads(tmp_path):
    """simulate --line y --measure tau (or cop) wrote a file identify with the same flags
    rejects; it is refused, and --measure balance round-trips."""
    for what in ("tau", "cop", "both"):
        code, out = run("simulate", *ROBOT, "--measure", what, "--out", tmp_path / "t.csv")
        assert code == 2 and f"--measure: {what}: a robot balancing on its line" in out, out
        assert not (tmp_path / "t.csv").exists()
