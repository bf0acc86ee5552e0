"""Hostile inputs, as a new user would try them: each case's exit code, one-line message and
what is left on disk (issue 13's table)."""

from __future__ import annotations

import csv
import json
import os
import re
from pathlib import Path

import numpy as np
import pytest
from cli_run import STICK_URDF
from cli_run import outcome as run
from click.testing import CliRunner

from sescid.cli import cli
from sescid.tables import read_table


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
    code, out = run("poses", "--count", 22, "--out", csv, "--figure", tmp_path / "no" / "f.png")
    assert code == 2 and "does not exist" in out and not csv.exists()
    raw = tmp_path / "raw.csv"
    code, out = run(
        "experiment", "--poses", bench["poses"], "--out", raw, "--truth", tmp_path / "no" / "t.json"
    )
    assert code == 2 and "does not exist" in out and not raw.exists()
    assert sorted(os.listdir(tmp_path)) == []


def test_demo_and_report_leave_no_folder_on_failure(bench, tmp_path):
    """`demo --count 10` (too few poses) creates no folder; `report` on data that does not
    match the fit leaves no report folder and no temporary."""
    code, out = run("demo", "--count", 10, "--out-dir", tmp_path / "demo")
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
    code, out = run("simulate", "--count", 100, "--range-deg", 20, "--out", path)
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
        (("simulate", "--count", 10**11), "more than half this machine's memory"),
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
    assert code == 2 and re.search(
        r"outside the model's joint limits \(first: row \d+, column '", out
    )
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
    code, out = run("identify", one, "--method", "ls", "--out", tmp_path / "h.json")
    assert code == 2 and "too few" in out
    code, out = run("identify", one, "--out", tmp_path / "h.json")  # the default fits as MAP
    assert code == 0 and "no residual degrees of freedom" in out


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
    with pytest.raises(DataError, match=r"pose \d+, \w+: .* looks like degrees"):
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


# --- 3. usage errors: one line, exit 2, the closest command or option (issue 27) -------------


@pytest.mark.parametrize(
    ("args", "line"),
    [
        (("identfy", "x.csv"), "sescid: error: no command 'identfy' (did you mean identify?)"),
        (("xyz",), "sescid: error: no command 'xyz' (sescid --help lists them)"),
        (
            ("identify", "m.csv", "--weigted", "--out", "f.json"),
            "sescid: error: identify: no option --weigted (did you mean --weighted?)",
        ),
        (("--verbose",), "sescid: error: no option --verbose (did you mean --version?)"),
        (("identify",), "sescid: error: identify: Missing argument 'DATA...' (see sescid identify"),
        (("identify", "m.csv", "--out"), "sescid: error: identify: Option '--out' requires an"),
        (("identify", "m.csv", "--method", "lsq", "--out", "f"), "Invalid value for '--method'"),
        (("simulate", "--count", "0", "--out", "s.csv"), "Invalid value for '--count': 0 is"),
        (("poses", "--count", "abc", "--out", "p.csv"), "poses: Invalid value for '--count'"),
    ],
)
def test_usage_errors_are_one_line_with_a_suggestion(tmp_path, args, line):
    """A mistyped command or option, a missing argument or a bad value: one line
    `sescid: error: …` (the command named, the closest match suggested), exit 2."""
    res = CliRunner().invoke(cli, list(args))
    assert res.exit_code == 2 and res.output.count("\n") == 1, res.output
    assert res.output.startswith("sescid: error: ") and line in res.output, res.output
    assert "Usage:" not in res.output and "Try 'sescid" not in res.output


def test_api_option_errors_name_the_flag(tmp_path):
    """An options record's error names the command-line flag that set it (`budget` →
    `--budget`), and the count of `simulate` keeps its former name `--poses`."""
    code, out = run("session", "--adapter", "kinematic", "--budget", 5, "--no-view",
                    "--out-dir", tmp_path / "s")  # fmt: skip
    assert code == 2 and out.startswith("sescid: error: --budget: 5 poses cannot identify")
    assert not (tmp_path / "s").exists()
    code, out = run("simulate", "--poses", 7, "--out", tmp_path / "s.csv")
    assert code == 0 and "wrote" in out and len((tmp_path / "s.csv").read_text().splitlines()) == 8


