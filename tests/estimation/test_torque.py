"""The joint-torque measurement kind, checked against Pinocchio, MuJoCo and simulations with a
known truth: the physics, what torques can and cannot determine, sensor offsets and friction,
pooling with the CoP, a gantry, files and the command line."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from click.testing import CliRunner
from oracle import PinStatics
from urdf_gen import random_urdf

import sescid
from sescid import identify
from sescid.cli import cli
from sescid.errors import DataError
from sescid.estimation import IdentifyOptions, Measurements, fit_summary, perturbed_sesc
from sescid.simulation import random_poses
from sescid.tables import write_table

G0 = 9.81  #: Pinocchio's and MuJoCo's default |g|, m/s²
JOINTS_OP2 = 20


def _poses(robot, n, seed, half=0.5):
    return np.random.default_rng(seed).uniform(-half, half, (n, robot.nq))


def _tau(robot, q, r=None, **kw):
    return robot.torques(q, r, g0=G0, **kw)


def test_holding_torques_match_pinocchio_single_support(op2):
    """τ = g_a − J_aᵀ w with the sole's contact wrench w (Pinocchio) on the OP2."""
    q = _poses(op2, 12, 0)
    oracle = PinStatics(op2.model_path, "r_sole", op2.joint_names, G0)
    np.testing.assert_allclose(_tau(op2, q), oracle.torques(q), rtol=0, atol=2e-14)


@pytest.mark.parametrize("seed", range(4))
def test_holding_torques_match_pinocchio_on_random_trees(tmp_path, seed):
    """Random trees (fixed links merged, continuous joints, any support link)."""
    rng = np.random.default_rng(seed)
    text, links, _ = random_urdf(rng, n_links=9)
    path = tmp_path / "tree.urdf"
    path.write_text(text)
    support = links[int(rng.integers(0, len(links)))]
    robot = sescid.load_robot(path, support)
    q = rng.uniform(-2, 2, (6, robot.nq))
    oracle = PinStatics(path, support, robot.joint_names, G0)
    scale = np.abs(oracle.torques(q)).max()
    np.testing.assert_allclose(_tau(robot, q), oracle.torques(q), rtol=0, atol=1e-13 * scale)


def test_fixed_torso_matches_generalized_gravity(op2):
    """A gantry (the torso held): Pinocchio's computeGeneralizedGravity on a fixed base."""
    import pinocchio as pin

    torso = op2.model.model_root
    robot = sescid.load_robot("op2", support=torso)
    model = pin.buildModelFromUrdf(str(robot.model_path))
    model.gravity.linear = np.array([0.0, 0.0, -G0])
    data = model.createData()
    q = _poses(robot, 8, 1)
    cols = {n: i for i, n in enumerate(robot.joint_names)}
    for qk, ours in zip(q, _tau(robot, q), strict=True):
        qp = pin.neutral(model)
        for jid in range(1, model.njoints):
            qp[model.joints[jid].idx_q] = qk[cols[model.names[jid]]]
        g = pin.computeGeneralizedGravity(model, data, qp)
        theirs = np.array([g[model.joints[j].idx_v] for j in range(1, model.njoints)])
        mine = np.array([ours[cols[model.names[j]]] for j in range(1, model.njoints)])
        np.testing.assert_allclose(mine, theirs, rtol=0, atol=1e-13)


def _held_mjcf(rng) -> str:
    """A small held tree (no free joint) of hinged bodies with off-axis inertials."""

    def f(v):
        return " ".join(f"{x:.9g}" for x in v)

    def body(i, depth):
        turn = f' quat="{f(rng.normal(size=4))}"' if i else ""  # the held root: level
        out = [f'<body name="b{i}" pos="{f(rng.uniform(-0.2, 0.2, 3))}"{turn}>']
        if i:
            out.append(f'<joint name="j{i}" axis="{f(rng.normal(size=3))}" '
                       f'pos="{f(rng.uniform(-0.05, 0.05, 3))}"/>')  # fmt: skip
        out.append(
            f'<inertial pos="{f(rng.uniform(-0.1, 0.1, 3))}" mass="{rng.uniform(0.1, 2):.6f}" '
            'diaginertia="0.01 0.01 0.01"/>'
        )
        if depth < 3:
            for c in range(1 + (depth == 0)):
                out += body(i * 2 + c + 1, depth + 1)
        out.append("</body>")
        return out

    return "<mujoco><worldbody>" + "".join(body(0, 0)) + "</worldbody></mujoco>"


