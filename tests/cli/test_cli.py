"""The command line: the simulate → identify → predict flow, the demo, and bad input."""

from __future__ import annotations

import numpy as np
import pytest
from cli_run import invoke as run
from click.testing import CliRunner

import sescid
from sescid import tables
from sescid.bench import ExperimentConfig, real_robot
from sescid.cli import cli


@pytest.fixture(scope="module")
def sim_csv(tmp_path_factory):
    path = tmp_path_factory.mktemp("cli") / "sim.csv"
    res = run("simulate", "--robot", "op2", "--count", 300, "--seed", 4, "--out", path)
    assert res.exit_code == 0, res.output
    return path


def test_simulate_identify_predict(sim_csv, tmp_path):
    table = tables.read_table(sim_csv)
    op2 = sescid.load_robot("op2")
    assert table.n == 300
    columns = ["cop_x", "cop_y", "cop_x_true", "cop_y_true", "support"]
    assert set(op2.joint_names + columns) == set(table.names())
    q = tables.read_poses(table, op2.joint_names)
    # the robot simulated is the bench's real robot (7 % unmodelled mass), not the model
    r_true = real_robot(op2, ExperimentConfig())[0]
    true = np.column_stack([table.get("cop_x_true"), table.get("cop_y_true")])
    np.testing.assert_allclose(true, op2.cop(q, r_true), atol=0)
    assert np.sqrt(np.mean((true - op2.cop(q)) ** 2)) > 1e-3  # m: a robot the model is not
    fit_path = tmp_path / "fit.json"
    res = run("identify", sim_csv, "--robot", "op2", "--out", fit_path)
    assert res.exit_code == 0, res.output
    assert "300 poses, rank 42 of 63" in res.output
    pred = tmp_path / "pred.csv"
    res = run("predict", fit_path, sim_csv, "--out", pred)
    assert res.exit_code == 0, res.output
    out = tables.read_table(pred)
    fit = sescid.identify(op2, q, tables.read_cop(table))
    np.testing.assert_allclose(out.get("cop_x"), fit.predict_cop(q)[:, 0], atol=1e-15)
    np.testing.assert_allclose(out.get("com_z"), fit.predict_com(q)[:, 2], atol=1e-15)
    assert np.all(out.get("com_z_std") > 0)


def test_demo_prints_the_papers_numbers(tmp_path):
    res = run("demo", "--out-dir", tmp_path / "d", "--count", 1000, "--seed", 0)
    assert res.exit_code == 0, res.output
    assert "regressor rank p = 42 of 63" in res.output
    assert "paper: 4.0 mm" in res.output and "noise floor" in res.output
    for name in ("fit.json", "fig3a_r_magnitudes.png", "fig3b_cop.png", "summary.csv"):
        assert (tmp_path / "d" / name).stat().st_size > 1000 or name == "summary.csv"
    summary = tables.read_table(tmp_path / "d" / "summary.csv")
    values = dict(zip(summary.text["quantity"], summary.get("value"), strict=True))
    assert values["rank"] == 42
    assert values["mae_m"] == pytest.approx(values["noise_floor_mae_m"], rel=0.03)


def _bad(tmp_path, *args, match: str):
    out = tmp_path / "out.file"
    res = run(*args, "--out", out)
    assert res.exit_code == 2, res.output
    lines = [ln for ln in res.output.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("sescid: error: "), res.output
    assert match in lines[0], lines[0]
    assert not out.exists() and not [p for p in tmp_path.iterdir() if p.name.startswith(".")]


def _rewrite(sim_csv, tmp_path, fn):
    text = sim_csv.read_text().splitlines()
    path = tmp_path / "bad.csv"
    path.write_text("\n".join(fn(text)) + "\n")
    return path


def test_bad_input_gives_one_line_and_no_output(sim_csv, tmp_path):
    _bad(tmp_path, "identify", tmp_path / "nope.csv", match="nope.csv: file not found")

    def drop_column(t):
        return [",".join(row.split(",")[1:]) for row in t]

    _bad(
        tmp_path,
        "identify",
        _rewrite(sim_csv, tmp_path, drop_column),
        match="missing joint column 'r_sho_pitch'",
    )

    def nan(t):
        return t[:5] + [t[5].replace(t[5].split(",")[3], "nan", 1)] + t[6:]

    _bad(tmp_path, "identify", _rewrite(sim_csv, tmp_path, nan), match="row 6, column 'l_sho_roll'")

    def text_field(t):
        return t[:3] + ["abc," + t[3].split(",", 1)[1]] + t[4:]

    _bad(
        tmp_path,
        "identify",
        _rewrite(sim_csv, tmp_path, text_field),
        match="row 4, column 'r_sho_pitch': 'abc' is not a number",
    )
    _bad(
        tmp_path,
        "identify",
        _rewrite(sim_csv, tmp_path, lambda t: t[:21]),
        "--method",
        "ls",
        match="20 poses are too few",
    )

    def degrees(t):
        cells = t[2].split(",")
        cells[0] = "25.0"
        return t[:2] + [",".join(cells)] + t[3:]

    _bad(tmp_path, "identify", _rewrite(sim_csv, tmp_path, degrees), match="looks like degrees")
    _bad(tmp_path, "identify", sim_csv, "--robot", "nao", match="unknown robot 'nao'")
    _bad(tmp_path, "identify", sim_csv, "--support", "toe", match="unknown support link 'toe'")
    broken = tmp_path / "broken.urdf"
    broken.write_text("<robot name='b'><link name='a'>")
    _bad(tmp_path, "simulate", "--robot", broken, "--support", "a", match="malformed URDF")
    _bad(tmp_path, "predict", sim_csv, sim_csv, match="not a JSON file")


def test_papers_38_poses_work(tmp_path):
    sim = tmp_path / "s.csv"
    assert run("simulate", "--count", 38, "--out", sim).exit_code == 0
    res = run("identify", sim, "--out", tmp_path / "f.json")
    assert res.exit_code == 0 and "38 poses, rank 42 of 63" in res.output


def test_version_is_answered_before_anything_loads():
    """``sescid --version`` alone is answered by the script's entry without numpy or the package,
    with the text the command line prints (``VERSION_MESSAGE``, one home)."""
    import subprocess
    import sys

    code = (
        "import sys\nfrom _sescid_launch import main\nsys.argv = ['sescid', '--version']\nmain()\n"
        "print(sorted(m for m in ('numpy', 'sescid', 'click') if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    fast, loaded = out.stdout.splitlines()
    assert loaded == "[]"
    assert fast == CliRunner().invoke(cli, ["--version"], prog_name="sescid").output.strip()
    assert fast == f"sescid, version {sescid.__version__}"
