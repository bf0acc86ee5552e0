"""One stance check for every way a stance arrives (issue 35, "Stances typed wrong"): a
``support`` column in any case, ``FILE@FRAME``, Measurements, and predict's rows; each refusal a
one-line error naming the file (and row) or the option."""

from __future__ import annotations

import re

import numpy as np
import pytest
from cli_run import outcome as run

import sescid
from sescid.errors import DataError, OptionError
from sescid.estimation import Measurements
from sescid.robots import example_path
from sescid.stance import Stance, data_stance, parse_stance
from sescid.tables import read_table, write_table

TRUNK = "MP_BODY"


def _relabel(table, label: str | None, header: str = "support") -> dict[str, np.ndarray]:
    cols = {c: table.get(c) for c in table.columns}
    if label is not None:
        cols[header] = np.full(table.n, label)
    return cols


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """Simulated CoP data on each sole (60 poses each), and the same rows relabelled."""
    d = tmp_path_factory.mktemp("stances")
    for side, seed, name in (("r_sole", 1, "r.csv"), ("l_sole", 2, "l.csv")):
        code, out = run("simulate", "--support", side, "--poses", 60, "--seed", seed,
                        "--out", d / name)  # fmt: skip
        assert code == 0, out
    r, l_ = read_table(d / "r.csv"), read_table(d / "l.csv")
    a, b = _relabel(r, "r_sole"), _relabel(l_, "l_sole")
    write_table(d / "both.csv", {c: np.concatenate([a[c], b[c]]) for c in a})
    write_table(d / "trunk.csv", _relabel(r, TRUNK))
    some = _relabel(r, "r_sole")
    some["support"] = np.array(["r_sole"] * (r.n - 1) + [TRUNK])  # one row at the trunk
    write_table(d / "some.csv", some)
    write_table(d / "cap.csv", _relabel(l_, "l_sole", "Support"))
    write_table(d / "bare_l.csv", _relabel(l_, None))
    return d


def _truth_mm(out: str) -> float:
    return float(re.findall(r"noise-free CoP at these poses ([\d.]+) mm", out)[-1])


@pytest.mark.parametrize("name", ["trunk.csv", "some.csv"])
def test_a_cop_at_a_trunk_is_refused_in_every_row_or_one(files, tmp_path, name):
    """A support column naming the trunk (every row, or the last) on a CoP file: refused with
    the file, row and column, as --support TRUNK is (it was fitted 53 mm off)."""
    code, out = run(
        "identify", files / name, "--allow-outside-limits", "--out", tmp_path / "f.json"
    )
    row = 2 if name == "trunk.csv" else 61
    assert code == 2 and f"{name}: row {row}, column 'support': '{TRUNK}'" in out, out
    assert "no centre of pressure" in out and out.count("\n") == 1
    assert not (tmp_path / "f").exists()
    code, out = run("identify", f"{files / 'bare_l.csv'}@{TRUNK}", "--out", tmp_path / "g.json")
    assert code == 2 and f"bare_l.csv@{TRUNK}: '{TRUNK}'" in out, out


def test_the_support_header_in_any_case(files, tmp_path):
    """'Support' is the support column: the left-foot rows are fitted on the left foot (they
    were fitted as right-foot ones, 48 mm off); two such headers are refused."""
    code, out = run("identify", files / "cap.csv", "--allow-outside-limits",
                    "--out", tmp_path / "f.json")  # fmt: skip
    assert code == 0, out
    code, ref = run("identify", f"{files / 'bare_l.csv'}@l_sole", "--allow-outside-limits",
                    "--out", tmp_path / "g.json")  # fmt: skip
    assert code == 0, ref
    assert _truth_mm(out) == _truth_mm(ref) < 1.0
    cols = _relabel(read_table(files / "cap.csv"), "l_sole") | {"SUPPORT": np.full(60, "l_sole")}
    write_table(tmp_path / "two.csv", cols)
    code, out = run("identify", tmp_path / "two.csv", "--out", tmp_path / "h.json")
    assert code == 2 and "'support', 'SUPPORT' both name each row's stance" in out, out


