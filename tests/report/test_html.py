"""The report of a CoP fit: numbers against recomputed residuals, figures, a self-contained
HTML page, and a check in a real browser."""

from __future__ import annotations

import base64
import os
import re
import shutil
import subprocess
import tempfile

import matplotlib.image
import numpy as np
import pytest
from click.testing import CliRunner
from fitting import cop_offset_stats, identify_ls
from op2_stance import stable_poses

import sescid
from sescid.cli import cli
from sescid.estimation import Measurements
from sescid.report import ReportOptions, write_report
from sescid.report.text import RESIDUAL_DEFINITION
from sescid.tables import write_table

FIGURES = 5


@pytest.fixture(scope="module")
def case(tmp_path_factory):
    """A fit from a known 'real' robot (model + 40 g on the torso) and its measured CoPs."""
    robot = sescid.load_robot("op2")
    q = stable_poses(robot, 60, seed=0)
    r_true = robot.sesc_vectors()
    r_true[robot.body_names.index("MP_BODY")] += [-0.002, 0.001, 0.0]
    rng = np.random.default_rng(0)
    cop = robot.cop(q, r_true) + rng.normal(0, 5e-4, size=(len(q), 2))
    se = np.full((len(q), 2), 5e-4)
    fit = identify_ls(robot, q, cop, sigma=se)
    out = tmp_path_factory.mktemp("report")
    data = Measurements(q=q, cop=cop, cop_se=se)
    ids = tuple(str(i) for i in range(100, 160))
    res = write_report(fit, data, out, ReportOptions(pose_ids=ids))
    return robot, q, cop, fit, out, res


def test_offset_stats_closed_form():
    meas = np.array([[0.0, 0.0], [1.0, 2.0]])
    pred = np.array([[3.0, 4.0], [4.0, 6.0]])
    s = cop_offset_stats(meas, pred)
    assert (s["mean_x"], s["mean_y"], s["mean"]) == (3.0, 4.0, 5.0)
    assert s["rms"] == pytest.approx(np.sqrt((9 + 16 + 9 + 16) / 4))


def test_report_residuals_are_recomputed_from_both_models(case):
    """Residuals measured − predicted per CoP component, recomputed here from each model's SESC
    vectors: the tables' mean, RMS and MAE; the identified RMS is the fit's own (same data,
    one definition: per row)."""
    robot, q, cop, fit, _, res = case
    k = res.content.cop
    for model, r in (("manufacturer model", robot.sesc_vectors()), ("identified", fit.r)):
        d = cop - robot.cop(q, r)  # (n, 2): both rows of each pose
        x, y, all_ = k.stats[model]
        assert (x.mean, y.mean) == pytest.approx((d[:, 0].mean(), d[:, 1].mean()), abs=1e-15)
        assert all_.rms == pytest.approx(np.sqrt(np.mean(d**2)), rel=1e-12)
        assert all_.mae == pytest.approx(np.mean(np.abs(d)), rel=1e-12)
        assert all_.n_rows == 2 * len(q)
    assert k.total().rms == pytest.approx(fit.kind("cop").rms, rel=1e-12)
    # the 2 mm / 1 mm torso shift (× torso share of the mass) shows before, not after
    cad_mean = np.hypot(
        k.stats["manufacturer model"][0].mean, k.stats["manufacturer model"][1].mean
    )
    assert cad_mean > 5 * abs(k.stats["identified"][0].mean)
    page = res.html.read_text()
    assert RESIDUAL_DEFINITION.split(",")[0] in page


def test_report_figures_are_nonblank_pngs(case):
    *_, res = case
    assert len(res.figures) == FIGURES
    for path in res.figures:
        img = matplotlib.image.imread(path)
        assert img.shape[0] > 200 and img.shape[1] > 400
        assert img[..., :3].std() > 0.05, path.name


def test_html_is_self_contained(case):
    *_, out, res = case
    page = res.html.read_text()
    imgs = re.findall(
        r'<img alt="[^"]*" src="data:image/png;base64,([A-Za-z0-9+/=]+)">'
        r"<figcaption>[^<]*<code>([^<]+)</code>",
        page,
    )
    assert sorted(name for _, name in imgs) == sorted(p.name for p in res.figures)
    for data, name in imgs:  # each embedded figure is the file it names
        assert base64.b64decode(data) == (out / name).read_bytes()
    assert not re.search(r'(src|href)="(?!data:)', page)  # nothing fetched from elsewhere
    assert "comes from the prior (manufacturer) model" in page
    assert page.count("<tr><td><code>") == len(case[3].base) + len(case[3].unidentifiable)
    assert not list(out.glob(".*"))  # no temporary files left
    assert "nan" not in re.sub(r"<[^>]*>|data:image/png;base64,[A-Za-z0-9+/=]+", "", page)
    assert "-0.00<" not in page and "±0<" not in page