def test_mujoco_bias_force_of_a_held_model(tmp_path):
    """MuJoCo: a tree whose root body is held (no free joint), at rest: ``qfrc_bias``."""
    mujoco = pytest.importorskip("mujoco")
    rng = np.random.default_rng(4)
    path = tmp_path / "held.xml"
    path.write_text(_held_mjcf(rng))
    model = mujoco.MjModel.from_xml_path(str(path))
    robot = sescid.load_robot(path, "b0")
    data = mujoco.MjData(model)
    names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j) for j in range(model.njnt)]
    order = [robot.joint_names.index(n) for n in names]
    for _ in range(5):
        q = rng.uniform(-1.5, 1.5, robot.nq)
        data.qpos[:] = q[order]
        data.qvel[:] = 0
        mujoco.mj_forward(model, data)
        ours = _tau(robot, q[None])[0][order]
        np.testing.assert_allclose(ours, data.qfrc_bias, rtol=0, atol=1e-12)


def test_what_torques_determine_by_name(op2):
    """OP2 on its right sole: torques determine 40 of the CoP's 42 combinations, the two lost
    are the support body's own horizontal components, named so; pooled with a CoP: 42."""
    q = _poses(op2, 60, 2)
    m = Measurements(q=q, tau=_tau(op2, q), tau_joints=tuple(op2.joint_names))
    fit = identify(op2, m, gravity_accel=G0, total_mass=op2.total_mass, method="ls")
    assert fit.rank == 40
    kinds = {c.kind for c in fit.unidentifiable}
    assert "support-horizontal" in kinds and "not-excited" not in kinds
    horizontal = [c for c in fit.unidentifiable if c.kind == "support-horizontal"]
    assert len(horizontal) == 2 and all(op2.body_names[0] in c.reason for c in horizontal)
    pooled = dataclasses.replace(m, cop=op2.cop(q) + 1e-4 * np.random.default_rng(3).normal(
        size=(60, 2)))  # fmt: skip
    fit2 = identify(op2, pooled, gravity_accel=G0, total_mass=op2.total_mass, method="ls")
    assert fit2.rank == 42 and {k.kind for k in fit2.kinds} == {"cop", "tau"}


def test_noise_free_torques_recover_the_truth_and_the_offsets(op2):
    """A perturbed robot, noise-free torques with offsets: every determined quantity exact."""
    r_true = perturbed_sesc(op2, 0.15, offset=0.05, seed=1)
    q = _poses(op2, 50, 4)
    offsets = np.random.default_rng(5).normal(0, 0.1, op2.nq)
    tau = _tau(op2, q, r_true) + offsets + 1e-12 * np.random.default_rng(6).normal(size=(50, 20))
    m = Measurements(q=q, tau=tau, tau_joints=tuple(op2.joint_names))
    fit = identify(op2, m, gravity_accel=G0, total_mass=op2.total_mass, method="ls")
    est = np.array([e.value for e in fit.nuisance if e.what == "offset"])
    np.testing.assert_allclose(est, offsets, atol=1e-9)
    qf = _poses(op2, 200, 7)
    np.testing.assert_allclose(
        fit.predict_torque(qf), _tau(op2, qf, r_true) * op2.total_mass / op2.total_mass, atol=1e-9
    )
    # the CoM differs from the truth only by a constant horizontal shift: the support body's
    # own moments (with its children's joint-axis parts, which turn with it), unseen by torques
    d = fit.predict_com(qf)[:, :2] - op2.com(qf, r_true)[:, :2]
    assert np.ptp(d, axis=0).max() < 1e-9 and np.abs(d).max() > 1e-5