def test_file_at_frame_that_its_column_contradicts(files, tmp_path):
    """`l.csv@r_sole` where the column says l_sole is refused (the @ was ignored); an @ that
    agrees is read; an unknown frame names the file@frame."""
    code, out = run("identify", f"{files / 'l.csv'}@r_sole", "--out", tmp_path / "f.json")
    assert code == 2 and "column 'support' says 'l_sole', but" in out and "l.csv@r_sole" in out
    code, out = run("identify", f"{files / 'l.csv'}@l_sole", "--allow-outside-limits",
                    "--out", tmp_path / "f.json")  # fmt: skip
    assert code == 0, out
    code, out = run("identify", f"{files / 'l.csv'}@nope", "--out", tmp_path / "f.json")
    assert code == 2 and "l.csv@nope: " in out and "unknown support 'nope'" in out, out


def test_one_file_of_two_stances_reports_the_residuals_of_two_files(files, tmp_path):
    """The residual RMS/MAE of one file holding both stances are those of the two files (they
    were 76 mm against 4.7 mm: residual blocks spanned the two stances), and so with --robust
    (the in-memory path)."""
    figures = []
    for data in ([files / "both.csv"], [files / "r.csv", files / "l.csv"]):
        for extra in ((), ("--robust",)):
            code, out = run("identify", *data, "--method", "ls", *extra,
                            "--allow-outside-limits", "--out", tmp_path / "f.json")  # fmt: skip
            assert code == 0, out
            figures.append(re.search(r"residual RMS ([\d.]+) mm, MAE ([\d.]+) mm", out).groups())
            figures[-1] += (_truth_mm(out),)
    assert figures[0] == figures[2] and figures[1] == figures[3], figures
    assert float(figures[0][0]) < 6.0


def test_measurements_of_a_stance_that_cannot_measure_them(op2):
    """Arrays take the same check: a CoP held at a trunk, torques on both feet; an option's
    spelling is an OptionError naming it."""
    q = np.zeros((20, op2.nq))
    with pytest.raises(DataError, match=f"data: '{TRUNK}': a robot held there"):
        sescid.identify(op2, Measurements(q=q, cop=np.zeros((20, 2)), support=TRUNK))
    tau = op2.torques(q)
    m = Measurements(q=q, tau=tau, tau_joints=tuple(op2.joint_names), support="double")
    with pytest.raises(DataError, match="data: 'double': joint torques on both feet"):
        sescid.identify(op2, m)
    assert parse_stance("gantry:MP_BODY", op2).mount == "gantry"
    assert parse_stance(TRUNK, op2).mount == "gantry"
    own = Stance("r_sole", "stand")  # the reference's own support, in any spelling
    assert data_stance(op2, "stand:r_sole") == data_stance(op2, None) == (own, op2)
    # checked data carry it typed: a text resolved once, a Stance kept, the robot rooted there
    left = Measurements(q=q, cop=np.zeros((20, 2)), support="stand:l_sole").checked(op2)
    assert left.support == Stance("l_sole", "stand") == left.checked(op2).support
    assert Measurements(q=q, cop=np.zeros((20, 2))).checked(op2).support == own
    assert Measurements(q=q, support="double").stance_on(op2) == Stance("r_sole", "double")
    with pytest.raises(OptionError, match="support: .*unknown support 'toe'"):
        data_stance(op2, "toe", where="--support")


