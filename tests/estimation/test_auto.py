"""The default method (auto): MAP with the CAD prior when the data leave directions weakly
determined, least squares when they determine every direction well; barely excited directions
taken from the prior; least squares that is expected to be worse than CAD says so."""

from __future__ import annotations

import numpy as np
import pytest

import sescid
from sescid.estimation import fit_notes
from sescid.estimation.result.validation import perturbed_sesc
from sescid.simulation import random_poses

SIGMA = 0.00493


def test_auto_is_the_default_and_chooses_map_for_38_noisy_poses(op2):
    """A CAD model 15 % of the mass off: the data show it, auto is the evidence's MAP."""
    q = random_poses(op2, 38, 30, 1)
    r_true = perturbed_sesc(op2, fraction=0.15, offset=0.05, seed=1)
    cop = op2.cop(q, r_true) + np.random.default_rng(0).normal(0, SIGMA, (38, 2))
    fit = sescid.identify(op2, q, cop)
    assert fit.method == "map" and fit.choice is not None and fit.choice.chosen == "map"
    assert fit.map is not None and fit.map.prior == "bodies" and fit.map.prior_share > 0.01
    assert fit.map.prior_scale_by == "evidence"
    assert fit_notes(fit)[0].startswith("method auto chose MAP")
    explicit = sescid.identify(op2, q, cop, method="map")
    np.testing.assert_array_equal(fit.r, explicit.r)


def test_auto_keeps_the_cad_model_when_the_data_do_not_show_it_off(op2):
    """Data of the CAD model itself: no evidence against it, the model is kept (its prior
    holding every direction), and the fit says why."""
    q = random_poses(op2, 38, 30, 1)
    cop = op2.cop(q) + np.random.default_rng(0).normal(0, SIGMA, (38, 2))
    fit = sescid.identify(op2, q, cop)
    assert fit.choice is not None and "do not show the CAD model to be off" in fit.choice.reason
    assert np.abs(fit.r - op2.sesc_vectors()).max() < 1e-6


def test_auto_takes_least_squares_when_the_data_determine_everything(op2):
    q = random_poses(op2, 4000, 30, 3)
    r_true = perturbed_sesc(op2, fraction=0.15, offset=0.05, seed=4)
    cop = op2.cop(q, r_true) + np.random.default_rng(1).normal(0, 1e-5, (4000, 2))
    fit = sescid.identify(op2, q, cop)
    assert fit.choice is not None and fit.choice.chosen == "ls" and fit.method == "ls"
    np.testing.assert_array_equal(fit.r, sescid.identify(op2, q, cop, method="ls").r)


def test_auto_fits_what_map_fits_when_least_squares_has_no_degrees_of_freedom(op2):
    """20 poses (40 equations) for the OP2's 42 combinations: least squares refuses and names
    the one minimum (``min_poses``), the default fits with MAP and says it has no residual."""
    q = random_poses(op2, 20, 30, 0)
    cop = op2.cop(q) + np.random.default_rng(0).normal(0, SIGMA, (20, 2))
    assert sescid.estimation.min_poses(op2) == 22
    with pytest.raises(sescid.SescidError, match="at least 22 poses are needed"):
        sescid.identify(op2, q, cop, method="ls")
    fit = sescid.identify(op2, q, cop)
    assert fit.method == "map" and fit.choice is not None and fit.choice.chosen == "map"
    assert any("no residual degrees of freedom" in w for w in fit.warnings)


def test_least_squares_worse_than_cad_says_so(op2):
    q = random_poses(op2, 38, 30, 1)
    r_true = perturbed_sesc(op2, seed=1)
    cop = op2.cop(q, r_true) + np.random.default_rng(0).normal(0, SIGMA, (38, 2))
    fit = sescid.identify(op2, q, cop, method="ls")
    assert any("worse than the CAD model" in w for w in fit.warnings)
    # 1000 poses: least squares keeps its promise, no such warning
    q = random_poses(op2, 1000, 30, 1)
    cop = op2.cop(q, r_true) + np.random.default_rng(0).normal(0, SIGMA, (1000, 2))
    fit = sescid.identify(op2, q, cop, method="ls")
    assert not any("worse than the CAD model" in w for w in fit.warnings)


def test_barely_excited_directions_take_the_prior(op2):
    """The head pan moves by ±0.2 mrad only: least squares would take two combinations from
    noise; they are named and taken from the prior (the fit equals the prior along them)."""
    rng = np.random.default_rng(0)
    q = random_poses(op2, 200, 30, 1)
    q[:, op2.joint_names.index("head_pan")] = rng.uniform(-2e-4, 2e-4, 200)
    r_true = perturbed_sesc(op2, seed=5)
    cop = op2.cop(q, r_true) + rng.normal(0, SIGMA, (200, 2))
    fit = sescid.identify(op2, q, cop, method="ls")
    assert len(fit.weak) == 2 and all("MP_NECK" in c.label() for c in fit.weak)
    assert any("barely excited" in w for w in fit.warnings)
    for c in fit.weak:
        g = np.zeros(fit.r.size)
        index = {b: i for i, b in enumerate(op2.body_names)}
        for body, axis, coef in c.terms:
            g[3 * index[body] + "xyz".index(axis)] = coef
        # along a weak direction the fit is the prior's (to the named terms' rounding)
        assert abs(g @ (fit.r - fit.r_prior).reshape(-1)) < 1e-3 * np.abs(fit.r).max()
    mapped = sescid.identify(op2, q, cop, method="map")
    assert len(mapped.weak) == 2 and any("decided by the prior" in w for w in mapped.warnings)
