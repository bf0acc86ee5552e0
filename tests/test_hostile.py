"""Hostile inputs, as a new user would try them: each case's exit code, one-line message and
what is left on disk (issue 13's table)."""

from __future__ import annotations

import csv
import json
import os
from pathlib import Path

import numpy as np
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
        ("experiment", "--poses", poses, "--samples", 20, "--out", raw, "--truth", d / "t.json"),
        ("fsr", raw, "--poses", poses, "--out", measured),
        ("identify", measured, "--weighted", "--out", fit),
    ]
    for step in steps:
        code, out = run(*step)
        assert code == 0, out
    return {
        "dir": d,
        "poses": poses,
        "raw": raw,
        "measured": measured,
        "fit": fit,
        "truth": d / "t.json",
    }


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


# --- 2. garbage in: an error or a stored, printed warning -------------------------------------


@pytest.fixture(scope="module")
def sim(tmp_path_factory):
    """100 simulated poses within ±20° (some outside the OP2's joint limits)."""
    d = tmp_path_factory.mktemp("sim")
    path = d / "sim.csv"
    code, out = run("simulate", "--poses", 100, "--range-deg", 20, "--out", path)
    assert code == 0, out
    return path


def _rewrite(src: Path, dst: Path, edit) -> Path:
    """A copy of a CSV with each data row passed through ``edit(header, row)``."""
    lines = src.read_text().splitlines()
    header = lines[0].split(",")
    rows = [edit(header, line.split(",")) for line in lines[1:]]
    dst.write_text("\n".join([",".join(header)] + [",".join(r) for r in rows]) + "\n")
    return dst


def _drop_truth(header, row):
    return row


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (("simulate", "--range-deg", 1000), "--range-deg: must be in (0, 180]"),
        (("simulate", "--poses", 10**11), "more than half this machine's memory"),
        (("simulate", "--seed", -1), "Invalid value for '--seed'"),
        (("poses", "--range-deg", 1000), "--range-deg: must be in (0, 180]"),
        (("identify", "{sim}", "--method", "map", "--prior-scale", "1e300"), "'--prior-scale'"),
        (("identify", "{sim}", "--rtol", "nan"), "rtol"),
        (("identify", "{sim}", "--online", "--online-step", 0), "--online-step"),
        (
            ("identify", "{sim}", "--method", "consistent", "--total-mass", 3130),
            "grams? the unit is kg",
        ),
    ],
)
def test_options_out_of_range_are_one_line_errors(sim, tmp_path, args, message):
    """Each out-of-range option exits 2 with a message naming it, before any output."""
    out = tmp_path / "out.csv"
    args = [sim if a == "{sim}" else a for a in args]
    code, text = run(*args, "--out", out)
    assert code == 2 and message in text, text
    assert not out.exists()


def test_angles_outside_the_joint_limits(sim, tmp_path):
    """Measured poses outside the limits are an error naming pose and joint; with
    --allow-outside-limits (or on simulated data) a warning printed and stored in the fit."""
    plain = tmp_path / "plain.csv"
    keep = [i for i, h in enumerate(sim.read_text().splitlines()[0].split(",")) if "_true" not in h]
    plain.write_text(
        "\n".join(
            ",".join(line.split(",")[i] for i in keep) for line in sim.read_text().splitlines()
        )
        + "\n"
    )
    fit = tmp_path / "fit.json"
    code, out = run("identify", plain, "--out", fit)
    assert code == 2 and "outside the model's joint limits (first: pose" in out
    code, out = run("identify", plain, "--allow-outside-limits", "--out", fit)
    assert code == 0 and "warning:" in out and "joint limits" in out
    assert any("joint limits" in w for w in json.loads(fit.read_text())["warnings"])


def test_one_pose_repeated_is_not_determined(sim, tmp_path):
    """100 copies of one pose: rank and condition are reported, and predictions elsewhere
    have nan ("not determined") intervals, never zero width."""
    lines = sim.read_text().splitlines()
    same = tmp_path / "same.csv"
    same.write_text("\n".join([lines[0]] + [lines[1]] * 100) + "\n")
    fit, pred = tmp_path / "fit.json", tmp_path / "pred.csv"
    code, out = run("identify", same, "--out", fit)
    assert code == 0 and "the data excite 2 of the 42" in out and "condition" in out
    code, out = run("predict", fit, sim, "--level", 0.95, "--out", pred)
    assert code == 0 and "not determined" in out
    rows = list(csv.DictReader(pred.open()))
    lower = np.array([float(r["cop_x_lower"]) for r in rows])
    assert np.isnan(lower[1:]).all() and np.isfinite(lower[0])


def test_all_zero_cop_is_flagged(sim, tmp_path):
    """An all-zero CoP (the collapsed model would fit it exactly) is anchored, never a fit of
    σ̂ = 0, and the suspicion of a dead sensor is stored and printed as a warning."""

    def zero(header, row):
        for c in ("cop_x", "cop_y"):
            row[header.index(c)] = "0"
        return row

    fit = tmp_path / "fit.json"
    code, out = run("identify", _rewrite(sim, tmp_path / "z.csv", zero), "--out", fit)
    assert code == 0 and "dead or unplugged foot sensor" in out and "σ̂ = 0" not in out
    assert "residual RMS 0.000 mm" not in out


