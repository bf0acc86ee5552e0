"""Tilted support: the CoM-height direction it adds, its standard error, LS warning, intervals."""

from __future__ import annotations

import numpy as np

import sescid
from sescid.estimation import cop_interval, fit_notes
from sescid.estimation.result.tilt import level_basis, tilt_direction
from sescid.estimation.result.validation import cop_std


def _data(robot, n, tilt, noise, seed):
    """Random ±25° poses under gravity tilted by N(0, tilt²) per axis; a perturbed true r."""
    rng = np.random.default_rng(seed)
    lo, hi = robot.joint_limits.T
    q = np.clip(rng.uniform(-0.44, 0.44, size=(n, robot.nq)), lo, hi)
    g = np.column_stack([rng.normal(0, tilt, (n, 2)), -np.ones(n)])
    g /= np.linalg.norm(g, axis=1, keepdims=True)
    r = robot.sesc_vectors() + rng.normal(0, 0.002, size=(len(robot.body_names), 3))
    cop = robot.cop(q, r, g) + rng.normal(0, noise, size=(n, 2))
    return q, g, r, cop


def _offset(robot, d, r):
    """CoM-height contribution along d at the zero pose (m)."""
    return float(robot.regressor(np.zeros((1, robot.nq)), (2,))[0, 0] @ d) * float(d @ r.ravel())


def test_level_data_add_no_direction(op2):
    """A level sole: rank 42, no tilt direction, no tilt note."""
    q, _, r, _ = _data(op2, 200, 0.0, 0.0, 0)
    fit = sescid.identify(op2, q, op2.cop(q, r), method="ls")
    assert fit.rank == 42 and tilt_direction(fit) is None
    assert level_basis(op2).shape == (63, 42)


def test_noise_free_tilt_determines_the_height_offset(op2):
    """Noise-free tilted data: rank 43, the offset equals the truth's along that direction."""
    q, g, r, cop = _data(op2, 200, 0.01, 0.0, 1)
    fit = sescid.identify(op2, q, cop, gravity=g, method="ls")
    t = tilt_direction(fit)
    assert fit.rank == 43 and t is not None
    assert abs(t.value - _offset(op2, t.direction, r)) < 1e-9
    assert abs(t.prior - _offset(op2, t.direction, op2.sesc_vectors())) < 1e-15
    assert any("CoM-height offset" in n for n in fit_notes(fit))


def test_ls_warns_map_does_not(op2):
    """Bench-like tilt (5 mrad) and CoP noise (1 mm): LS warns (rel. std > 10 %), MAP not."""
    q, g, r, cop = _data(op2, 60, 0.005, 0.001, 2)
    ls = sescid.identify(op2, q, cop, gravity=g, method="ls")
    t = tilt_direction(ls)
    assert t is not None and t.rel_std > 0.1
    assert abs(t.value - _offset(op2, t.direction, r)) < 4 * t.std
    assert any("CoM-height offset only weakly" in w for w in ls.warnings)
    fit = sescid.identify(op2, q, cop, gravity=g, method="map")
    assert not any("CoM-height" in w for w in fit.warnings)


def test_tilted_cop_std_carries_the_height_uncertainty(op2):
    """cop_std under gravity = √(var_x − 2t cov_xz + t² var_z) from the fit's covariance."""
    q, g, _, cop = _data(op2, 80, 0.01, 0.001, 3)
    fit = sescid.identify(op2, q, cop, gravity=g, method="map")
    phi = op2.regressor(q[:5], (0, 1, 2))
    c = np.einsum("nri,ij,nsj->nrs", phi, fit.cov, phi)  # (5, 3, 3) covariance of the CoM
    t = g[:5, :2] / g[:5, 2:3]
    want = np.sqrt(
        np.stack(
            [c[:, a, a] - 2 * t[:, a] * c[:, a, 2] + t[:, a] ** 2 * c[:, 2, 2] for a in (0, 1)], 1
        )
    )
    assert np.abs(cop_std(fit, q[:5], g[:5]) - want).max() < 1e-12
    iv = cop_interval(fit, q[:5], 0.95, gravity=g[:5])
    assert np.allclose(iv.value, fit.predict_cop(q[:5], g[:5]), atol=0)
    assert np.all(iv.half_width > 0)


def test_cli_identify_warns_with_gravity_ls(op2, tmp_path):
    """`sescid identify` on tilted data with LS stores the warning in the fit and prints it."""
    from click.testing import CliRunner

    from sescid.cli import cli
    from sescid.tables import write_table

    q, g, _, cop = _data(op2, 60, 0.005, 0.001, 4)
    cols = {j: q[:, i] for i, j in enumerate(op2.joint_names)}
    cols |= {"cop_x": cop[:, 0], "cop_y": cop[:, 1]}
    cols |= {f"grav_{a}": g[:, i] for i, a in enumerate("xyz")}
    write_table(tmp_path / "d.csv", cols)
    out = tmp_path / "f.json"
    res = CliRunner().invoke(
        cli, ["identify", str(tmp_path / "d.csv"), "--method", "ls", "--out", str(out)]
    )
    assert res.exit_code == 0, res.output
    assert "CoM-height offset only weakly" in res.output
    assert any("CoM-height" in w for w in sescid.load_fit(out).warnings)