def test_friction_band_and_offset_separate_with_approach_sides(op2):
    """Held torques at the edge of a ±f band on the approach side: f and the offset are both
    recovered when each joint is approached from both sides; from one side only they are
    confounded and reported as not determined, with the reason."""
    q = _poses(op2, 60, 8)
    rng = np.random.default_rng(9)
    f = rng.uniform(0.1, 0.3, op2.nq)
    off = rng.normal(0, 0.1, op2.nq)
    side = np.where(rng.random(60) < 0.5, 1.0, -1.0)
    tau = _tau(op2, q) + off + side[:, None] * f
    m = Measurements(q=q, tau=tau, tau_joints=tuple(op2.joint_names), approach=side)
    fit = identify(op2, m, gravity_accel=G0, total_mass=op2.total_mass, method="ls")
    got = {(e.what, e.name): e for e in fit.nuisance}
    for j, name in enumerate(op2.joint_names):
        assert got["friction", name].value == pytest.approx(f[j], abs=1e-9)
        assert got["offset", name].value == pytest.approx(off[j], abs=1e-9)
    one_side = dataclasses.replace(m, approach=np.ones(60), tau=_tau(op2, q) + off + f)
    fit1 = identify(
        op2, one_side, gravity_accel=G0, total_mass=op2.total_mass, allow_exact=True, method="ls"
    )
    lost = [e for e in fit1.nuisance if not e.determined]
    assert len(lost) == 2 * op2.nq
    assert all(np.isnan(e.value) and np.isnan(e.std) and "confounded" in e.reason for e in lost)


def test_noisy_torques_estimate_their_noise_and_pool_with_the_cop(op2):
    """Each kind's noise is estimated from its own residuals (variance components)."""
    rng = np.random.default_rng(10)
    q = _poses(op2, 80, 11)
    m = Measurements(
        q=q,
        cop=op2.cop(q) + rng.normal(0, 0.005, (80, 2)),
        tau=_tau(op2, q) + rng.normal(0, 0.05, (80, op2.nq)),
        tau_joints=tuple(op2.joint_names),
    )
    kw = {"gravity_accel": G0, "total_mass": op2.total_mass, "method": "ls"}
    fit = identify(op2, m, tau_noise_model="shared", **kw)
    cop, tau = fit.kind("cop"), fit.kind("tau")
    assert cop.sigma == pytest.approx(0.005, rel=0.2) and tau.sigma == pytest.approx(0.05, rel=0.1)
    assert cop.sigma_by == tau.sigma_by == "estimated"
    assert cop.rms < 0.0055 and tau.rms < 0.055
    # the noise per joint (the default): each σ_j near 0.05, the torques' σ̂ a scale ≈ 1, the
    # CoP's still in metres
    joint = identify(op2, m, **kw)
    cop, tau = joint.kind("cop"), joint.kind("tau")
    sigma = np.array([r.sigma for r in joint.torque_noise])
    assert np.all(np.abs(sigma / 0.05 - 1) < 0.3) and tau.weighted and not cop.weighted
    assert tau.sigma == pytest.approx(1.0, rel=0.1) and cop.sigma == pytest.approx(0.005, rel=0.2)


