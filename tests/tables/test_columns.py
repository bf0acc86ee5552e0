"""The one reader of joint, CoP, torque, approach and pose-id columns: units at the boundary,
every error naming the file, row and column."""

from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner

import sescid
from sescid.cli import cli
from sescid.errors import DataError
from sescid.tables import (
    read_approach,
    read_gravity,
    read_joint_columns,
    read_table,
    read_torques,
    write_table,
)
from sescid.tables.columns import MAX_TORQUE_NM


def _table(tmp_path, cols, name="t.csv"):
    write_table(tmp_path / name, cols)
    return read_table(tmp_path / name)


def test_deg_columns_read_as_degrees(tmp_path):
    t = _table(tmp_path, {"a_deg": np.array([90.0, -45.0]), "b": np.array([0.1, 0.2])})
    q, units = read_joint_columns(t, ["a", "b"])
    assert np.array_equal(q[:, 0], np.radians([90.0, -45.0])) and units == {"a": "deg", "b": "rad"}


def test_deg_columns_through_the_commands(tmp_path, op2):
    """identify and predict on `<joint>_deg` columns give the radian file's numbers."""
    sim = sescid.simulate(op2, 40, noise=0.001, seed=5)
    rad = {j: sim.q[:, k] for k, j in enumerate(op2.joint_names)}
    deg = {f"{j}_deg": np.degrees(sim.q[:, k]) for k, j in enumerate(op2.joint_names)}
    cop = {"cop_x": sim.cop[:, 0], "cop_y": sim.cop[:, 1]}
    write_table(tmp_path / "rad.csv", rad | cop)
    write_table(tmp_path / "deg.csv", deg | cop)
    runner = CliRunner()
    for name in ("rad", "deg"):
        args = ["identify", str(tmp_path / f"{name}.csv"), "--allow-outside-limits"]
        res = runner.invoke(cli, [*args, "--out", str(tmp_path / f"{name}.json")])
        assert res.exit_code == 0, res.output
        res = runner.invoke(
            cli,
            [
                "predict",
                str(tmp_path / "rad.json"),
                str(tmp_path / f"{name}.csv"),
                "--out",
                str(tmp_path / f"p_{name}.csv"),
            ],
        )
        assert res.exit_code == 0, res.output
    r = [json.loads((tmp_path / f"{n}.json").read_text())["r"] for n in ("rad", "deg")]
    for body in r[0]:
        np.testing.assert_allclose(r[1][body], r[0][body], rtol=0, atol=1e-9)
    p = [read_table(tmp_path / f"p_{n}.csv") for n in ("rad", "deg")]
    np.testing.assert_allclose(p[1].get("cop_x"), p[0].get("cop_x"), rtol=0, atol=1e-12)


def test_torques_any_subset_with_standard_errors(tmp_path):
    t = _table(
        tmp_path,
        {
            "b": np.zeros(3),
            "tau_c": np.array([1.0, 2.0, 3.0]),
            "tau_a": np.array([-1.0, 0.5, 0.25]),
            "tau_se_c": np.array([0.1, 0.1, 0.2]),
            "tau_se_a": np.array([0.3, 0.3, 0.3]),
        },
    )
    tor = read_torques(t, ["a", "b", "c"])
    assert tor.joints == ("a", "c")  # model order
    assert np.array_equal(tor.tau, [[-1.0, 1.0], [0.5, 2.0], [0.25, 3.0]])
    assert np.array_equal(tor.se, [[0.3, 0.1], [0.3, 0.1], [0.3, 0.2]])
    none = read_torques(_table(tmp_path, {"a": np.zeros(2)}, "n.csv"), ["a"])
    assert none.joints == () and none.tau.shape == (2, 0) and none.se is None


@pytest.mark.parametrize(
    ("cols", "match"),
    [
        ({"tau_knee": [1.0, 2.0]}, r"column 'tau_knee': 'knee' is not a joint of the model"),
        ({"tau_a": [1.0, 2e4]}, r"row 3, column 'tau_a': 20000 is not a plausible joint torque"),
        ({"tau_a": [1.0, np.nan]}, r"row 3, column 'tau_a': value nan is not finite"),
        ({"tau_a": [1.0, 1.0], "tau_se_a": [0.1, -1]}, r"row 3, column 'tau_se_a'"),
        ({"tau_se_a": [0.1, 0.1]}, r"column 'tau_se_a' has no torque column"),
        ({"tau_a": [1.0, 1.0], "tau_b": [1.0, 1.0], "tau_se_a": [0.1, 0.1]}, r"'tau_se_b'"),
    ],
)
def test_torque_errors_name_file_row_and_column(tmp_path, cols, match):
    t = _table(tmp_path, {k: np.array(v) for k, v in cols.items()})
    with pytest.raises(DataError, match=match) as exc:
        read_torques(t, ["a", "b"])
    assert str(exc.value).startswith(str(tmp_path / "t.csv"))


