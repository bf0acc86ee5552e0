"""The report of joint-torque fits (a robot without foot sensors) and of pooled CoP + torque
fits: every number against a computation made here from the fit and the data (residuals per
joint, sensor offsets and friction bands, ranks per kind of data, masses), "not determined"
for what the data do not determine, the command line without CoP columns, and the page in a
real browser."""

from __future__ import annotations

import dataclasses
import html
import re

import numpy as np
import pytest
from click.testing import CliRunner
from fitting import identify_consistent
from op2_stance import stable_poses
from test_html import _browse, _chromium

import sescid
from sescid import identify
from sescid.cli import cli
from sescid.estimation import Measurements
from sescid.report import ReportOptions, coverage, write_report
from sescid.report.numbers import support_leg_joints
from sescid.report.text import NOT_DETERMINED
from sescid.tables import write_table

CHROMIUM = pytest.mark.skipif(_chromium() is None, reason="no chromium (apt-get install chromium)")
#: the OP2's right leg from its sole up to the trunk (MP_BODY), as its URDF chains them
OP2_RIGHT_LEG = ["r_ank_roll", "r_ank_pitch", "r_knee", "r_hip_pitch", "r_hip_roll", "r_hip_yaw"]


def _torque_data(robot, q, seed=0, noise=0.02):
    """Torque readings of every joint: a real robot (the torso's SESC vector 8 / 4 mm off the
    model's), per-joint offsets, friction bands on a known approach side, noise."""
    rng = np.random.default_rng(seed)
    r_true = robot.sesc_vectors()
    r_true[robot.body_names.index("MP_BODY")] += [-0.008, 0.004, 0.0]
    joints = tuple(robot.joint_names)
    offsets = rng.normal(0, 0.05, len(joints))
    friction = rng.uniform(0.1, 0.3, len(joints))
    approach = np.where(rng.random(len(q)) < 0.5, 1.0, -1.0)
    tau = robot.torques(q, r_true, joints=joints) + offsets + approach[:, None] * friction
    tau += rng.normal(0, noise, tau.shape)
    m = Measurements(q=q, tau=tau, tau_joints=joints, approach=approach)
    return m, r_true, offsets, friction


@pytest.fixture(scope="module")
def torque_case(op2, tmp_path_factory):
    """A torque-only fit (weighed mass) of 40 single-support poses and its report."""
    q = stable_poses(op2, 40, range_deg=20, seed=0)
    m, r_true, offsets, friction = _torque_data(op2, q)
    fit = identify(op2, m, total_mass=op2.total_mass, method="ls")
    out = tmp_path_factory.mktemp("torque_report")
    res = write_report(fit, m, out, ReportOptions(n_side=3))
    return m, fit, res, r_true, offsets, friction


def _row(page: str, name: str) -> list[str]:
    """Cell texts of the first table row whose first cell is ``<code>name</code>``."""
    m = re.search(rf"<tr><td[^>]*><code>{re.escape(name)}</code></td>(.*?)</tr>", page)
    assert m, name
    return [
        html.unescape(re.sub(r"<[^>]+>", "", c))
        for c in re.findall(r"<td[^>]*>(.*?)</td>", m.group(1))
    ]


def _expected_residuals(fit, m):
    """measured − (gravity torque of the fit's r and mass + offset + approach · band), here."""
    est = {(e.what, e.name): e.value for e in fit.nuisance if e.kind == "tau" and e.determined}
    off = np.array([est.get(("offset", j), 0.0) for j in m.tau_joints])
    band = np.array([est.get(("friction", j), 0.0) for j in m.tau_joints])
    grav = fit.robot.torques(
        m.q, fit.r, joints=m.tau_joints, total_mass=fit.total_mass, g0=fit.gravity_accel
    )
    return m.tau - grav - off - m.approach[:, None] * band