def test_cop_in_millimetres_is_refused(sim, tmp_path):
    """CoP columns 1000× too large (mm for m) are refused naming row and column."""

    def mm(header, row):
        for c in ("cop_x", "cop_y"):
            row[header.index(c)] = str(float(row[header.index(c)]) * 1000)
        return row

    code, out = run("identify", _rewrite(sim, tmp_path / "mm.csv", mm), "--out", tmp_path / "f")
    assert code == 2 and "not a plausible CoP (columns are in metres)" in out


def test_excel_bom_long_field_and_one_row(sim, tmp_path):
    """A UTF-8 BOM (Excel) is read like the plain file; a field over 131 072 characters and a
    one-row file get one-line errors."""
    bom = tmp_path / "bom.csv"
    bom.write_text(sim.read_text(), encoding="utf-8-sig")
    code, out = run("identify", bom, "--out", tmp_path / "f.json")
    assert code == 0, out
    long = tmp_path / "long.csv"
    long.write_text(sim.read_text().splitlines()[0] + "\n" + "1" * 140_000 + "\n")
    code, out = run("identify", long, "--out", tmp_path / "g.json")
    assert code == 2 and "row 2" in out and out.count("\n") == 1
    one = tmp_path / "one.csv"
    one.write_text("\n".join(sim.read_text().splitlines()[:2]) + "\n")
    code, out = run("identify", one, "--out", tmp_path / "h.json")
    assert code == 2 and "too few" in out


def test_fit_json_with_null_and_sensor_files_with_garbage(bench, tmp_path):
    """A fit JSON with null in r, a sensor file with 1e999 or four sensors at one point: one
    line, exit 2."""
    d = json.loads(bench["fit"].read_text())
    d["r"][next(iter(d["r"]))][0] = None
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(d))
    code, out = run("predict", bad, bench["poses"], "--out", tmp_path / "p.csv")
    assert code == 2 and out.count("\n") == 1
    from sescid.robots.op2 import __file__ as op2_init

    cfg = json.loads((Path(op2_init).parent / "op2_fsr.json").read_text())
    inf = json.dumps(cfg).replace("0.085", "1e999")
    (tmp_path / "inf.json").write_text(inf)
    code, out = run(
        "fsr", bench["raw"], "--sensors", tmp_path / "inf.json", "--out", tmp_path / "m"
    )
    assert code == 2 and "finite" in out
    for foot in cfg["feet"].values():
        foot["sensors_m"] = [[0.0, 0.0]] * 4
    (tmp_path / "one.json").write_text(json.dumps(cfg))
    code, out = run(
        "fsr", bench["raw"], "--sensors", tmp_path / "one.json", "--out", tmp_path / "m"
    )
    assert code == 2 and "≥ 1 mm apart" in out


def test_truth_command_compares_with_the_real_robot(bench):
    """`sescid truth FIT TRUTH`: the identified model is closer to the "real" robot (7 % extra
    mass) than the manufacturer model, at the actual poses and at fresh poses near them."""
    import re

    code, out = run("truth", bench["fit"], bench["truth"], "--fresh", 300)
    assert code == 0, out
    pairs = re.findall(r"identified ([\d.]+) mm, manufacturer ([\d.]+) mm", out)
    assert len(pairs) == 2
    for ident, manuf in pairs:
        assert float(ident) < float(manuf)
    code, out = run("truth", bench["fit"], bench["fit"])
    assert code == 2 and "not an experiment truth file" in out


def test_api_refuses_degrees_and_millimetres(op2):
    """The Python API, like the readers, refuses angles in degrees, a CoP in mm and a CoP noise
    in mm, naming the pose and the joint or axis."""
    import sescid
    from sescid.errors import DataError, OptionError
    from sescid.estimation import Measurements

    s = sescid.simulate(op2, 60, seed=1)
    with pytest.raises(DataError, match=r"pose \d+, joint \w+: .* looks like degrees"):
        sescid.identify(op2, Measurements(q=np.degrees(s.q), cop=s.cop))
    with pytest.raises(DataError, match=r"cop_[xy] = .* not a plausible CoP"):
        sescid.identify(op2, Measurements(q=s.q, cop=s.cop * 1000))
    with pytest.raises(OptionError, match="not a plausible CoP noise"):
        sescid.simulate(op2, 10, noise=4.93)
    assert sescid.identify(op2, Measurements(q=s.q, cop=s.cop)).rank == 42  # the same in SI


def test_map_without_residual_does_not_claim_an_exact_fit(op2):
    """21 poses (42 equations, 42 combinations): MAP fits with the prior's help and says its
    noise rests on the prior, not that an exact fit was asked for."""
    import sescid

    s = sescid.simulate(op2, 21, seed=0)
    fit = sescid.identify(op2, s.q, s.cop, method="map")
    assert np.isfinite(fit.sigma_hat)
    text = " ".join(fit.warnings)
    assert "rest on the prior" in text and "exact fit was asked" not in text


def test_output_folder_in_a_read_only_place_names_the_folder(tmp_path, monkeypatch):
    """A folder output whose temporary cannot be created: the error names the output folder."""
    import tempfile

    from sescid.base.files import OutputSet
    from sescid.errors import DataError

    def refuse(*a, **k):
        raise PermissionError(13, "Permission denied", str(tmp_path / ".demo.x.tmp"))

    monkeypatch.setattr(tempfile, "mkdtemp", refuse)
    with pytest.raises(DataError, match=r"demo: cannot create the output folder \(Permission"):
        OutputSet([], [], folders=[tmp_path / "demo"]).folder(tmp_path / "demo")
