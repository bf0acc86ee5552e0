"""Hostile inputs, as a new user would try them: each case's exit code, one-line message and
what is left on disk (issue 13's table)."""

from __future__ import annotations

import os

import pytest
from click.testing import CliRunner

from sescid.cli import cli


def run(*args) -> tuple[int, str]:
    """Exit code and combined output of ``sescid ARGS``."""
    res = CliRunner().invoke(cli, [str(a) for a in args])
    if res.exception is not None and not isinstance(res.exception, SystemExit):
        raise res.exception  # a traceback is a failure of the case, never an answer
    return res.exit_code, res.output


@pytest.fixture(scope="module")
def bench(tmp_path_factory):
    """A small walk-through: poses (CSV), raw log, measured CoPs, a weighted fit."""
    d = tmp_path_factory.mktemp("bench")
    poses, raw, measured, fit = d / "poses.csv", d / "raw.csv", d / "measured.csv", d / "fit.json"
    steps = [
        ("poses", "--count", 24, "--candidates", 400, "--test-poses", 50, "--out", poses),
        ("experiment", "--poses", poses, "--samples", 20, "--out", raw),
        ("fsr", raw, "--poses", poses, "--out", measured),
        ("identify", measured, "--weighted", "--out", fit),
    ]
    for step in steps:
        code, out = run(*step)
        assert code == 0, out
    return {"dir": d, "poses": poses, "raw": raw, "measured": measured, "fit": fit}


# --- 1. outputs never destroy inputs; all of a command's outputs or none ----------------------


def test_fsr_refuses_to_overwrite_its_raw_log(bench):
    """`fsr raw.csv --out raw.csv`: exit 2, one line, the robot's raw log intact."""
    before = bench["raw"].read_bytes()
    code, out = run("fsr", bench["raw"], "--out", bench["raw"])
    assert code == 2 and "also an input" in out and out.count("\n") == 1
    assert bench["raw"].read_bytes() == before


def test_export_refuses_its_fit_and_experiment_its_pose_list(bench, tmp_path):
    """`export fit.json --out fit.json` and `experiment --out X --truth X` are refused."""
    code, out = run("export", bench["fit"], "--out", bench["fit"])
    assert code == 2 and "also an input" in out
    x = tmp_path / "x.csv"
    code, out = run("experiment", "--poses", bench["poses"], "--out", x, "--truth", x)
    assert code == 2 and "twice" in out and not x.exists()
    code, out = run("experiment", "--poses", bench["poses"], "--out", bench["poses"])
    assert code == 2 and "also an input" in out


def test_write_protected_output_needs_force(bench, tmp_path):
    """A write-protected output is refused with a hint; --force replaces it."""
    out_file = tmp_path / "pred.csv"
    out_file.write_text("keep\n")
    out_file.chmod(0o444)
    code, out = run("predict", bench["fit"], bench["poses"], "--out", out_file)
    assert code == 2 and "write-protected" in out and "--force" in out
    assert out_file.read_text() == "keep\n"
    code, out = run("predict", bench["fit"], bench["poses"], "--out", out_file, "--force")
    assert code == 0, out
    assert out_file.read_text().startswith("cop_x")


def test_no_partial_output_when_a_later_output_cannot_be_written(bench, tmp_path):
    """`poses --figure nodir/f.png` and `experiment --truth nodir/t.json` fail before writing:
    neither the pose CSV nor the raw log is left behind."""
    csv = tmp_path / "p.csv"
    code, out = run("poses", "--count", 21, "--out", csv, "--figure", tmp_path / "no" / "f.png")
    assert code == 2 and "does not exist" in out and not csv.exists()
    raw = tmp_path / "raw.csv"
    code, out = run(
        "experiment", "--poses", bench["poses"], "--out", raw, "--truth", tmp_path / "no" / "t.json"
    )
    assert code == 2 and "does not exist" in out and not raw.exists()
    assert sorted(os.listdir(tmp_path)) == []


def test_demo_and_report_leave_no_folder_on_failure(bench, tmp_path):
    """`demo --poses 10` (too few poses) creates no folder; `report` on data that does not
    match the fit leaves no report folder and no temporary."""
    code, out = run("demo", "--poses", 10, "--out-dir", tmp_path / "demo")
    assert code == 2 and not (tmp_path / "demo").exists()
    bad = tmp_path / "bad.csv"
    bad.write_text("pose,cop_x,cop_y\n0,0,0\n")
    code, out = run("report", bench["fit"], bad, "--out-dir", tmp_path / "rep")
    assert code == 2 and out.count("\n") == 1
    assert sorted(os.listdir(tmp_path)) == ["bad.csv"]


def test_report_writes_its_folder_and_refuses_an_input_inside_it(bench, tmp_path):
    """`report` writes its page and five figures into the folder; a folder holding the fit
    under the name of a report file is refused before anything is written."""
    rep = tmp_path / "rep"
    code, out = run("report", bench["fit"], bench["measured"], "--out-dir", rep)
    assert code == 0, out
    assert len(list(rep.glob("*.png"))) == 5 and (rep / "report.html").is_file()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]
    trap = tmp_path / "trap"
    trap.mkdir()
    fit_copy = trap / "report.html"
    fit_copy.write_bytes(bench["fit"].read_bytes())
    code, out = run("report", fit_copy, bench["measured"], "--out-dir", trap)
    assert code == 2 and "also an input" in out
    assert fit_copy.read_bytes() == bench["fit"].read_bytes()
    assert sorted(p.name for p in trap.iterdir()) == ["report.html"]