def test_torque_residuals_per_joint_are_recomputed(torque_case):
    """Each joint's RMS/MAE (identified and manufacturer model) equals residuals recomputed
    here; the all-joints RMS is the fit's own; the page's table quotes them."""
    m, fit, res, *_ = torque_case
    t = res.content.tau
    mine = _expected_residuals(fit, m)
    # the manufacturer model with its own best offset and band per joint (least squares here)
    raw = m.tau - fit.robot.torques(m.q, joints=m.tau_joints)
    design = np.column_stack([np.ones(m.n), m.approach])
    cad = raw - design @ np.linalg.lstsq(design, raw, rcond=None)[0]
    page = res.html.read_text()
    for j, name in enumerate(m.tau_joints):
        s_fit, s_cad = t.stats["identified"][j], t.stats["manufacturer model"][j]
        assert s_fit.rms == pytest.approx(np.sqrt(np.mean(mine[:, j] ** 2)), rel=1e-9)
        assert s_fit.mae == pytest.approx(np.mean(np.abs(mine[:, j])), rel=1e-9)
        assert s_cad.rms == pytest.approx(np.sqrt(np.mean(cad[:, j] ** 2)), rel=1e-9)
        assert _row(page, name)[:3] == ["40", f"{s_fit.rms:.4f}", f"{s_fit.mae:.4f}"]
    assert t.total().rms == pytest.approx(np.sqrt(np.mean(mine**2)), rel=1e-9)
    assert t.total().rms == pytest.approx(fit.kind("tau").rms, rel=1e-9)
    assert t.total().n_rows == 40 * 20
    # the torso's shift shows in the manufacturer model's residuals, not in the identified ones
    assert t.total("manufacturer model").rms > 1.2 * t.total().rms


def test_offsets_and_friction_bands_are_shown_with_their_errors(torque_case):
    """Each sensor's offset and band in the page as value ± 1σ (N·m), and near the truth."""
    m, fit, res, _, offsets, friction = torque_case
    page = res.html.read_text()
    est = {(e.what, e.name): e for e in fit.nuisance}
    for j, name in enumerate(m.tau_joints):
        off, band = est["offset", name], est["friction", name]
        cells = _row(page.split("Torque sensor offsets")[1], name)
        assert cells[0] == f"{off.value:.4f} ± {off.std:.4f}"
        assert cells[1] == f"{band.value:.4f} ± {band.std:.4f}"
        assert abs(band.value - friction[j]) < 5 * band.std
        assert abs(off.value - offsets[j]) < 5 * off.std
    assert "why not determined" not in page  # every one is determined here


def test_not_determined_is_said_never_zero(op2, tmp_path):
    """Three poses, four joints: the offsets trade with each other; the page says "not
    determined" with the reason, and never prints nan, ±0 or a fake 0."""
    q = stable_poses(op2, 3, range_deg=20, seed=1)
    full, *_ = _torque_data(op2, q, seed=1)
    cols = [op2.joint_names.index(j) for j in ("r_hip_pitch", "r_knee", "r_ank_pitch", "l_knee")]
    m = Measurements(q=q, tau=full.tau[:, cols], tau_joints=tuple(op2.joint_names[i] for i in cols))
    fit = identify(op2, m, total_mass=op2.total_mass, allow_exact=True, method="ls")
    lost = [e for e in fit.nuisance if not e.determined]
    assert lost and all(np.isnan(e.value) for e in lost)
    page = write_report(fit, m, tmp_path, ReportOptions(n_side=2)).html.read_text()
    part = page.split("Torque sensor offsets")[1]
    for e in lost:
        cells = _row(part, e.name)
        assert cells[0] == NOT_DETERMINED and e.reason in cells[-1]
    text = re.sub(r"<[^>]*>|data:image/png;base64,[A-Za-z0-9+/=]+", " ", page)
    assert not re.search(r"\bnan\b", text)
    assert not re.search(r"±\s*0(\.0+)?\b|-0\.0+\b", text)
    assert "friction bands were not estimated" in text