def test_predict_uses_each_rows_stance(files, tmp_path):
    """predict of a pooled fit on rows labelled with both stances predicts each in its own
    (the left rows were predicted in the right foot's frame, 150 mm off); --support agrees with
    the column or is refused; a trunk and a one-stance fit are refused naming file or option."""
    fit, one = tmp_path / "two.json", tmp_path / "one.json"
    for data, out in (((files / "r.csv", files / "l.csv"), fit), ((files / "r.csv",), one)):
        code, text = run("identify", *data, "--method", "ls", "--allow-outside-limits",
                         "--out", out)  # fmt: skip
        assert code == 0, text
    code, text = run("predict", fit, files / "both.csv", "--out", tmp_path / "both.csv")
    assert code == 0, text
    code, text = run("predict", fit, files / "l.csv", "--support", "l_sole",
                     "--out", tmp_path / "l.csv")  # fmt: skip
    assert code == 0, text
    both, left = read_table(tmp_path / "both.csv"), read_table(tmp_path / "l.csv")
    model = sescid.load_fit(fit)
    q = read_table(files / "both.csv")
    ql = np.column_stack([q.get(j) for j in model.robot.joint_names])
    np.testing.assert_allclose(both.get("cop_x")[60:], left.get("cop_x"), rtol=0, atol=0)
    np.testing.assert_allclose(both.get("cop_x")[:60], model.predict_cop(ql[:60])[:, 0], atol=0)
    truth = np.column_stack([q.get("cop_x_true"), q.get("cop_y_true")])
    got = np.column_stack([both.get("cop_x"), both.get("cop_y")])
    assert np.sqrt(np.mean((got - truth) ** 2)) < 0.003
    cases = [
        ((fit, files / "l.csv", "--support", TRUNK), f"support: '{TRUNK}': a robot held there"),
        ((fit, files / "l.csv", "--support", "r_sole"), "support: r_sole, but "),
        ((one, files / "l.csv"), f"l.csv: row 2, column 'support': 'l_sole': {one}: the fit "
         "was made in one stance ('r_sole')"),
        ((one, files / "l.csv", "--support", "l_sole"), f"support: l_sole: {one}: the fit was"),
        ((fit, files / "trunk.csv"), "trunk.csv: row 2, column 'support': 'MP_BODY': a robot"),
    ]  # fmt: skip
    for args, message in cases:
        code, text = run("predict", *args, "--out", tmp_path / "x.csv")
        assert code == 2 and message in text and text.count("\n") == 1, text
        assert not (tmp_path / "x.csv").exists()


def test_experiment_stands_each_planned_pose_on_its_stance(tmp_path):
    """A plan over two stances: experiment measures the rows of the stance it stands on and
    says where the others go (it stood every pose on the first stance and labelled it so);
    --mount double stands on both feet, labelled double (it stood on one foot)."""
    plan = tmp_path / "p.csv"
    code, out = run("poses", "--stances", "r_sole,l_sole", "--count", 30, "--candidates", 400,
                    "--out", plan)  # fmt: skip
    assert code == 0, out
    labels = np.array(read_table(plan).text["support"])
    for side in ("r_sole", "l_sole"):
        raw = tmp_path / f"{side}.csv"
        code, out = run("experiment", "--poses", plan, "--support", side, "--samples", 5,
                        "--out", raw)  # fmt: skip
        assert code == 0, out
        other = "l_sole" if side == "r_sole" else "r_sole"
        n = int(np.sum(labels == side))
        assert f"measuring the {n} poses planned for '{side}'" in out, out
        assert f"'{other}' (--support {other})" in out
        log = read_table(raw)
        assert set(log.text["support"]) == {side}
        planned = set(np.array(read_table(plan).get("pose"))[labels == side].astype(int))
        assert set(log.get("pose").astype(int)) <= planned
    code, out = run("experiment", "--poses", plan, "--double-support", "--samples", 5,
                    "--out", tmp_path / "d.csv")  # fmt: skip
    assert code == 2 and "planned for 'r_sole', 'l_sole' (column 'support')" in out, out
    assert not (tmp_path / "d.csv").exists()
    both = tmp_path / "pd.csv"
    code, out = run("poses", "--stances", "double", "--count", 25, "--candidates", 600,
                    "--out", both)  # fmt: skip
    assert code == 0, out
    code, out = run("experiment", "--poses", both, "--mount", "double", "--samples", 5,
                    "--out", tmp_path / "e.csv")  # fmt: skip
    assert code == 0 and "(double support)" in out, out
    log = read_table(tmp_path / "e.csv")
    assert set(log.text["support"]) == {"double"}
    left = sum(log.get(f"l_fsr{k}") for k in range(1, 5))
    assert np.median(left) > 100  # the left foot carries load: both feet on the floor