# --- 4. errors name the file's row (header row 1) and column (issue 27) -----------------------


def _cells(src: Path, dst: Path, edits: dict[tuple[int, str], str], blank_after: int = 0) -> Path:
    """A copy of a CSV with cells replaced (file row, column) → text, and a blank line after
    file row ``blank_after`` (0: none)."""
    lines = src.read_text().splitlines()
    header = lines[0].split(",")
    out = []
    for k, line in enumerate(lines, start=1):
        cells = line.split(",")
        for (row, col), value in edits.items():
            if row == k:
                cells[header.index(col)] = value
        out.append(",".join(cells))
        if k == blank_after:
            out.append("")
    dst.write_text("\n".join(out) + "\n")
    return dst


def test_standard_error_rows_are_the_files(bench, tmp_path):
    """A zero or negative cop_se (the reader's check of a weighted fit) names the file's row
    and the column, with the header as row 1; a blank line above counts as a row."""
    m = bench["measured"]
    code, out = run("identify", _cells(m, tmp_path / "a.csv", {(6, "cop_se_y"): "0"}),
                    "--weighted", "--out", tmp_path / "f.json")  # fmt: skip
    assert code == 2 and "a.csv: row 6, column 'cop_se_y' = 0 m" in out, out
    bad = _cells(m, tmp_path / "b.csv", {(4, "cop_se_x"): "-0.001"}, blank_after=2)
    code, out = run("identify", bad, "--weighted", "--out", tmp_path / "f.json")
    assert code == 2 and "b.csv: row 5, column 'cop_se_x' = -0.001 m" in out, out
    text = _cells(m, tmp_path / "c.csv", {(9, "cop_x"): "abc"}, blank_after=3)
    code, out = run("identify", text, "--out", tmp_path / "f.json")
    assert code == 2 and "c.csv: row 10, column 'cop_x': 'abc' is not a number" in out, out
    assert not (tmp_path / "f.json").exists()


def test_torque_errors_name_row_and_column(tmp_path):
    """tau_se of 0, a NaN torque and an approach of 2 name the file's row and the column."""
    sim = tmp_path / "t.csv"
    code, out = run("simulate", "--count", 40, "--measure", "tau", "--tau-friction", 0.1,
                    "--out", sim)  # fmt: skip
    assert code == 0, out
    header = sim.read_text().splitlines()[0].split(",")
    joint = next(h for h in header if h.startswith("tau_") and not h.startswith("tau_se"))
    taus = [h for h in header if h.startswith("tau_") and not h.startswith("tau_se")]
    lines = sim.read_text().splitlines()
    se = tmp_path / "se.csv"
    extra = ",".join(f"tau_se_{t[4:]}" for t in taus)
    rows = [f"{x}," + ",".join(["0.01"] * len(taus)) for x in lines[1:]]
    rows[4] = rows[4][: -len("0.01")] + "0"  # file row 6, the last torque's standard error
    se.write_text("\n".join([f"{lines[0]},{extra}", *rows]) + "\n")
    joint = taus[-1]
    code, out = run("identify", se, "--weighted", "--out", tmp_path / "f.json")
    assert code == 2 and f"se.csv: row 6, column 'tau_se_{joint[4:]}' = 0 N·m" in out, out
    for cell, expect in (("nan", "is not finite"), ("2", "is not +1 or -1")):
        col = joint if cell == "nan" else "approach"
        bad = _cells(sim, tmp_path / "x.csv", {(8, col): cell})
        code, out = run("identify", bad, "--out", tmp_path / "f.json")
        assert code == 2 and f"x.csv: row 8, column '{col}'" in out and expect in out, out


# --- 5. a file that is not what the command reads (issue 27) ----------------------------------