def test_torques_beat_the_cop_on_a_perturbed_robot(op2):
    """38 single-support poses: torques (0.05 N·m, unknown offsets) with the CAD prior predict
    the CoM better than the CoP (4.93 mm) with the same prior; least squares equals an
    independent lstsq on the same rows."""
    rng = np.random.default_rng(12)
    r_true = perturbed_sesc(op2, 0.04, offset=0.03, seed=2)
    q = random_poses(op2, 38, 30, 13)
    tau = _tau(op2, q, r_true) + rng.normal(0, 0.1, op2.nq) + rng.normal(0, 0.05, (38, 20))
    cop = op2.cop(q, r_true) + rng.normal(0, 0.00493, (38, 2))
    joints = tuple(op2.joint_names)
    mass = op2.total_mass
    ls = identify(op2, Measurements(q=q, tau=tau, tau_joints=joints), total_mass=mass,
                  gravity_accel=G0, robust=False, method="ls",
                  tau_noise_model="shared")  # fmt: skip
    phi = op2.torque_regressor(q, g0=G0) * mass
    a = np.zeros((38 * 20, 63 + 20))
    for j in range(20):
        a[j * 38 : (j + 1) * 38, :63] = phi[:, j]
        a[j * 38 : (j + 1) * 38, 63 + j] = 1.0
    x0 = op2.sesc_vectors().reshape(-1)
    dx = np.linalg.lstsq(a, tau.T.reshape(-1) - a[:, :63] @ x0, rcond=1e-10)[0]
    qf = random_poses(op2, 2000, 30, 14)
    ref = op2.com(qf, (x0 + dx[:63]).reshape(-1, 3))
    np.testing.assert_allclose(ls.predict_com(qf)[:, :2], ref[:, :2], atol=1e-9)

    def err(fit):
        d = fit.predict_com(qf)[:, :2] - op2.com(qf, r_true)[:, :2]
        return float(np.sqrt(np.mean(np.sum(d**2, axis=1))))

    tau_map = identify(op2, Measurements(q=q, tau=tau, tau_joints=joints), method="map",
                       total_mass=mass, gravity_accel=G0)  # fmt: skip
    cop_map = identify(op2, q, cop, method="map")
    assert err(tau_map) < 0.6 * err(cop_map)


def test_gantry_beats_the_cad_model(op2):
    """The torso held in a fixture (no balance): torques alone, with the CAD prior (MAP),
    predict the held torques and the CoM better than CAD; least squares cannot (the offsets of
    joints on the fixed torso trade with their subtree's moments over a limited range); the held
    body's own moments are named as unseen."""
    torso = op2.model.model_root
    robot = sescid.load_robot("op2", support=torso)
    r_true = perturbed_sesc(robot, 0.1, offset=0.03, seed=3)
    rng = np.random.default_rng(15)
    q = random_poses(robot, 40, 45, 16)
    tau = _tau(robot, q, r_true) + rng.normal(0, 0.03, (40, robot.nq))
    m = Measurements(q=q, tau=tau, tau_joints=tuple(robot.joint_names))
    fit = identify(robot, m, method="map", total_mass=robot.total_mass, gravity_accel=G0)
    qf = random_poses(robot, 500, 45, 17)
    fit_err = fit.predict_torque(qf) - _tau(robot, qf, r_true)
    cad_err = _tau(robot, qf) - _tau(robot, qf, r_true)
    assert np.sqrt(np.mean(fit_err**2)) < 0.75 * np.sqrt(np.mean(cad_err**2))
    com_fit = fit.predict_com(qf) - robot.com(qf, r_true)
    com_cad = robot.com(qf) - robot.com(qf, r_true)
    assert np.sqrt(np.mean(com_fit**2)) < np.sqrt(np.mean(com_cad**2))
    held = [c for c in fit.unidentifiable if c.kind.startswith("support")]
    assert len(held) == 3 and all(torso in c.reason or robot.body_names[0] in c.reason
                                  for c in held)  # fmt: skip


def test_without_a_weighed_mass_the_model_mass_is_used_with_a_warning(op2):
    q = _poses(op2, 40, 18)
    m = Measurements(q=q, tau=_tau(op2, q) + 1e-3, tau_joints=tuple(op2.joint_names))
    fit = identify(op2, m, gravity_accel=G0, method="ls")
    assert not fit.mass_given and any("total mass was not given" in w for w in fit.warnings)
    assert fit.total_mass == pytest.approx(op2.total_mass)


def test_streamed_torques_equal_in_memory_bit_for_bit(op2):
    q = _poses(op2, 5000, 19)
    tau = _tau(op2, q) + np.random.default_rng(20).normal(0, 0.05, (5000, 20))
    joints = tuple(op2.joint_names)
    whole = identify(op2, Measurements(q=q, tau=tau, tau_joints=joints), method="ls")
    parts = (Measurements(q=q[s : s + 777], tau=tau[s : s + 777], tau_joints=joints)
             for s in range(0, 5000, 777))  # fmt: skip
    streamed = identify(op2, parts, method="ls")
    np.testing.assert_array_equal(whole.r, streamed.r)
    np.testing.assert_array_equal(whole.cov, streamed.cov)
    a, b = whole.kind("tau"), streamed.kind("tau")
    assert a.sigma == b.sigma and a.mae == pytest.approx(b.mae, rel=1e-12)


