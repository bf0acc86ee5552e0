"""audit and compare with known truth: data simulated from a perturbed model; the candidates'
prediction errors against Pinocchio's CoM and holding torques; the near-true file ranks first, a
phantom is named with its body, a scaled file as every body's mass; a moved mass is flagged
between two fits and noise is not; the model checks; the command line and its one-line errors."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from audit_gen import variant_urdf
from cli_run import invoke as run

import sescid
from sescid.audit import AuditOptions, audit, compare, model_checks
from sescid.audit.linear import ALL_BODIES
from sescid.base import G0
from sescid.errors import OptionError
from sescid.estimation import Measurements
from sescid.simulation import TorqueNoise

HAND = "MP_ARM_LOW_R"
TORSO = "MP_BODY"
COP_NOISE, TAU_NOISE = 0.002, 0.05


@pytest.fixture(scope="module")
def files(tmp_path_factory) -> dict[str, Path]:
    """The truth and the issue's four candidates, on the OP2."""
    d = tmp_path_factory.mktemp("audit")
    src = Path(sescid.load_robot("op2").model_path)
    truth = variant_urdf(src, d / "truth.urdf", mass_jitter=0.1, com_jitter=0.005, seed=1)
    near = variant_urdf(truth, d / "near.urdf", mass_jitter=0.01, com_jitter=0.001, seed=2)
    return {
        "truth": truth,
        "near": near,
        "low": variant_urdf(near, d / "low.urdf", mass_scale=0.92),
        "phantom": variant_urdf(near, d / "phantom.urdf", phantom=(HAND, 1.0, (0, 0, -0.05))),
        "battery": variant_urdf(near, d / "battery.urdf", moved=(TORSO, 0.3, (0.03, 0, 0))),
    }


def _data(path: Path, seed: int, n: int = 38, torques: bool = True) -> Measurements:
    robot = sescid.load_robot(str(path), "r_sole")
    tau = TorqueNoise(noise=TAU_NOISE) if torques else None
    sim = sescid.simulate(robot, n=n, range_deg=20, noise=COP_NOISE, seed=seed, torques=tau)
    t = sim.torques
    return Measurements(
        q=sim.q, cop=sim.cop, tau=None if t is None else t.tau,
        tau_joints=() if t is None else t.joints, source="sim",
    )  # fmt: skip


@pytest.fixture(scope="module")
def result(files):
    truth = sescid.load_robot(str(files["truth"]), "r_sole")
    data = _data(files["truth"], 3)
    models = [str(files[k]) for k in ("low", "phantom", "near", "battery")]
    return data, audit(data, models, support="r_sole", total_mass=truth.total_mass, folds=3)


def test_prediction_errors_are_pinocchios(files, result):
    """Each candidate's CoP and torque errors are those of Pinocchio's CoM and holding torques
    of that file (an independent model of the same file)."""
    from oracle import PinStatics

    data, res = result
    robot = sescid.load_robot(str(files["near"]), "r_sole")
    for c in res.candidates:
        pin = PinStatics(c.model, "r_sole", robot.joint_names, g0=G0)
        cop = pin.com(data.q)[:, :2]
        tau = pin.torques(data.q)
        cop_err, tau_err = c.error("cop"), c.error("tau")
        assert cop_err is not None and tau_err is not None
        assert cop_err.prediction == pytest.approx(
            np.sqrt(np.mean((data.cop - cop) ** 2)), rel=1e-9
        )
        res = data.tau - tau
        res = res - res.mean(axis=0)  # each sensor's offset, fitted aside
        assert tau_err.prediction == pytest.approx(np.sqrt(np.mean(res**2)), rel=1e-6)
        assert c.total_mass == pytest.approx(pin.total_mass(), rel=1e-12)


def test_the_near_true_file_ranks_first_and_the_faults_are_named(files, result):
    _, res = result
    by = {Path(c.model).stem: c for c in res.candidates}
    assert res.best is by["near"] and by["near"].rank == 1
    # the data's noise is found (the simulation's)
    assert by["near"].error("cop").noise == pytest.approx(COP_NOISE, rel=0.35)  # type: ignore[union-attr]
    assert by["near"].error("tau").noise == pytest.approx(TAU_NOISE, rel=0.2)  # type: ignore[union-attr]
    # the phantom: its body, about 1 kg less than the file says
    ph = by["phantom"].rejected[0]
    assert ph.bodies == (HAND,)
    assert abs(ph.change + 1.0) < 4 * ph.std + 0.02
    assert any(
        ch.body == "audit_phantom" and "phantom" in ch.problem for ch in by["phantom"].checks
    )
    assert by["phantom"].mass_gap == pytest.approx(-1.0, abs=0.05)
    # every mass 8 % low: every body carries 1/0.92 − 1 = 8.7 % more
    low = by["low"].rejected[0]
    assert low.bodies == (ALL_BODIES,)
    assert low.share == pytest.approx(1 / 0.92 - 1, abs=0.01)
    # the battery: the torso's first moment (or bodies the data cannot tell from it)
    bat = by["battery"].rejected
    assert bat and (bat[0].bodies == (TORSO,) or TORSO in bat[0].alternatives)
    # a fit absorbs what a prior gets wrong: the held-out error stays near the noise
    for c in res.candidates:
        cv = c.error("cop").cv  # type: ignore[union-attr]
        assert COP_NOISE * 0.6 < cv < COP_NOISE * 2