def test_measure_checks_each_samples_stance(tmp_path):
    """measure: a pose whose samples switch stance (it was written twice, from halves), an
    empty support cell (reported without its row) and a log whose stance disagrees with the
    plan's (accepted silently) are refused naming the row; a log as planned is read."""
    plan = tmp_path / "p.csv"
    code, out = run("poses", "--stances", "r_sole,l_sole", "--count", 30, "--candidates", 400,
                    "--out", plan)  # fmt: skip
    assert code == 0, out
    raw = tmp_path / "raw.csv"
    code, out = run("experiment", "--poses", plan, "--samples", 6, "--out", raw)
    assert code == 0, out
    code, out = run("measure", raw, "--poses", plan, "--out", tmp_path / "m.csv")
    assert code == 0, out
    log = read_table(raw)
    cols = {c: log.get(c) for c in log.columns}
    labels = np.array(log.text["support"], dtype=object)
    cases = {}
    switch = labels.copy()
    switch[3] = "l_sole"  # pose 0's fourth sample (rows 2–7 hold its six)
    cases["switch"] = (switch, "pose 0 switches stance between its samples ('r_sole' at row 2, "
                       "'l_sole' at row 5)")  # fmt: skip
    empty = labels.copy()
    empty[7] = ""
    cases["empty"] = (empty, "row 9, column 'support' is empty")
    cases["wrong"] = (np.full(len(labels), "l_sole"), "row 2: pose 0 was measured on 'l_sole', "
                      f"but {plan} plans it on 'r_sole'")  # fmt: skip
    for name, (values, message) in cases.items():
        bad = tmp_path / f"{name}.csv"
        write_table(bad, cols | {"support": values})
        code, out = run("measure", bad, "--poses", plan, "--out", tmp_path / "x.csv")
        assert code == 2 and message in out and out.count("\n") == 1, (name, out)
        assert not (tmp_path / "x.csv").exists()


