"""Measurement files read through the one column reader: torque and approach errors name the
file's own row (not a chunk's array index) and the column."""

from __future__ import annotations

import numpy as np
import pytest

import sescid
from sescid.errors import DataError
from sescid.io.measurements import read_measurements
from sescid.tables import write_table


def _file(path, robot, n=12, **extra):
    rng = np.random.default_rng(0)
    q = rng.uniform(-0.2, 0.2, (n, robot.nq))
    cols = {j: q[:, k] for k, j in enumerate(robot.joint_names)}
    j = robot.joint_names[2]
    cols |= {f"tau_{j}": np.linspace(-1, 1, n), f"tau_se_{j}": np.full(n, 0.05)}
    cols |= extra
    write_table(path, cols)
    return path, j


def test_torques_and_approach_read_from_a_file(tmp_path, op2):
    path, j = _file(tmp_path / "t.csv", op2, approach=np.where(np.arange(12) % 2, 1.0, -1.0))
    (m,) = list(read_measurements(path, op2, allow_outside_limits=True))
    assert m.tau_joints == (j,) and np.array_equal(m.tau[:, 0], np.linspace(-1, 1, 12))
    assert np.array_equal(m.tau_se[:, 0], np.full(12, 0.05))
    assert np.array_equal(m.approach, np.where(np.arange(12) % 2, 1, -1))


@pytest.mark.parametrize(
    ("change", "match"),
    [
        ("tau", r"t.csv: row 6, column 'tau_{j}': 20000 is not a plausible joint torque"),
        ("approach", r"t.csv: row 6, column 'approach': 0 is not \+1 or -1"),
        ("se", r"t.csv: row 6, column 'tau_se_{j}': -0.1 is not a standard error"),
        ("unknown", r"t.csv: column 'tau_knee': 'knee' is not a joint of the model"),
    ],
)
def test_bad_cells_name_the_file_row(tmp_path, op2, change, match):
    path, j = _file(tmp_path / "t.csv", op2, approach=np.ones(12))
    t = sescid.read_table(path)
    cols = {k: v.copy() for k, v in t.columns.items()}
    if change == "tau":
        cols[f"tau_{j}"][4] = 2e4
    elif change == "approach":
        cols["approach"][4] = 0.0
    elif change == "se":
        cols[f"tau_se_{j}"][4] = -0.1
    else:
        cols["tau_knee"] = np.zeros(12)
    write_table(path, cols)
    with pytest.raises(DataError, match=match.format(j=j)):
        list(read_measurements(path, op2, allow_outside_limits=True))