def test_the_true_file_is_not_rejected(files, result):
    """The file the data were simulated from: within the noise (the near-true one differs by 1 %
    of each mass and 1 mm of each CoM, which 760 torque rows may see)."""
    data, res = result
    truth = audit(data, [str(files["truth"])], support="r_sole", total_mass=res.weighed_mass,
                  folds=0)  # fmt: skip
    assert not truth.best.rejected and truth.best.score < 1.3


def test_torque_sensor_offsets_are_not_the_files(files):
    """Offsets on every torque sensor (as sescid's fits, fitted aside): the true file is still
    within the noise, and its errors are those of the offset-free readings."""
    robot = sescid.load_robot(str(files["truth"]), "r_sole")
    tau = TorqueNoise(noise=TAU_NOISE, offset=0.3)
    sim = sescid.simulate(robot, n=38, range_deg=20, noise=COP_NOISE, seed=8, torques=tau)
    t = sim.torques
    assert t is not None and np.abs(t.offsets).max() > 5 * TAU_NOISE
    data = Measurements(q=sim.q, cop=sim.cop, tau=t.tau, tau_joints=t.joints, source="sim")
    res = audit(data, [str(files["truth"])], support="r_sole", total_mass=robot.total_mass,
                folds=0)  # fmt: skip
    assert not res.best.rejected
    err = res.best.error("tau")
    assert err is not None and err.prediction < 1.3 * TAU_NOISE


def test_the_json_record(result):
    _, res = result
    doc = json.loads(json.dumps(res.to_json(), allow_nan=False))
    c = doc["candidates"][0]
    assert {"model", "total_mass", "mass_gap", "prediction_error", "cv_error", "rank", "rejected",
            "checks"} <= set(c)  # fmt: skip
    assert set(c["prediction_error"]) == {"cop_mm", "tau_Nm"}
    assert [x["rank"] for x in doc["candidates"]] == [1, 2, 3, 4]
    ph = next(x for x in doc["candidates"] if x["model"].endswith("phantom.urdf"))
    assert {"bodies", "change", "std", "z"} <= set(ph["rejected"][0])


def test_cop_alone_with_the_weighed_mass(files):
    """CoP data cannot see a common mass scale; the weighed mass can."""
    truth = sescid.load_robot(str(files["truth"]), "r_sole")
    data = _data(files["truth"], 5, torques=False)
    models = [str(files["low"]), str(files["near"])]
    res = audit(data, models, support="r_sole", total_mass=truth.total_mass, folds=0)
    assert Path(res.best.model).stem == "near"
    no_mass = audit(data, models, support="r_sole", folds=0)
    low = next(c for c in no_mass.candidates if "low" in c.model)
    assert not low.rejected  # the same CoP: nothing to reject without the weighed mass


def test_the_options_record_is_the_keywords(files):
    """``AuditOptions`` gives the audit the keywords give (the JSON, every number), keywords
    override its fields, and bad values or names are an OptionError naming the option."""
    truth = sescid.load_robot(str(files["truth"]), "r_sole")
    data = _data(files["truth"], 5, torques=False)
    models = [str(files["low"]), str(files["near"])]
    kw = audit(data, models, support="r_sole", total_mass=truth.total_mass, folds=0)
    opts = AuditOptions(support="r_sole", total_mass=truth.total_mass, folds=0)
    assert audit(data, models, opts).to_json() == kw.to_json()
    over = audit(data, models, AuditOptions(support="r_sole", folds=0), total_mass=truth.total_mass)
    assert over.to_json() == kw.to_json()
    for bad, name in (({"folds": 1}, "folds"), ({"total_mass": -1.0}, "total_mass")):
        with pytest.raises(OptionError, match=name):
            AuditOptions(**bad)
    with pytest.raises(OptionError, match="z_level"):
        audit(data, models, z_level=2.0)