def test_raw_log_torques_may_be_missing(tmp_path):
    (tmp_path / "raw.csv").write_text("pose,tau_a\n0,1.5\n0,\n")
    tor = read_torques(read_table(tmp_path / "raw.csv"), ["a"], allow_missing=True)
    assert tor.tau[0, 0] == 1.5 and np.isnan(tor.tau[1, 0])
    assert MAX_TORQUE_NM >= 1e3


def test_approach_column(tmp_path):
    t = _table(tmp_path, {"approach": np.array([1.0, -1.0, 1.0])})
    assert read_approach(t).tolist() == [1, -1, 1]
    assert read_approach(_table(tmp_path, {"a": np.zeros(1)}, "n.csv")) is None
    bad = _table(tmp_path, {"approach": np.array([1.0, 0.0])}, "b.csv")
    with pytest.raises(DataError, match=r"b.csv: row 3, column 'approach': 0 is not \+1 or -1"):
        read_approach(bad)
    (tmp_path / "x.csv").write_text("approach\n1\nup\n")
    with pytest.raises(DataError, match=r"x.csv: row 3, column 'approach': 'up'"):
        read_approach(read_table(tmp_path / "x.csv"))


def test_gravity_error_names_the_columns(tmp_path):
    t = _table(
        tmp_path, {"grav_x": np.zeros(2), "grav_y": np.zeros(2), "grav_z": np.array([-1, 1.0])}
    )
    with pytest.raises(DataError, match=r"t.csv: row 3, columns grav_x/y/z: gravity"):
        read_gravity(t)


@pytest.mark.parametrize(
    ("text", "match"), [("", "empty file"), ("a,b\n", "no data rows"), ("\n\n", "empty file")]
)
def test_empty_csv_files_name_the_file(tmp_path, text, match):
    (tmp_path / "e.csv").write_text(text)
    with pytest.raises(DataError, match=f"e.csv: {match}"):
        read_table(tmp_path / "e.csv")


def test_parquet_without_rows_names_the_file(tmp_path):
    """A Parquet file with columns and no row: 'no data rows' (was an empty table whose later
    errors named no file)."""
    write_table(tmp_path / "z.parquet", {"a": np.zeros(0)})
    with pytest.raises(DataError, match=r"z.parquet: no data rows"):
        read_table(tmp_path / "z.parquet")
    (tmp_path / "empty.parquet").write_bytes(b"")
    with pytest.raises(DataError, match=r"empty.parquet: cannot read Parquet"):
        read_table(tmp_path / "empty.parquet")


def test_one_row_file_reads(tmp_path):
    (tmp_path / "one.csv").write_text("a,cop_x\n0.5,0.01\n")
    t = read_table(tmp_path / "one.csv")
    assert t.n == 1 and read_joint_columns(t, ["a"])[0].shape == (1, 1)


def test_row_numbers_read_only_as_far_as_asked(tmp_path):
    """A row named in a warning about the first pose of a big file is found without reading
    the rest: a blank line makes the first data row the file's row 3, and a cell beyond the
    CSV reader's field limit further down (which would stop a whole-file scan) is never read."""
    from sescid.tables.rows import RowNumbers

    path = tmp_path / "t.csv"
    path.write_text("a,b\n\n1,2\n3,4\n5," + "9" * 200_000 + "\n")
    numbers = RowNumbers(path)
    assert numbers(0) == 3 and numbers(1) == 4


def test_measurements_of_a_streamed_file_keep_row_names_not_the_chunks(tmp_path, op2):
    """Each chunk's Measurements names its rows through the chunk's ``RowNames`` (first row,
    the file's row numbers), not a bound ``Table.where`` that would keep the chunk's columns
    alive as long as the fit keeps the row names (10⁶ poses: 636 → 321 MB peak); the names are
    the same."""
    from sescid.io.measurements import read_measurements
    from sescid.tables import write_table
    from sescid.tables.rows import RowNames

    q = np.zeros((5, op2.nq))
    cols = {j: q[:, k] for k, j in enumerate(op2.joint_names)}
    write_table(tmp_path / "m.csv", cols | {"cop_x": np.zeros(5), "cop_y": np.zeros(5)})
    (m,) = list(read_measurements(tmp_path / "m.csv", op2))
    assert isinstance(m.row_of, RowNames)
    assert m.at(3) == "row 5" and m.cell(0, "cop_x") == "row 2, column 'cop_x'"