def test_a_planned_pose_list_is_not_a_measurement(bench, tmp_path):
    """The planner's file carries the model's CoP as cop_x_model/cop_y_model (a prediction):
    `identify poses.csv` and `report fit poses.csv` refuse it in one line (it used to fit the
    model to itself and exit 0); experiment and predict still read it."""
    head = bench["poses"].read_text().splitlines()[0].split(",")
    assert "cop_x_model" in head and "cop_x" not in head
    for args in (
        ("identify", bench["poses"], "--out", tmp_path / "f.json"),
        ("report", bench["fit"], bench["poses"], "--out-dir", tmp_path / "r"),
    ):
        code, out = run(*args)
        assert code == 2 and out.count("\n") == 1, out
        assert "a planned pose list (cop_x_model, cop_y_model are the model's predictions" in out
    code, out = run("predict", bench["fit"], bench["poses"], "--out", tmp_path / "p.csv")
    assert code == 0, out
    assert sorted(p.name for p in tmp_path.iterdir()) == ["p.csv"]


def test_a_file_of_another_kind_says_what_it_is(bench, tmp_path):
    """A table reader given a fit, a truth, a sensor file, a model, a YAML mapping, binary
    data, a Parquet file named .csv or a semicolon CSV: one line saying what the file is."""
    from sescid.robots.op2 import __file__ as op2_init

    op2_dir = Path(op2_init).parent
    semi = tmp_path / "semi.csv"
    semi.write_text("pose;r_knee;cop_x\n0;0.1;0.01\n")
    binary = tmp_path / "bin.csv"
    binary.write_bytes(bytes(range(256)) * 8)
    yaml = tmp_path / "map.csv"
    yaml.write_text("format: sescid-bag-mapping/1\njoints:\n  topic: /joint_states\n")
    parquet = tmp_path / "pq.csv"
    import pyarrow as pa
    import pyarrow.parquet as pq

    pq.write_table(pa.table({"pose": [0, 1]}), parquet)
    cases = [
        (bench["truth"], "an experiment's truth (sescid experiment --truth), format sescid-exp"),
        (bench["fit"], "a fit (sescid identify --out), format sescid-fit/"),
        (op2_dir / "op2_fsr.json", "a foot-sensor file (--sensors)"),
        (op2_dir / "op2.urdf", "an XML file (a robot model?), not a table"),
        (yaml, "a YAML file (a mapping?), not a table"),
        (binary, "binary data, not a table"),
        (parquet, "a Parquet file without the .parquet name"),
        (semi, "the header is one column split by semicolons"),
    ]
    for path, what in cases:
        code, out = run("identify", path, "--out", tmp_path / "f.json")
        assert code == 2 and out.count("\n") == 1 and what in out, (path, out)
        assert out.startswith(f"sescid: error: {path}: ")
    assert not (tmp_path / "f.json").exists()


# --- 6. options that would do nothing, robots with nothing to measure (issue 27) -------------