def test_another_robot_talos(tmp_path):
    """The same on Talos (example-robot-data): a phantom on the right gripper is named."""
    from refs import erd

    src = erd("talos_data/robots/talos_reduced.urdf")
    truth = variant_urdf(src, tmp_path / "t.urdf", mass_jitter=0.05, com_jitter=0.003, seed=4)
    near = variant_urdf(truth, tmp_path / "near.urdf", mass_jitter=0.01, com_jitter=0.001, seed=5)
    ph = variant_urdf(near, tmp_path / "ph.urdf", phantom=("arm_right_7_link", 1.0, (0, 0, -0.1)))
    robot = sescid.load_robot(str(truth), "right_sole_link")
    sim = sescid.simulate(robot, n=38, range_deg=15, noise=COP_NOISE, seed=6)
    data = Measurements(q=sim.q, cop=sim.cop, source="sim")
    res = audit(data, [str(ph), str(near)], support="right_sole_link",
                total_mass=robot.total_mass, folds=0)  # fmt: skip
    assert Path(res.best.model).stem == "near"
    bad = next(c for c in res.candidates if c.model.endswith("ph.urdf"))
    named = bad.rejected[0]
    holder = sescid.load_robot(str(ph), "right_sole_link")
    body = holder.body_names[holder.model.link_frames["audit_phantom"][0]]
    assert named.bodies == (body,) or body in named.alternatives


def test_model_checks_name_the_body(tmp_path):
    import xml.etree.ElementTree as ET

    src = Path(sescid.load_robot("op2").model_path)
    tree = ET.parse(src)
    root = tree.getroot()
    for link in root.findall("link"):
        if link.get("name") == "MP_HEAD":
            inertia = link.find("inertial/inertia")
            assert inertia is not None
            inertia.set("ixx", "1e-4")
            inertia.set("iyy", "1e-4")
            inertia.set("izz", "5e-4")  # > ixx + iyy
        if link.get("name") == "MP_NECK":
            mass = link.find("inertial/mass")
            assert mass is not None
            mass.set("value", "0")
    for joint in root.findall("joint"):
        if joint.get("name") == "head_pan":
            joint.set("type", "continuous")
    path = tmp_path / "bad.urdf"
    tree.write(path)
    robot = sescid.load_robot(str(path), "r_sole")
    found = {(c.body, c.problem.split(" ")[0]) for c in model_checks(robot)}
    assert ("MP_HEAD", "inertia") in found
    assert ("MP_NECK", "moves") in found
    assert ("MP_NECK", "joint") in found  # head_pan turns the neck body
    assert model_checks(sescid.load_robot("op2")) == []


# --- compare --------------------------------------------------------------------------------
def _fit(path: Path, seed: int):
    cad = sescid.load_robot("op2")
    sim = sescid.simulate(sescid.load_robot(str(path), "r_sole"), n=38, range_deg=20,
                          noise=COP_NOISE, seed=seed)  # fmt: skip
    return sescid.identify(cad, sim.q, cop=sim.cop)


