"""Older catalogue items at the data boundary (issue 35): calibrate names a dead pad, and CoP
cells left null in a Parquet file (or empty in a CSV) are reported, not fitted silently."""

from __future__ import annotations

import re

import numpy as np
import pytest
from cli_run import outcome as run

from sescid.tables import read_table


@pytest.fixture(scope="module")
def raw(tmp_path_factory):
    """A bench's raw log of 24 planned poses."""
    d = tmp_path_factory.mktemp("boundary")
    for step in (
        ("poses", "--count", 24, "--candidates", 400, "--test-poses", 50, "--out", d / "p.csv"),
        ("experiment", "--poses", d / "p.csv", "--samples", 20, "--out", d / "raw.csv",
         "--truth", d / "t.json"),
    ):  # fmt: skip
        code, out = run(*step)
        assert code == 0, out
    return d / "raw.csv"


def test_calibrate_names_a_dead_pad(raw, tmp_path):
    """A pad reading 0 in every sample: calibrate's error names its column (it said only
    "a loaded pad reading 0")."""
    lines = raw.read_text().splitlines()
    col = lines[0].split(",").index("r_fsr3")
    dead = tmp_path / "dead.csv"
    dead.write_text("\n".join([lines[0]] + [",".join(c if k != col else "0"
                                                    for k, c in enumerate(x.split(",")))
                                           for x in lines[1:]]) + "\n")  # fmt: skip
    code, out = run("calibrate", dead, "--out", tmp_path / "cal.json")
    assert code == 2 and "column 'r_fsr3' reads 0 in 24 of 24 poses" in out, out
    assert "dead pad" in out and out.count("\n") == 1


def test_a_null_cop_cell_is_reported(tmp_path):
    """One null cop_x in a Parquet file: the fit says so, naming the row (it was silent)."""
    pa = pytest.importorskip("pyarrow")
    pq = pytest.importorskip("pyarrow.parquet")
    code, out = run("simulate", "--poses", 60, "--seed", 1, "--clip", "--out", tmp_path / "s.csv")
    assert code == 0, out
    t = read_table(tmp_path / "s.csv")
    cols = {c: list(t.get(c)) for c in t.columns}
    cols["cop_x"][4] = None
    pq.write_table(pa.table(cols), tmp_path / "null.parquet")
    code, out = run("identify", tmp_path / "null.parquet", "--out", tmp_path / "f.json")
    assert code == 0, out
    assert (
        "1 CoP coordinate(s) not measured (empty or null cells; first: row 6, column "
        "'cop_x')" in out
    ), out
    code, out = run("identify", tmp_path / "s.csv", "--out", tmp_path / "g.json")
    assert code == 0 and "not measured" not in out
    assert np.isfinite(t.get("cop_x")).all()


def test_every_pose_approached_from_one_side_is_said(tmp_path):
    """Torques with every pose approached from one side: the offset and the friction band are
    confounded; the default fit (MAP) said the bands were "separated for 20 of 20 joints", it
    now says none is and that the prior split them; both sides: separated."""
    from sescid.tables import write_table

    data = tmp_path / "tau.csv"
    code, out = run("simulate", "--measure", "tau", "--tau-friction", 0.02, "--poses", 80,
                    "--seed", 3, "--clip", "--out", data)  # fmt: skip
    assert code == 0, out
    t = read_table(data)
    assert set(np.unique(t.get("approach"))) == {-1.0, 1.0}
    cols = {c: t.get(c) for c in t.columns} | {"approach": np.ones(t.n)}
    write_table(tmp_path / "one.csv", cols)
    code, out = run("identify", data, "--out", tmp_path / "a.json")
    assert code == 0 and "separated from the offsets for 20 of 20 joints" in out, out
    code, out = run("identify", tmp_path / "one.csv", "--out", tmp_path / "b.json")
    assert code == 0, out
    assert "separated from the offsets for 0 of 20 joints" in out, out
    assert "the prior, not the data, split their offset and band" in out
    assert re.search(r"tau\.offset\[\w+\]: decided by the prior: confounded with "
                     r"tau\.friction\[\w+\]", out)  # fmt: skip
    code, out = run("identify", tmp_path / "one.csv", "--method", "ls", "--out",
                    tmp_path / "c.json")  # fmt: skip
    assert code == 0 and "separated from the offsets for 0 of 20 joints" in out, out