@pytest.mark.parametrize(
    ("args", "line"),
    [
        (("experiment", "--poses", "{poses}", "--friction", "0.1", "0.3", "--out", "{out}"),
         "--friction: does nothing without --torques"),
        (("experiment", "--poses", "{poses}", "--approach", "up", "--out", "{out}"),
         "--approach: does nothing without --torques"),
        (("experiment", "--poses", "{poses}", "--mount", "gantry", "--out", "{out}"),
         "--mount: a robot held in a gantry loads no foot: nothing is measured without"),
        (("experiment", "--support", "MP_BODY", "--poses", "{poses}", "--mount", "gantry",
          "--torques", "all", "--fsr-gain", "0.05", "--out", "{out}"),
         "--fsr-gain: does nothing on a robot held in a gantry"),
        (("identify", "{measured}", "--gain-prior", "0.1", "--out", "{out}"),
         "--gain-prior: does nothing without --tau-gains"),
        (("identify", "{measured}", "--mc-draws", "5", "--out", "{out}"),
         "--mc-draws: does nothing without --joint-noise-deg"),
        (("identify", "{measured}", "--method", "ls", "--noise", "0.001", "--out", "{out}"),
         "--noise: does nothing without --method map (or auto) or --online"),
        (("simulate", "--tau-offset", "0.1", "--out", "{out}"), "--tau-offset: does nothing with"),
        (("simulate", "--measure", "tau", "--noise", "0.01", "--out", "{out}"),
         "--noise: does nothing with --measure tau"),
        (("poses", "--tau-joints", "r_knee", "--out", "{out}"), "--tau-joints: does nothing"),
        (("poses", "--support", "MP_BODY", "--kinds", "tau", "--count", "20", "--hang-height",
          "inf", "--out", "{out}"), "--hang-height: must be a finite height > 0 m, got inf"),
        (("session", "--adapter", "python:x.py:Robot", "--friction", "0", "0.1", "--out-dir",
          "{out}"), "--friction: does nothing with --adapter python:x.py:Robot"),
        (("session", "--adapter", "kinematic", "--no-view", "--view-linger", "5", "--out-dir",
          "{out}"), "--view-linger: does nothing with --no-view"),
    ],
)  # fmt: skip
def test_an_option_that_does_nothing_is_refused(bench, tmp_path, args, line):
    """An option given while it has no effect (a torque setting without torques, a gantry
    without torque sensors, a MAP setting of a least-squares fit, …) is one line, exit 2,
    before anything is written; it used to be accepted silently."""
    out = tmp_path / "out"
    given = {"{poses}": bench["poses"], "{measured}": bench["measured"], "{out}": out}
    code, text = run(*[given.get(a, a) for a in args])
    assert code == 2 and text.count("\n") == 1 and line in text, text
    assert list(tmp_path.iterdir()) == []


ONE_BODY = """<robot name="block"><link name="foot"><inertial><origin xyz="0.01 0 0.1"/>
<mass value="2"/><inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/>
</inertial><collision><origin xyz="0 0 0.1"/><geometry><box size="0.1 0.08 0.2"/></geometry>
</collision></link></robot>"""


def test_robots_with_nothing_to_measure(tmp_path):
    """A one-body robot: torques are refused by simulate and experiment (they wrote a 1-byte
    file, or failed in numpy); a one-joint robot with one pose and --allow-exact gives a fit
    that says what is not determined (it failed in LAPACK)."""
    block, stick = tmp_path / "block.urdf", tmp_path / "stick.urdf"
    block.write_text(ONE_BODY)
    stick.write_text(STICK_URDF)
    b = ("--robot", block, "--support", "foot")
    out = tmp_path / "o.csv"
    code, text = run("simulate", *b, "--measure", "tau", "--count", 10, "--out", out)
    assert (
        code == 2 and "block has no joints: there is no joint torque" in text and not out.exists()
    )
    code, text = run("simulate", *b, "--count", 10, "--out", tmp_path / "s.csv")
    assert code == 0, text
    code, text = run("experiment", *b, "--mount", "gantry", "--torques", "all", "--poses",
                     tmp_path / "s.csv", "--out", out)  # fmt: skip
    assert code == 2 and "the model has no joints to measure" in text and not out.exists()
    code, text = run("identify", tmp_path / "s.csv", *b, "--out", tmp_path / "f.json")
    assert code == 2 and "block has no joints: every pose is the same rigid body" in text, text
    code, text = run("poses", *b, "--count", 5, "--out", out)
    assert code == 2 and out.exists() is False and text.count("\n") == 1, text
    s = ("--robot", stick, "--support", "foot")
    code, text = run("simulate", *s, "--measure", "tau", "--count", 1, "--extra-mass", 0,
                     "--out", tmp_path / "t.csv")  # fmt: skip
    assert code == 0, text
    fit = tmp_path / "f.json"
    code, text = run("identify", tmp_path / "t.csv", *s, "--allow-exact", "--out", fit)
    assert code == 0 and "sigma_hat not determined" in text, text
    assert "not determined" in text and fit.is_file()


@pytest.fixture(scope="module")
def torque_raw(tmp_path_factory):
    """A raw log with joint torques and approach sides (kinematic bench), and its pose list."""
    d = tmp_path_factory.mktemp("traw")
    poses, raw = d / "poses.csv", d / "raw.csv"
    code, out = run("poses", "--count", 24, "--candidates", 400, "--test-poses", 50, "--out", poses)
    assert code == 0, out
    code, out = run("experiment", "--poses", poses, "--torques", "all", "--friction", 0.05, 0.1,
                    "--samples", 12, "--out", raw)  # fmt: skip
    assert code == 0, out
    return poses, raw