def test_support_leg_is_the_chain_to_the_trunk(op2, torque_case):
    """The support leg: the joints from the right sole up to the OP2's trunk; on a gantry (the
    trunk held) the joints whose torque varies most."""
    m, fit, *_ = torque_case
    cols, chain = support_leg_joints(fit, m.tau_joints, m.tau)
    assert chain and [m.tau_joints[c] for c in cols] == OP2_RIGHT_LEG
    gantry = dataclasses.replace(fit, robot=sescid.load_robot("op2", support="MP_BODY"))
    tau = np.zeros((5, 20))
    tau[:, [3, 7, 11]] = np.arange(5)[:, None] * [1.0, 3.0, 2.0]
    cols, chain = support_leg_joints(gantry, m.tau_joints, tau)
    assert not chain and len(cols) == 6 and {3, 7, 11} <= set(cols)


def _rank(a: np.ndarray) -> int:
    s = np.linalg.svd(a, compute_uv=False)
    return int(np.sum(s > 1e-6 * s[0]))


def test_what_each_kind_determines_matches_ranks_computed_here(op2, torque_case, tmp_path):
    """Per kind: the rank of the SESC part with the sensor terms (rank [Φ N] − rank N, SVD
    here); pooled: the fit's own rank; the unseen directions named by kind."""
    m, *_ = torque_case
    rng = np.random.default_rng(5)
    both = dataclasses.replace(m, cop=op2.cop(m.q) + rng.normal(0, 5e-4, (m.n, 2)))
    fit = identify(op2, both, total_mass=op2.total_mass, method="ls")
    cov = {c.kinds: c for c in coverage(fit, both.checked(op2))}
    phi_c = op2.regressor(m.q).transpose(1, 0, 2).reshape(2 * m.n, -1)
    phi_t = op2.total_mass * op2.torque_regressor(m.q, m.tau_joints)  # (n, J, 3N)
    nj = len(m.tau_joints)
    nuis = np.zeros((m.n * nj, 2 * nj))  # an offset and a band per joint, rows (joint, pose)
    for j in range(nj):
        nuis[j * m.n : (j + 1) * m.n, j] = 1.0
        nuis[j * m.n : (j + 1) * m.n, nj + j] = m.approach
    x_t = np.hstack([phi_t.transpose(1, 0, 2).reshape(m.n * nj, -1), nuis])
    assert cov["cop",].rank == _rank(phi_c) == 42
    assert cov["tau",].rank == _rank(x_t) - _rank(nuis) == 40
    assert cov["cop", "tau"].rank == fit.rank == 42
    assert (cov["tau",].count("support-horizontal"), cov["tau",].count("support-vertical")) == (
        2,
        1,
    )
    assert cov["cop",].count("support-horizontal") == 0
    for c in cov.values():
        assert c.rank + len(c.unseen) == c.n_par == 63
    page = write_report(fit, both, tmp_path, ReportOptions(n_side=2)).html.read_text()
    assert "pooled: CoP + joint torques" in page and "2 more than torques alone" in page


def _shown(x: float, sign: bool = False) -> str:
    """One decimal, no "-0.0"; with ``sign`` a "+" before a positive value."""
    text = f"{x:.1f}"
    if float(text) == 0:
        return "0.0"
    return "+" + text if sign and not text.startswith("-") else text


def test_masses_table_is_the_fits_inertials(op2, tmp_path):
    """Consistent masses (a 50 g floor makes some constraints active): each body's row quotes
    ``fit.inertials``; the change is computed here from the model file's masses."""
    q = stable_poses(op2, 40, seed=0)
    cop = op2.cop(q) + np.random.default_rng(0).normal(0, 5e-4, (40, 2))
    fit = identify_consistent(op2, q, cop, mass_floor=0.05)
    b = fit.inertials
    page = write_report(fit, Measurements(q=q, cop=cop), tmp_path, ReportOptions(n_side=2))
    text = page.html.read_text().split("Masses and CoMs")[1]
    masses = [bd.mass for bd in op2.model.bodies]
    for i, name in enumerate(op2.body_names):
        cells = _row(text, name)
        change = 100 * (b.masses[i] - masses[i]) / masses[i]
        assert cells[:3] == [f"{masses[i]:.4f}", f"{b.masses[i]:.4f}", _shown(change, True)]
        assert cells[3:6] == [_shown(v * 1e3) for v in b.coms_link[i]]
        mine = [a.split(": ", 1)[1] for a in b.active_constraints if a.startswith(name + ": ")]
        assert cells[7] == ("; ".join(mine) or "none")
    assert any("mass at floor" in a for a in b.active_constraints)


