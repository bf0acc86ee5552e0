"""CoP files that measure one coordinate, or leave either empty in some rows: each row fits
the coordinates it has."""

from __future__ import annotations

import numpy as np
import pytest

import sescid
from sescid import identify
from sescid.errors import DataError
from sescid.estimation import Measurements


def reference(robot, q, cop, rtol=1e-6):
    """Least squares on the measured rows alone, the model filling the rest: numpy's minimum
    norm solution around r0 on the dense regressor (an independent computation)."""
    phi = robot.regressor(q, (0, 1)).reshape(-1, 3 * len(robot.body_names))
    y = cop.reshape(-1)
    keep = ~np.isnan(y)
    r0 = robot.sesc_vectors().reshape(-1)
    d = y[keep] - phi[keep] @ r0
    delta = np.linalg.lstsq(phi[keep], d, rcond=rtol)[0]
    return (r0 + delta).reshape(-1, 3)


@pytest.mark.parametrize("n", [300, 6000])  # numpy and compiled accumulation
def test_missing_coordinates_are_rows_not_fitted(op2, rng, n):
    q = rng.uniform(-0.5, 0.5, (n, op2.nq))
    cop = op2.cop(q) + rng.normal(0, 0.005, (n, 2))
    cop[rng.random(n) < 0.3, 1] = np.nan  # some rows measure x only
    cop[rng.random(n) < 0.2, 0] = np.nan
    cop[np.all(np.isnan(cop), axis=1), 0] = 0.001  # every row measures something
    fit = identify(op2, Measurements(q=q, cop=cop), method="ls")
    (kind,) = fit.kinds
    assert kind.n_rows == int(np.sum(~np.isnan(cop)))
    ref = reference(op2, q, cop)
    fresh = rng.uniform(-0.5, 0.5, (200, op2.nq))
    np.testing.assert_allclose(fit.predict_cop(fresh), op2.cop(fresh, ref), atol=1e-9)
    e = cop - fit.predict_cop(q)
    assert fit.rms == pytest.approx(np.sqrt(np.nanmean(e**2)), rel=1e-9)


def test_a_file_with_one_coordinate(op2, tmp_path, rng):
    from sescid.tables import write_table

    lim = op2.joint_limits
    q = rng.uniform(np.maximum(lim[:, 0], -0.5), np.minimum(lim[:, 1], 0.5), (200, op2.nq))
    cop = op2.cop(q) + rng.normal(0, 0.005, (200, 2))
    cols = {j: q[:, i] for i, j in enumerate(op2.joint_names)}
    write_table(tmp_path / "x.csv", cols | {"cop_x": cop[:, 0]})
    fit = sescid.identify(op2, tmp_path / "x.csv", method="ls")
    assert fit.kinds[0].n_rows == 200
    only_x = np.column_stack([cop[:, 0], np.full(200, np.nan)])
    np.testing.assert_allclose(
        fit.r, identify(op2, Measurements(q=q, cop=only_x), method="ls").r, atol=0
    )
    # empty cells: the coordinate was not measured in that row
    text = (tmp_path / "x.csv").read_text().splitlines()
    head = text[0] + ",cop_y"
    rows = [f"{line},{'' if k % 3 else repr(float(cop[k, 1]))}" for k, line in enumerate(text[1:])]
    (tmp_path / "xy.csv").write_text("\n".join([head, *rows]) + "\n")
    fit = sescid.identify(op2, tmp_path / "xy.csv", method="ls")
    assert fit.kinds[0].n_rows == 200 + len(range(0, 200, 3))


def test_a_row_without_either_coordinate_is_named(op2, tmp_path):
    joints = ",".join(op2.joint_names)
    zeros = ",".join("0" for _ in op2.joint_names)
    (tmp_path / "m.csv").write_text(f"{joints},cop_x,cop_y\n{zeros},0.01,0.0\n{zeros},,\n")
    with pytest.raises(DataError, match=r"m\.csv: row 3: neither cop_x nor cop_y"):
        sescid.identify(op2, tmp_path / "m.csv", method="ls")
    with pytest.raises(DataError, match="pose 1: neither cop_x nor cop_y"):
        Measurements(q=np.zeros((2, op2.nq)), cop=[[0.0, 0.0], [np.nan, np.nan]]).checked(op2)
    with pytest.raises(DataError, match="pose 0, cop_x: inf is not a finite number"):
        Measurements(q=np.zeros((1, op2.nq)), cop=[[np.inf, 0.0]]).checked(op2)
