"""Every default of the bench, measure and calibrate commands is the API's (no drift)."""

from __future__ import annotations

import inspect

from sescid.bench import FRESH_POSES, FRESH_WITHIN_DEG, ExperimentConfig, TorqueConfig
from sescid.cli import cli
from sescid.sensors import CalibrationOptions, PadSessionOptions, fsr


def _defaults(command: str) -> dict:
    return {p.name: p.default for p in cli.get_command(None, command).params}


def test_experiment_defaults_are_the_configs():
    d, cfg, tc = _defaults("experiment"), ExperimentConfig(), TorqueConfig()
    assert d["extra_mass"] == cfg.extra_mass_fraction and d["backlash_deg"] == cfg.backlash_deg
    assert (d["fsr_noise"], d["fsr_bias"], d["fsr_gain"]) == (
        cfg.fsr_noise,
        cfg.fsr_bias,
        cfg.fsr_gain,
    )
    assert (d["registers"], d["mount"], d["tilt_deg"]) == (cfg.registers, cfg.mount, cfg.tilt_deg)
    assert (d["torque_noise"], d["torque_offset"], d["torque_gain"]) == (
        tc.noise,
        tc.offset,
        tc.gain,
    )
    assert tuple(d["friction"]) == tc.friction and d["approach"] == tc.approach
    assert d["torques"] == "none" and tc.joints == ()


def test_calibrate_measure_truth_defaults_are_the_api_defaults():
    d, opt = _defaults("calibrate"), CalibrationOptions()
    assert (d["total_mass"], d["prior_scale"]) == (opt.total_mass, opt.prior_scale)
    assert (d["gain_prior"], d["offset_prior"]) == (opt.gain_prior, opt.offset_prior)
    assert d["min_samples"] == PadSessionOptions().min_samples
    assert (
        _defaults("measure")["min_samples"]
        == inspect.signature(fsr).parameters["min_samples"].default
    )
    assert _defaults("fsr") == _defaults("measure")
    t = _defaults("truth")
    assert (t["fresh"], t["within_deg"]) == (FRESH_POSES, FRESH_WITHIN_DEG)