def _blank_cells(src: Path, dst: Path, column: str, pose: str | None) -> Path:
    """A raw log copy with ``column`` emptied in the samples of ``pose`` (None: every pose)."""
    lines = src.read_text().splitlines()
    header = lines[0].split(",")
    c, p = header.index(column), header.index("pose")
    out = [lines[0]]
    for line in lines[1:]:
        cells = line.split(",")
        if pose is None or cells[p] == pose:
            cells[c] = ""
        out.append(",".join(cells))
    dst.write_text("\n".join(out) + "\n")
    return dst


def test_measure_never_writes_an_undetermined_value(torque_raw, tmp_path):
    """A dead torque sensor (no value at any pose) is left out with a note; a pose without
    torque samples of one joint, or without its approach side, is dropped with the reason;
    the measured file always fits (it used to hold NaN that identify then refused)."""
    poses, raw = torque_raw
    cases = [
        ("tau_r_knee", None, "note: no usable tau_r_knee sample at any pose (a dead sensor?)"),
        ("tau_l_hip_roll", "3", "pose 3 dropped: too few usable samples of tau_l_hip_roll"),
        ("approach", "5", "pose 5 dropped: no 'approach' value in its samples"),
    ]
    for column, pose, line in cases:
        bad = _blank_cells(raw, tmp_path / "raw.csv", column, pose)
        out = tmp_path / "m.csv"
        code, text = run("measure", bad, "--poses", poses, "--out", out)
        assert code == 0 and line in text, text
        m = out.read_text()
        assert "nan" not in m.lower()
        if pose is None:
            assert column not in m.splitlines()[0].split(",")
        else:
            ids = [r.split(",")[0] for r in m.splitlines()[1:]]
            assert pose not in ids and len(ids) == 23
        code, text = run("identify", out, "--out", tmp_path / "f.json")
        assert code == 0, text


def _scaled_torques(src: Path, dst: Path, factor: float, only: str | None = None) -> Path:
    """A copy of a measured file with its tau_<joint> columns (or one) multiplied."""
    lines = src.read_text().splitlines()
    header = lines[0].split(",")
    cols = [i for i, h in enumerate(header) if h.startswith("tau_") and not h.startswith("tau_se")]
    cols = [i for i in cols if only is None or header[i] == only]
    out = [lines[0]]
    for line in lines[1:]:
        cells = line.split(",")
        for i in cols:
            cells[i] = repr(float(cells[i]) * factor)
        out.append(",".join(cells))
    dst.write_text("\n".join(out) + "\n")
    return dst


def test_torques_in_other_units_or_of_the_other_sign(torque_raw, bench, tmp_path):
    """identify refuses torques in mN·m by the physical bound measure uses (the robot's weight
    2 m from the joint) and torques of the reversed sign convention, naming the column; a fit
    of standing CoP data at a trunk support (a gantry's) is refused, not written."""
    poses, raw = torque_raw
    measured = tmp_path / "m.csv"
    assert run("measure", raw, "--poses", poses, "--out", measured)[0] == 0
    fit = tmp_path / "f.json"
    code, out = run("identify", _scaled_torques(measured, tmp_path / "mnm.csv", 1e3),
                    "--out", fit)  # fmt: skip
    assert code == 2 and "is more than the robot's weight at 2 m" in out and "mN·m" in out, out
    assert re.search(r"mnm.csv: row \d+, column 'tau_\w+' = ", out), out
    code, out = run("identify", _scaled_torques(measured, tmp_path / "neg.csv", -1), "--out", fit)
    assert code == 2 and "the torques are the model's with the opposite sign" in out, out
    code, out = run("identify", bench["measured"], "--support", "MP_BODY", "--out", fit)
    assert code == 2 and "a CoP fitted at a trunk: the support 'MP_BODY'" in out, out
    assert not fit.exists()