@pytest.fixture(scope="module")
def moved(files, tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("moved")
    return variant_urdf(files["truth"], d / "moved.urdf", moved=(TORSO, 0.3, (0.03, 0, 0)))


def test_compare_flags_a_moved_mass_and_not_noise(files, moved):
    before = _fit(files["truth"], 11)
    after = _fit(moved, 12)
    again = _fit(files["truth"], 13)
    res = compare([before, after])
    assert res.changed and (
        res.changed[0].bodies == (TORSO,) or TORSO in res.changed[0].alternatives
    )
    # the CoM moved by 0.3 kg × 30 mm / M along x (the torso frame's x is the support's at q=0)
    shift = 0.3 * 0.03 / sescid.load_robot(str(files["truth"]), "r_sole").total_mass
    assert res.com_change[0] == pytest.approx(shift, abs=3 * res.com_change_std)
    assert 0 < res.compared < before.r.size and res.not_compared == before.r.size - res.compared
    same = compare([before, again])
    assert not same.changed
    several = compare([before, again, after, _fit(files["truth"], 14)])
    assert [s.outlier for s in several.sessions] == [False, False, True, False]
    for r in (res, same, several):  # strict JSON: what is not determined is null
        doc = json.loads(json.dumps(r.to_json(), allow_nan=False))
        assert {"changed", "com_change_mm", "mass_change"} <= set(doc)


# --- command line ----------------------------------------------------------------------------


@pytest.fixture(scope="module")
def data_csv(files, tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("cli") / "d.csv"
    res = run("simulate", "--robot", files["truth"], "--support", "r_sole", "--count", 38,
              "--range-deg", 20, "--noise", COP_NOISE, "--seed", 3, "--out", out)  # fmt: skip
    assert res.exit_code == 0, res.output
    return out


def test_cli_audit_ranks_writes_json_and_fails_for_ci(files, data_csv, tmp_path):
    out = tmp_path / "a.json"
    res = run("audit", data_csv, "--models", files["phantom"], files["near"], "--support",
              "r_sole", "--folds", 0, "--json", out)  # fmt: skip
    assert res.exit_code == 0, res.output
    assert f"#1 {files['near']}" in res.output and HAND in res.output
    doc = json.loads(out.read_text())
    assert doc["best"] == str(files["near"])
    res = run("audit", data_csv, "-m", files["phantom"], "--support", "r_sole", "--folds", 0,
              "--fail-on", "rejected")  # fmt: skip
    assert res.exit_code == 3
    res = run("audit", data_csv, "-m", files["near"], "--support", "r_sole", "--folds", 0,
              "--fail-on", "checks")  # fmt: skip
    assert res.exit_code == 0


def _one_line_error(res, *words):
    assert res.exit_code == 2, res.output
    line = res.output.strip()
    assert "\n" not in line and line.startswith("sescid: error:"), line
    for w in words:
        assert w in line, line


def test_cli_bad_input_is_one_line(files, data_csv, tmp_path):
    text = Path(files["near"]).read_text().replace('"head_pan"', '"head_pan_renamed"')
    other = tmp_path / "renamed.urdf"
    other.write_text(text)
    res = run("audit", data_csv, "-m", files["near"], other, "--support", "r_sole", "--folds", 0)
    _one_line_error(res, "renamed.urdf", "head_pan")
    from refs import erd

    talos = tmp_path / "talos.urdf"  # another robot, with a support frame of the same name
    text = erd("talos_data/robots/talos_reduced.urdf").read_text()
    talos.write_text(text.replace('"right_sole_link"', '"r_sole"'))
    res = run("audit", data_csv, "-m", files["near"], talos, "--support", "r_sole")
    _one_line_error(res, "not the same robot")
    fit_a, fit_b = tmp_path / "a.json", tmp_path / "b.json"
    assert run("identify", data_csv, "--robot", "op2", "--out", fit_a).exit_code == 0
    assert run("identify", f"{data_csv}", "--robot", "op2", "--support", "l_sole",
               "--allow-outside-limits", "--out", fit_b).exit_code in (0, 2)  # fmt: skip
    if fit_b.exists():
        _one_line_error(run("compare", fit_a, fit_b), "support")
    _one_line_error(run("compare", fit_a), "two")


def test_cli_balance_data_need_their_noise(tmp_path):
    """Balanced poses on a line: as many unknowns as rows, so the noise is given; the file the
    data come from (the model itself: --extra-mass 0) is then within it, and its tilt error is
    in degrees."""
    data = tmp_path / "b.csv"
    res = run("simulate", "--robot", "op2", "--line", "y", "--measure", "balance", "--count", 38,
              "--range-deg", 20, "--seed", 2, "--extra-mass", 0, "--out", data)  # fmt: skip
    assert res.exit_code == 0, res.output
    _one_line_error(run("audit", data, "-m", "op2", "--line", "y"), "--noise balance=")
    out = tmp_path / "a.json"
    res = run("audit", data, "-m", "op2", "--line", "y", "--noise", "balance=0.5", "--folds", 0,
              "--json", out)  # fmt: skip
    assert res.exit_code == 0, res.output
    c = json.loads(out.read_text())["candidates"][0]
    assert c["noise"] == {"balance_deg": pytest.approx(0.5)}
    assert 0.3 < c["prediction_error"]["balance_deg"] < 0.8 and not c["rejected"]


def test_the_reports_section_names_what_the_data_reject(files, result):
    """``sescid report``'s section: the fit's model file judged against the report's data."""
    from sescid.report.audit_section import audit_section
    from sescid.report.inputs import ReportOptions, as_measurements, report_content

    data, _ = result
    robot = sescid.load_robot(str(files["phantom"]), "r_sole")
    weighed = sescid.load_robot(str(files["truth"]), "r_sole").total_mass
    fit = sescid.identify(robot, data, total_mass=weighed)
    html = audit_section(report_content(fit, as_measurements(fit, data), ReportOptions()))
    assert "The model file against the data" in html and HAND in html
    assert "audit_phantom" in html  # the check, named by link
