"""The report's joints where the identified model's torque residual exceeds the manufacturer
model's (``report.numbers.worse_joints``): which joints, and the reason given for each."""

from __future__ import annotations

import dataclasses
import importlib.metadata

import numpy as np
import pytest

import sescid
from sescid.estimation import JointNoise, Measurements
from sescid.estimation.result.validation import perturbed_sesc
from sescid.report.numbers import CAD, IDENTIFIED, _kind_numbers, torque_numbers, worse_joints
from sescid.report.sections import worse_than_cad
from sescid.simulation import random_poses


def _numbers(fit_res: np.ndarray, cad_res: np.ndarray, joints):
    tau = np.zeros_like(fit_res)
    return _kind_numbers("tau", "N·m", joints, tau, {CAD: cad_res, IDENTIFIED: fit_res})


def test_each_reason_follows_from_the_fits_records():
    """Residuals drawn with a chosen RMS per joint and model: a joint within 10 % of CAD is not
    listed; the others get the reason their records imply (shared noise and a light load; a
    residual within σ_j; a small share of the parameters; else the other joints' data)."""
    op2 = sescid.load_robot("op2")
    rng = np.random.default_rng(0)
    joints = ("a", "b", "c", "d")
    unit = rng.normal(size=(400, 4))
    unit /= np.sqrt(np.mean(unit**2, axis=0))  # RMS 1 per column
    cad = unit * np.array([0.01, 0.01, 0.01, 2.0])
    fit_res = unit * np.array([0.0105, 0.05, 0.05, 2.0])
    k = _numbers(fit_res, cad, joints)
    fit = sescid.identify(op2, random_poses(op2, 40, 30, 1), op2.cop(random_poses(op2, 40, 30, 1)))
    shared = worse_joints(fit, k)
    assert [w.joint for w in shared] == ["b", "c"]
    assert all(w.reason.startswith("lightly loaded") for w in shared)
    assert shared[0].rms == pytest.approx(0.05) and shared[0].cad_rms == pytest.approx(0.01)
    records = (
        JointNoise("a", 0.01, 300, 0.01, "estimated", 400, 2.0),
        JointNoise("b", 0.048, 300, 0.05, "estimated", 400, 2.0),  # within its own noise
        JointNoise("c", 0.01, 300, 0.05, "estimated", 400, 0.1),  # decided elsewhere
        JointNoise("d", 1.0, 300, 2.0, "estimated", 400, 5.0),
    )
    per_joint = worse_joints(dataclasses.replace(fit, torque_noise=records), k)
    reasons = {w.joint: w.reason for w in per_joint}
    assert set(reasons) == {"b", "c"}
    assert reasons["b"].startswith("within this joint's own noise")
    assert "0.10 of the fit's parameters" in reasons["c"] and "prior" in reasons["c"]
    html = worse_than_cad(k, fit)
    assert "on 2 of 4 joints" in html and "--tau-noise-model joint" in html
    fine = _numbers(cad, cad, joints)
    assert "On every one of the 4 joints" in worse_than_cad(fine, fit)


@pytest.mark.slow
def test_romeo_shared_noise_is_worse_than_cad_on_light_joints_per_joint_is_not():
    """Romeo (example-robot-data), a perturbed model, torque noise growing with each joint's
    load: one shared noise level leaves light joints worse than CAD (named "lightly loaded");
    the default noise per joint leaves none."""
    try:
        dist = importlib.metadata.distribution("example-robot-data")
    except importlib.metadata.PackageNotFoundError:
        pytest.skip("example-robot-data is not installed")
    path = dist.locate_file(
        "cmeel.prefix/share/example-robot-data/robots/romeo_description/urdf/romeo.urdf"
    )
    rob = sescid.load_robot(str(path), support="r_sole")
    r_true = perturbed_sesc(rob, 0.05, offset=0.01, seed=5)
    names = tuple(rob.joint_names)
    rng = np.random.default_rng(0)
    q = random_poses(rob, 60, 20, 1)
    tau0 = rob.torques(q, r_true, joints=names)
    noise = 0.01 + 0.03 * np.abs(tau0).mean(axis=0)
    tau = tau0 + rng.normal(0, 0.05, len(names)) + rng.normal(size=tau0.shape) * noise
    m = Measurements(q=q, tau=tau, tau_joints=names)
    checked = m.checked(rob)
    shared = sescid.identify(rob, m, tau_noise_model="shared", total_mass=rob.total_mass)
    worse = worse_joints(shared, torque_numbers(shared, checked))
    assert worse and all(w.reason.startswith("lightly loaded") for w in worse)
    joint = sescid.identify(rob, m, total_mass=rob.total_mass)
    assert worse_joints(joint, torque_numbers(joint, checked)) == ()