def test_report_never_refits(case, monkeypatch, tmp_path):
    robot, q, cop, fit, *_ = case
    import sescid.estimation.solvers.least_squares

    def boom(*a, **k):
        raise AssertionError("the report must not fit")

    monkeypatch.setattr(sescid.estimation.solvers.solve, "solve_system", boom)
    monkeypatch.setattr(sescid.estimation.solvers.least_squares, "solve_system", boom)
    write_report(fit, Measurements(q=q[:5], cop=cop[:5]), tmp_path, ReportOptions(n_side=2))
    assert (tmp_path / "report.html").stat().st_size > 10000


def test_cli_report_and_bad_input(case, tmp_path):
    robot, q, cop, fit, *_ = case
    sescid.save_fit(fit, tmp_path / "fit.json")
    cols = {"pose": np.arange(len(q))} | {j: q[:, i] for i, j in enumerate(robot.joint_names)}
    write_table(tmp_path / "m.csv", cols | {"cop_x": cop[:, 0], "cop_y": cop[:, 1]})
    args = ["report", str(tmp_path / "fit.json"), str(tmp_path / "m.csv")]
    res = CliRunner().invoke(cli, [*args, "--out-dir", str(tmp_path / "rep")])
    assert res.exit_code == 0, res.output
    assert (tmp_path / "rep" / "report.html").is_file()
    assert "CoP residual, measured − predicted, over 60 poses (120 rows)" in res.output
    write_table(tmp_path / "bad.csv", cols)  # nothing measured
    bad = ["report", str(tmp_path / "fit.json"), str(tmp_path / "bad.csv")]
    res = CliRunner().invoke(cli, [*bad, "--out-dir", str(tmp_path / "rep2")])
    assert res.exit_code == 2 and "no measurement columns" in res.output
    assert "bad.csv" in res.output and res.output.count("\n") == 1
    assert not (tmp_path / "rep2").exists()


# --- a real headless browser ------------------------------------------------------------------
def _chromium() -> str | None:
    for name in (os.environ.get("CHROMIUM", ""), "chromium", "chromium-browser", "google-chrome"):
        if name and shutil.which(name):
            return shutil.which(name)
    return None


def _browse(binary: str, url: str, *extra: str) -> subprocess.CompletedProcess:
    with tempfile.TemporaryDirectory() as profile:
        cmd = [
            binary,
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            f"--user-data-dir={profile}",
            "--enable-logging=stderr",
            "--v=0",
            *extra,
            url,
        ]
        return subprocess.run(cmd, capture_output=True, text=True, timeout=90)


@pytest.mark.skipif(_chromium() is None, reason="no chromium binary (apt-get install chromium)")
def test_page_renders_in_headless_chromium(case, tmp_path):
    *_, res = case
    binary, url = _chromium(), res.html.resolve().as_uri()
    dom = _browse(binary, url, "--dump-dom")
    assert dom.returncode == 0, dom.stderr[-2000:]
    # the page's own check: every embedded figure decoded (naturalWidth > 0)
    assert f'data-figures-ok="{FIGURES}"' in dom.stdout
    console = [ln for ln in dom.stderr.splitlines() if ":CONSOLE" in ln or "Uncaught" in ln]
    assert console == []
    shot = tmp_path / "shot.png"
    run = _browse(binary, url, f"--screenshot={shot}", "--window-size=1100,2400")
    assert run.returncode == 0 and shot.stat().st_size > 10000, run.stderr[-2000:]
    img = matplotlib.image.imread(shot)
    assert img.shape[:2] == (2400, 1100)
    assert img[..., :3].std() > 0.05  # not a blank page
    assert not [ln for ln in run.stderr.splitlines() if ":CONSOLE" in ln or "Uncaught" in ln]


@pytest.mark.skipif(_chromium() is None, reason="no chromium binary (apt-get install chromium)")
def test_browser_check_catches_a_broken_figure(case, tmp_path):
    """The console check can fail: a corrupt embedded figure is reported by the page."""
    *_, res = case
    page = res.html.read_text()
    broken = re.sub(r"base64,[A-Za-z0-9+/=]{40}", "base64,AAAA", page, count=1)
    (tmp_path / "broken.html").write_text(broken)
    dom = _browse(_chromium(), (tmp_path / "broken.html").as_uri(), "--dump-dom")
    assert f'data-figures-ok="{FIGURES - 1}"' in dom.stdout
    assert any("figure failed to load" in ln for ln in dom.stderr.splitlines())