def test_raw_logs_and_repeated_files_are_not_pooled_poses(bench, tmp_path):
    """A raw log (one row per sample) given to identify, the same file twice (by path, link or
    copy) and a copied calibration session: one line each, nothing written."""
    fit = tmp_path / "f.json"
    raw = bench["raw"]
    code, out = run("identify", raw, "--out", fit)
    assert code == 2 and "a raw log (a 'sample' column" in out and "sescid measure" in out, out
    no_sample = tmp_path / "raw.csv"
    lines = raw.read_text().splitlines()
    col = lines[0].split(",").index("sample")
    no_sample.write_text("\n".join(",".join(c for k, c in enumerate(x.split(",")) if k != col)
                                   for x in lines) + "\n")  # fmt: skip
    code, out = run("identify", no_sample, "--out", fit)
    assert code == 2 and "row 2 and row 3 are both pose '0': one row per sample" in out, out
    m = bench["measured"]
    copy, link = tmp_path / "copy.csv", tmp_path / "link.csv"
    copy.write_bytes(m.read_bytes())
    link.symlink_to(m)
    for twice, what in ((m, "given twice as data"), (link, "given twice as data"),
                        (copy, "the same bytes as")):  # fmt: skip
        code, out = run("identify", m, twice, "--out", fit)
        assert code == 2 and what in out and "each pose would count twice" in out, out
    session = tmp_path / "session.csv"
    session.write_bytes(raw.read_bytes())
    code, out = run("calibrate", raw, session, "--total-mass", 3.13, "--out", tmp_path / "c.json")
    assert code == 2 and "a copy given twice as a session" in out, out
    assert not fit.exists() and not (tmp_path / "c.json").exists()


def test_columns_that_disagree_or_go_unused(bench, tmp_path):
    """A pose list whose <j>_deg or <j>_ticks copy was edited (it disagrees with the radians),
    IMU columns on a robot without a known IMU link (their gravity would be lost) and an
    --imu-link for a file without IMU columns: one line naming file, row and columns."""
    poses = bench["poses"]
    edited = _cells(poses, tmp_path / "p.csv", {(5, "r_knee_deg"): "12.5"})
    code, out = run("experiment", "--poses", edited, "--out", tmp_path / "r.csv")
    assert code == 2 and "p.csv: row 5: columns 'r_knee' (" in out, out
    assert "and 'r_knee_deg' (12.5°) disagree" in out
    ticks = _cells(poses, tmp_path / "t.csv", {(7, "l_el_ticks"): "100"})
    code, out = run("predict", bench["fit"], ticks, "--out", tmp_path / "o.csv")
    assert code == 2 and "t.csv: row 7: columns 'l_el' (" in out and "100 ticks" in out, out
    stick = tmp_path / "stick.urdf"
    stick.write_text(STICK_URDF)
    s = ("--robot", stick, "--support", "foot")
    sim = tmp_path / "s.csv"
    assert run("simulate", *s, "--count", 20, "--out", sim)[0] == 0
    lines = sim.read_text().splitlines()
    imu = tmp_path / "imu.csv"
    imu.write_text("\n".join([lines[0] + ",imu_roll,imu_pitch"]
                             + [x + ",0.01,0.02" for x in lines[1:]]) + "\n")  # fmt: skip
    code, out = run("identify", imu, *s, "--out", tmp_path / "f.json")
    assert code == 2 and "imu.csv: columns imu_roll, imu_pitch, but stick's profile" in out, out
    code, out = run("identify", sim, *s, "--imu-link", "body", "--out", tmp_path / "f.json")
    assert code == 2 and "--imu-link: 'body': " in out and "has no imu_roll" in out, out
    code, out = run("identify", imu, *s, "--imu-link", "body", "--out", tmp_path / "f.json")
    assert code == 0, out
    assert sorted(p.name for p in tmp_path.iterdir()) == ["f.json", "imu.csv", "p.csv", "s.csv",
                                                          "stick.urdf", "t.csv"]  # fmt: skip