def test_cli_report_reads_torques_without_cop_columns(op2, torque_case, tmp_path):
    """A robot without foot sensors: ``sescid report`` on tau_<joint> + approach columns only."""
    m, fit, *_ = torque_case
    sescid.save_fit(fit, tmp_path / "fit.json")
    cols = {j: m.q[:, i] for i, j in enumerate(op2.joint_names)}
    cols |= {f"tau_{j}": m.tau[:, k] for k, j in enumerate(m.tau_joints)}
    cols["approach"] = m.approach
    write_table(tmp_path / "tau.csv", cols)
    args = ["report", str(tmp_path / "fit.json"), str(tmp_path / "tau.csv")]
    res = CliRunner().invoke(cli, [*args, "--out-dir", str(tmp_path / "rep")])
    assert res.exit_code == 0, res.output
    assert "joint torques residual, measured − predicted, over 40 poses (800 rows)" in res.output
    assert "CoP" not in res.output
    assert "Joint torques" in (tmp_path / "rep" / "report.html").read_text()


@CHROMIUM
def test_torque_page_renders_in_headless_chromium(torque_case, tmp_path):
    """The torque-only page in Chromium: every figure decodes, no console error, the 3-D view
    draws a robot (and says nothing of a CoP it does not have)."""
    _, _, res, *_ = torque_case
    figures = len(res.figures)
    assert figures == 5
    dom = _browse(_chromium(), res.html.resolve().as_uri() + "#view3d=5", "--dump-dom")
    assert dom.returncode == 0, dom.stderr[-2000:]
    assert f'data-figures-ok="{figures}"' in dom.stdout
    assert not [ln for ln in dom.stderr.splitlines() if ":CONSOLE" in ln or "Uncaught" in ln]
    canvas = re.search(r'<canvas id="view3d"[^>]*data-pose="(\d+)" data-ink="(\d+)"', dom.stdout)
    assert canvas and int(canvas.group(1)) == 5 and int(canvas.group(2)) > 20_000
    label = re.search(r'<div id="view3d-label"[^>]*>([^<]*)</div>', dom.stdout).group(1)
    assert label.startswith("pose 5 (6/40): identified CoM (") and "CoP" not in label


def test_sensor_table_shows_every_parameter_the_fit_carries(torque_case):
    """A gain per sensor (as a fit with gains records them) gets its own column, value ± 1σ;
    one the data leave undetermined reads "not determined" with its reason."""
    from sescid.estimation import NuisanceEstimate
    from sescid.report.sections import nuisance_table

    m, fit, *_ = torque_case
    gains = tuple(
        NuisanceEstimate("tau", "gain", j, "1", 0.01 * k, 0.002, True)
        for k, j in enumerate(m.tau_joints[:-1])
    ) + (
        NuisanceEstimate(
            "tau", "gain", m.tau_joints[-1], "1", np.nan, np.nan, False, "only ratios: no mass"
        ),
    )
    page = nuisance_table(dataclasses.replace(fit, nuisance=fit.nuisance + gains), m.tau_joints)
    assert "gain error g ± 1σ" in page and "why not determined" in page
    assert _row(page, m.tau_joints[2])[2] == "0.0200 ± 0.0020"
    last = _row(page, m.tau_joints[-1])
    assert last[2] == NOT_DETERMINED and last[3] == "gain: only ratios: no mass"