def test_bad_torque_input_is_one_line(op2):
    q = _poses(op2, 30, 21)
    tau = _tau(op2, q)
    with pytest.raises(sescid.SescidError, match="no joint named 'knee'"):
        identify(
            op2, Measurements(q=q, tau=tau[:, :1], tau_joints=("knee",)).checked(op2), method="ls"
        )
    bad = tau.copy()
    bad[4, 2] = np.nan
    with pytest.raises(DataError, match="pose 4, tau_r_sho_roll: nan is not a finite number"):
        identify(op2, Measurements(q=q, tau=bad, tau_joints=tuple(op2.joint_names)), method="ls")
    with pytest.raises(DataError, match="approach = 0"):
        identify(op2, Measurements(q=q, tau=tau, tau_joints=tuple(op2.joint_names),
                                   approach=np.zeros(30)), method="ls")  # fmt: skip
    with pytest.raises(DataError, match=r"is more than the robot's weight at 2 m .*\(mN·m\?\)"):
        identify(
            op2, Measurements(q=q, tau=tau * 1e3, tau_joints=tuple(op2.joint_names)), method="ls"
        )
    with pytest.raises(DataError, match="the torques are the model's with the opposite sign"):
        identify(op2, Measurements(q=q, tau=-tau, tau_joints=tuple(op2.joint_names)), method="ls")


def test_cli_identifies_from_a_torque_file(op2, tmp_path):
    """A CSV with joint angles and tau_<joint> columns, no CoP: offsets printed and stored."""
    q = _poses(op2, 60, 22)
    off = np.linspace(-0.1, 0.1, op2.nq)
    tau = _tau(op2, q) + off + np.random.default_rng(23).normal(0, 0.02, (60, op2.nq))
    cols = {j: q[:, k] for k, j in enumerate(op2.joint_names)}
    cols |= {f"tau_{j}": tau[:, k] for k, j in enumerate(op2.joint_names)}
    path = tmp_path / "tau.csv"
    write_table(path, cols)
    out = tmp_path / "fit.json"
    res = CliRunner().invoke(
        cli,
        ["identify", str(path), "--out", str(out), "--total-mass", str(op2.total_mass),
         "--gravity-accel", str(G0), "--allow-outside-limits", "--no-robust"],
    )  # fmt: skip
    assert res.exit_code == 0, res.output
    assert "torque sensors [N·m]" in res.output and "rank 40 of 63" in res.output
    back = sescid.load_fit(out)
    got = np.array([e.value for e in back.nuisance if e.what == "offset"])
    std = np.array([e.std for e in back.nuisance if e.what == "offset"])
    assert np.all(np.abs(got - off) < 4 * std)  # the support leg's offsets trade with the CoM
    # the noise per joint (the default): each σ_j near the 0.02 N·m drawn, σ̂ a scale ≈ 1
    sigma = np.array([r.sigma for r in back.torque_noise])
    assert sigma.size == op2.nq and np.median(sigma) == pytest.approx(0.02, rel=0.1)
    assert np.all(np.abs(sigma / 0.02 - 1) < 0.35) and "noise σ_j" in res.output
    assert back.kind("tau").sigma == pytest.approx(1.0, rel=0.1) and back.mass_given


def test_options_check_their_ranges(op2):
    with pytest.raises(sescid.OptionError, match="tau_noise"):
        IdentifyOptions(tau_noise=-1.0)
    with pytest.raises(sescid.OptionError, match="gravity_accel"):
        IdentifyOptions(gravity_accel=9810.0)