def test_a_fit_of_an_older_file_format_says_so(bench, tmp_path):
    """A fit file of format sescid-fit/2 is read with a warning printed; its exact-fit
    covariance, stored as zeros by that version, is read as not determined (nan), so no
    interval comes out zero wide."""
    d = json.loads(bench["fit"].read_text())
    d["format"] = "sescid-fit/2"
    d["sigma_hat"] = None
    d["cov"] = [[0.0] * len(d["cov"])] * len(d["cov"])
    old = tmp_path / "old.json"
    old.write_text(json.dumps(d))
    pred = tmp_path / "p.csv"
    code, out = run("predict", old, bench["poses"], "--level", 0.95, "--out", pred)
    assert code == 0 and "an older fit file format 'sescid-fit/2'" in out, out
    rows = list(csv.DictReader(pred.open()))
    assert all(r["com_x_std"] == "nan" and r["cop_x_lower"] == "nan" for r in rows)


def test_dead_pads_and_forces_in_kilonewtons_are_named(bench, tmp_path):
    """A foot pad stuck at one value or without any value while the others vary (the CoP and
    the weight were silently wrong), and F/T forces in kN (every sample 'unloaded'): one line
    naming the column; the truth of another robot's fit names the fit and the truth."""
    raw = bench["raw"]
    lines = raw.read_text().splitlines()
    col = lines[0].split(",").index("r_fsr3")
    for value, what in (("0", "reads 0 in all"), ("", "has no value in the")):
        bad = tmp_path / "raw.csv"
        bad.write_text("\n".join([lines[0]] + [",".join(c if k != col else value
                                                        for k, c in enumerate(x.split(",")))
                                               for x in lines[1:]]) + "\n")  # fmt: skip
        code, out = run("measure", bad, "--poses", bench["poses"], "--out", tmp_path / "m.csv")
        assert code == 2 and f"column 'r_fsr3' {what}" in out and "dead" in out, out
    header = lines[0].split(",")
    keep = [k for k, h in enumerate(header) if "fsr" not in h]
    ft = tmp_path / "ft.csv"
    rows = [",".join([header[k] for k in keep] + ["r_cop_x", "r_cop_y", "r_fz"])]
    rows += [",".join([x.split(",")[k] for k in keep] + ["0.001", "-0.002", "0.0301"])
             for x in lines[1:]]  # fmt: skip
    ft.write_text("\n".join(rows) + "\n")
    code, out = run("measure", ft, "--poses", bench["poses"], "--out", tmp_path / "m.csv")
    assert code == 2 and "ft.csv: column 'r_fz': at most 0.0301 N" in out and "kN" in out, out
    assert not (tmp_path / "m.csv").exists()
    stick = tmp_path / "stick.urdf"
    stick.write_text(STICK_URDF)
    s = ("--robot", stick, "--support", "foot")
    assert run("simulate", *s, "--count", 20, "--out", tmp_path / "s.csv")[0] == 0
    assert run("identify", tmp_path / "s.csv", *s, "--out", tmp_path / "f.json")[0] == 0
    code, out = run("truth", tmp_path / "f.json", bench["truth"])
    assert code == 2 and out.startswith(f"sescid: error: {tmp_path / 'f.json'}: a fit of stick")
    assert f"but {bench['truth']} is the truth of op2 on 'r_sole'" in out, out


def test_a_pad_unloaded_through_one_pose_is_not_dead(bench, tmp_path):
    """A pad that reads 0 through one pose (its CoP at the other edge: the MuJoCo bench's
    left foot did this) while it varies elsewhere is measured, whichever chunk the pose falls
    in: the dead-pad rule judges the whole log (it judged the log's last pose alone)."""
    lines = bench["raw"].read_text().splitlines()
    header = lines[0].split(",")
    col, pose = header.index("r_fsr3"), header.index("pose")
    last = lines[-1].split(",")[pose]
    rows = [x.split(",") for x in lines[1:]]
    edited = [[c if (k != col or r[pose] != last) else "0" for k, c in enumerate(r)] for r in rows]
    raw = tmp_path / "raw.csv"
    raw.write_text("\n".join([lines[0]] + [",".join(r) for r in edited]) + "\n")
    code, out = run("measure", raw, "--poses", bench["poses"], "--out", tmp_path / "m.csv")
    assert code == 0, out
    assert len(read_table(tmp_path / "m.csv").columns["cop_x"]) == len({r[pose] for r in rows})