def test_every_spelling_of_a_stance_in_a_plan_and_a_log(tmp_path):
    """A plan and a raw log whose support cells spell a held trunk ``gantry:TRUNK`` (a user's
    or a planner's spelling) and a foot: experiment measures the trunk's poses (it found none,
    "planned for 'MP_BODY', not for 'MP_BODY'"), and measure reduces the log exactly as the
    one labelled ``TRUNK`` (it refused the spelling as an unknown link)."""
    plan = tmp_path / "p.csv"
    code, out = run("poses", "--stances", "r_sole", "--count", 24, "--candidates", 300,
                    "--out", plan)  # fmt: skip
    assert code == 0, out
    table = read_table(plan)
    spelled = np.array(["r_sole", f"gantry:{TRUNK}"] * (table.n // 2) + ["r_sole"] * (table.n % 2))
    cols = {c: table.get(c) for c in table.columns}
    write_table(plan, cols | {"support": spelled})
    raws = []
    for flags in (["--support", "r_sole"], ["--support", TRUNK, "--mount", "gantry"]):
        raws.append(tmp_path / f"raw{len(raws)}.csv")
        code, out = run("experiment", "--poses", plan, *flags, "--torques", "all",
                        "--samples", 10, "--out", raws[-1])  # fmt: skip
        assert code == 0, out
        assert f"measuring the {table.n // 2} poses planned for" in out, out
    logs = [read_table(r) for r in raws]
    joined = {c: np.concatenate([g.get(c) for g in logs]) for c in logs[1].columns}
    labels = np.concatenate([np.array(g.text["support"]) for g in logs])
    assert set(labels) == {"r_sole", TRUNK}
    results = []
    for name, cells in (
        ("label", labels),
        ("spelled", np.where(labels == TRUNK, f"gantry:{TRUNK}", labels)),
    ):
        write_table(tmp_path / f"{name}.csv", joined | {"support": cells})
        code, out = run("measure", tmp_path / f"{name}.csv", "--poses", plan,
                        "--out", tmp_path / f"m_{name}.csv")  # fmt: skip
        assert code == 0, out
        results.append((tmp_path / f"m_{name}.csv").read_bytes())
    assert results[0] == results[1]
    assert set(read_table(tmp_path / "m_spelled.csv").text["support"]) == {"r_sole", TRUNK}


def test_stances_that_a_plan_or_a_session_cannot_use(tmp_path):
    """poses --stances with a line support is refused by name (it was read as a gantry and
    failed on --kinds); session --stances with a gantry and no torque sensors is refused before
    anything runs (it ran with a stance it could never measure)."""

    wheeled = example_path("wheeled_humanoid")
    code, out = run("poses", "--robot", wheeled, "--support", "axle", "--line", "y",
                    "--stances", "axle,torso", "--out", tmp_path / "p.csv")  # fmt: skip
    assert code == 2 and "--stances: 'axle': the robot balances on a line there" in out, out
    code, out = run("session", "--stances", "r_sole,gantry:MP_BODY", "--no-view",
                    "--out-dir", tmp_path / "s")  # fmt: skip
    assert code == 2 and "'gantry:MP_BODY': a robot held in a gantry loads no foot" in out, out
    assert not (tmp_path / "s").exists()


def test_a_fit_file_missing_part_of_its_bodies_names_the_field(files, tmp_path):
    """A pooled fit JSON whose body record lost a field: the error names the file and the
    field (it said only "KeyError")."""
    import json

    fit = tmp_path / "two.json"
    code, text = run("identify", files / "r.csv", files / "l.csv", "--method", "ls",
                     "--allow-outside-limits", "--out", fit)  # fmt: skip
    assert code == 0, text
    data = json.loads(fit.read_text())
    del data["bodies"]["x"]
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(data))
    code, text = run("predict", bad, files / "l.csv", "--out", tmp_path / "x.csv")
    assert code == 2 and f"{bad}: malformed fit file (field 'x' missing)" in text, text


def test_torques_on_both_feet_and_report_support_name_file_or_option(tmp_path, files):
    """`double` on torque rows names the file and row (or the FILE@FRAME); report --support
    names the option and the fit file."""
    data = tmp_path / "tau.csv"
    code, out = run("simulate", "--measure", "tau", "--poses", 40, "--seed", 3, "--clip",
                    "--out", data)  # fmt: skip
    assert code == 0, out
    t = read_table(data)
    write_table(tmp_path / "d.csv", {c: t.get(c) for c in t.columns} | {"support": np.full(
        t.n, "double")})  # fmt: skip
    code, out = run("identify", tmp_path / "d.csv", "--out", tmp_path / "f.json")
    assert (
        code == 2 and "d.csv: row 2, column 'support': 'double': joint torques on both feet" in out
    ), out
    write_table(tmp_path / "bare.csv", {c: t.get(c) for c in t.columns})
    code, out = run("identify", f"{tmp_path / 'bare.csv'}@double", "--out", tmp_path / "f.json")
    assert code == 2 and "bare.csv@double: 'double': joint torques on both feet" in out, out
    one = tmp_path / "one.json"
    code, out = run("identify", files / "r.csv", "--allow-outside-limits", "--out", one)
    assert code == 0, out
    code, out = run("report", one, files / "l.csv", "--support", "l_sole",
                    "--out-dir", tmp_path / "rep")  # fmt: skip
    assert code == 2 and f"support: l_sole: {one}: the fit was made in one stance" in out, out
    code, out = run("report", one, files / "l.csv", "--support", "nope",
                    "--out-dir", tmp_path / "rep")  # fmt: skip
    assert code == 2 and "support: " in out and "unknown support 'nope'" in out, out


def test_report_of_rows_on_both_feet(tmp_path, files):
    """A file of rows on both feet (``double``: the CoP of the whole robot in the reference
    sole's frame, as on that sole) is reported with --support double (it was refused: "no row of
    the stance 'r_sole'") with the same residuals as the same rows labelled with the sole; without
    the flag the error names it."""
    one = tmp_path / "one.json"
    code, out = run("identify", files / "r.csv", "--allow-outside-limits", "--out", one)
    assert code == 0, out
    r = read_table(files / "r.csv")
    write_table(tmp_path / "d.csv", _relabel(r, "double"))
    code, out = run("report", one, tmp_path / "d.csv", "--out-dir", tmp_path / "x")
    assert code == 2 and "(--support double)" in out and out.count("\n") == 1, out
    lines = []
    for data, flags in ((tmp_path / "d.csv", ["--support", "double"]), (files / "r.csv", [])):
        code, out = run("report", one, data, *flags, "--out-dir", tmp_path / f"rep{len(lines)}")
        assert code == 0, out
        lines.append(next(x for x in out.splitlines() if x.startswith("CoP residual")))
    assert lines[0] == lines[1] and "over 60 poses" in lines[0], lines