def test_body_prior_fits_torques_and_cop(op2):
    """The per-body CAD prior (masses ±τ, first moments ±τ·5 cm per unit mass): on a robot
    whose bodies differ from CAD in that way it predicts the CoM better than CAD from torques
    and from the CoP, and says how many directions it decided."""
    from sescid.estimation import MapOptions
    from sescid.sesc import sesc_vectors

    rng = np.random.default_rng(30)
    bodies = []
    for b in op2.model.bodies:
        m = max(b.mass * (1 + rng.normal(0, 0.1)) + rng.normal(0, 0.01), 1e-3)
        bodies.append(
            dataclasses.replace(b, mass=m, com=(b.mass * b.com + rng.normal(0, 0.005, 3) * m) / m)
        )
    r_true = sesc_vectors(dataclasses.replace(op2.model, bodies=bodies))
    mass = sum(b.mass for b in bodies)
    q = random_poses(op2, 38, 30, 31)
    tau = _tau(op2, q, r_true, total_mass=mass) + rng.normal(0, 0.05, (38, op2.nq))
    opts = MapOptions(prior="bodies")
    m = Measurements(q=q, tau=tau, tau_joints=tuple(op2.joint_names))
    fit = identify(op2, m, method=opts, total_mass=mass, gravity_accel=G0)
    cop_fit = identify(op2, q, op2.cop(q, r_true) + rng.normal(0, 0.00493, (38, 2)),
                       method=opts)  # fmt: skip
    qf = random_poses(op2, 1000, 30, 32)

    def err(r):
        d = op2.com(qf, r)[:, :2] - op2.com(qf, r_true)[:, :2]
        return float(np.sqrt(np.mean(np.sum(d**2, axis=1))))

    assert err(fit.r) < 0.6 * err(op2.sesc_vectors()) and err(cop_fit.r) < err(op2.sesc_vectors())
    assert fit.map.prior == "bodies" and 0 < fit.map.prior_decided < 63


def test_few_or_no_degrees_of_freedom_are_flagged(op2):
    """22 poses (44 equations, 42 combinations): a warning; an exact fit: nan, said so."""
    q = random_poses(op2, 22, 30, 40)
    fit = identify(
        op2, q, op2.cop(q) + np.random.default_rng(41).normal(0, 0.005, (22, 2)), method="ls"
    )
    assert any("only 2 residual degrees of freedom" in w for w in fit.warnings)
    q = random_poses(op2, 21, 30, 42)
    exact = identify(op2, q, op2.cop(q), allow_exact=True, method="ls")
    assert np.isnan(exact.sigma_hat) and any("no degrees of freedom" in w for w in exact.warnings)
    assert all(np.isnan(c.std) for c in exact.base)
    assert "not determined" in fit_summary(exact)


def test_simulated_torque_readings_follow_the_sensor_model(op2):
    """simulate(torques=…): readings − truth = offsets + side·friction + N(0, σ²)."""
    from sescid.simulation import TorqueNoise, simulate

    sim = simulate(op2, 4000, 30, 0.0, 43, torques=TorqueNoise(0.05, 0.1, 0.2))
    t = sim.torques
    np.testing.assert_allclose(t.tau_true, op2.torques(sim.q), rtol=0, atol=1e-12)
    e = t.tau - t.tau_true - t.offsets - t.approach[:, None] * t.friction
    assert abs(e.std() - 0.05) < 0.002 and abs(e.mean()) < 0.002
    assert set(np.unique(t.approach)) == {-1.0, 1.0} and np.std(t.offsets) > 0.03