def test_export_writes_the_weighed_mass_the_fit_was_given(bench, tmp_path):
    """A fit made with --total-mass (CoP or torques) exports that mass by default (it wrote the
    model's 2.9253 kg); without one the export says the total is the model's."""
    fit = tmp_path / "f.json"
    code, out = run("identify", bench["measured"], "--weighted", "--total-mass", 3.13, "--out", fit)
    assert code == 0, out
    code, out = run("export", fit, "--out", tmp_path / "a.urdf")
    assert code == 0 and "(total 3.1300 kg, the weighed mass the fit was given)" in out, out
    code, out = run("export", bench["fit"], "--out", tmp_path / "b.urdf")
    assert code == 0 and "(total 2.9253 kg, the model's: weigh the robot" in out, out
    code, out = run("export", fit, "--total-mass", 3.0, "--out", tmp_path / "c.urdf")
    assert code == 0 and "(total 3.0000 kg, the given --total-mass)" in out, out


def test_report_names_poses_as_the_files_do(bench, tmp_path):
    """The report prints its page's path once (`wrote rep/report.html`, not `rep//…`); its
    per-pose figures are labelled with the files' pose ids (0–23 here, not 1–24)."""
    from sescid.report.figures import pose_ticks

    code, out = run("report", bench["fit"], bench["measured"], "--out-dir", f"{tmp_path}/rep/")
    assert code == 0 and f"wrote {tmp_path}/rep/report.html and" in out, out
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots()
    ax.plot(range(24), range(24))
    pose_ticks(ax, [str(k) for k in range(24)])
    ticks = [t.get_text() for t in ax.get_xticklabels()]
    assert ticks[0] == "0" and ticks[-1] == "22" and ax.get_xlabel() == "pose (id as in the file)"
    ax.cla()
    pose_ticks(ax, ["p3", "p0", "p1"])
    assert [t.get_text() for t in ax.get_xticklabels()] == ["p3", "p0", "p1"]
    plt.close(fig)


def test_a_torque_design_on_the_support_legs_joints(tmp_path):
    """Torque sensors on two support-leg joints see 36 combinations through 2 rows a pose: the
    D-optimal choice's Woodbury updates lost their digits there (a LinAlgError traceback, or
    'no candidate adds information'); it now plans, and a design that cannot determine the
    CoM says so."""
    out = tmp_path / "p.csv"
    args = ["poses", "--kinds", "tau", "--tau-joints", "r_knee,r_hip_pitch", "--candidates", 3000]
    code, text = run(*args, "--count", 38, "--out", out)
    assert code == 0 and "identifiable subspace: p = 36; chose 38 poses" in text, text
    assert len(out.read_text().splitlines()) == 39


def test_a_bug_is_one_line_without_a_traceback(bench, monkeypatch, tmp_path):
    """An exception sescid did not foresee still ends in one line and exit 1 (not 2: not the
    input's fault), naming it a bug; SESCID_TRACEBACK=1 (set for the tests) lets it through."""
    import sescid.cli.identify as cmd

    def broken(*a, **k):
        raise KeyError("cop")

    monkeypatch.setattr(cmd, "run_identify", broken)
    monkeypatch.delenv("SESCID_TRACEBACK", raising=False)
    out = str(tmp_path / "f.json")
    res = CliRunner().invoke(cli, ["identify", str(bench["measured"]), "--out", out])
    assert res.exit_code == 1 and res.output.count("\n") == 1, res.output
    assert res.output.startswith("sescid: internal error: KeyError: 'cop' (a bug in sescid")
    monkeypatch.setenv("SESCID_TRACEBACK", "1")
    res = CliRunner().invoke(cli, ["identify", str(bench["measured"]), "--out", out])
    assert isinstance(res.exception, KeyError)