def test_cli_simulates_and_identifies_torques_alone(op2, tmp_path):
    """`simulate --measure tau` writes torque columns only; identify recovers offsets and the
    friction band from them (the approach column) within their standard errors."""
    data, out = tmp_path / "t.csv", tmp_path / "fit.json"
    runner = CliRunner()
    res = runner.invoke(cli, ["simulate", "--count", "300", "--measure", "tau", "--tau-offset",
                              "0.1", "--tau-friction", "0.15", "--out", str(data)])  # fmt: skip
    assert res.exit_code == 0, res.output
    header = data.read_text().splitlines()[0].split(",")
    assert "cop_x" not in header and "tau_r_knee" in header and "approach" in header
    res = runner.invoke(cli, ["identify", str(data), "--out", str(out), "--total-mass",
                              str(op2.total_mass)])  # fmt: skip
    assert res.exit_code == 0, res.output
    fit = sescid.load_fit(out)
    friction = [e for e in fit.nuisance if e.what == "friction"]
    assert len(friction) == 20
    assert all(abs(e.value - 0.15) < 4 * e.std for e in friction)
    sigma = np.array([r.sigma for r in fit.torque_noise])
    assert np.median(sigma) == pytest.approx(0.05, rel=0.1)
    assert fit.kind("tau").sigma == pytest.approx(1.0, rel=0.1)


def test_torque_gains_ratios_from_the_data(op2):
    """Readings (1 + γ_j)(τ_j + o_j): Gauss–Newton recovers the gains' ratios from precise
    data (3 mN·m) (their common part is a different scale of M·r: the prior's), and within
    their standard errors from noisy data."""
    rng = np.random.default_rng(50)
    q = random_poses(op2, 200, 30, 51)
    gains = rng.normal(0, 0.05, op2.nq)
    off = rng.normal(0, 0.1, op2.nq)
    exact = (1 + gains) * (_tau(op2, q) + off) + 3e-3 * rng.normal(size=(200, op2.nq))
    joints = tuple(op2.joint_names)
    fit = identify(op2, Measurements(q=q, tau=exact, tau_joints=joints), tau_gains=True,
                   total_mass=op2.total_mass, gravity_accel=G0, method="ls")  # fmt: skip
    est = np.array([e.value for e in fit.nuisance if e.what == "gain"])
    shift = np.log1p(est) - np.log1p(gains)
    moving = _tau(op2, q).std(axis=0) > 0.1  # a nearly constant torque's gain is its offset's
    assert moving.sum() >= 8 and np.ptp(shift[moving]) < 3e-3
    assert all("ratios" in e.reason for e in fit.nuisance if e.what == "gain")
    noisy = (1 + gains) * (_tau(op2, q) + off) + rng.normal(0, 0.03, (200, op2.nq))
    fit = identify(op2, Measurements(q=q, tau=noisy, tau_joints=joints), tau_gains=True,
                   total_mass=op2.total_mass, gravity_accel=G0, method="ls")  # fmt: skip
    est = np.array([e.value for e in fit.nuisance if e.what == "gain"])
    std = np.array([e.std for e in fit.nuisance if e.what == "gain"])
    z = (np.log1p(est) - np.log1p(gains) - np.mean(np.log1p(est) - np.log1p(gains))) / std
    assert np.sqrt(np.mean(z**2)) < 2.0
    qf = random_poses(op2, 100, 30, 52)
    reading = fit.predict_torque(qf, reading=True)
    truth = (1 + gains) * (_tau(op2, qf) + off)
    assert np.sqrt(np.mean((reading - truth) ** 2)) < 0.03


def test_torque_gains_beside_a_cop_use_the_methods_rows(op2):
    """Torque gains with a CoP in the same data: the gains' system takes its CoP rows as the
    method makes them (a MAP fit with a CoP offset keeps that column), and every measured joint
    gets a gain."""
    rng = np.random.default_rng(60)
    q = random_poses(op2, 300, 30, 61)
    gains = rng.normal(0, 0.05, op2.nq)
    tau = (1 + gains) * _tau(op2, q) + 1e-3 * rng.normal(size=(300, op2.nq))
    cop = op2.cop(q) + 1e-4 * rng.normal(size=(300, 2))
    data = Measurements(q=q, cop=cop, tau=tau, tau_joints=tuple(op2.joint_names))
    for method in ("ls", sescid.MapOptions(bias=True)):
        fit = identify(op2, data, tau_gains=True, total_mass=op2.total_mass, gravity_accel=G0,
                       method=method)  # fmt: skip
        assert sum(e.what == "gain" for e in fit.nuisance) == op2.nq
        assert (fit.cop_offset is not None) == (method != "ls")
