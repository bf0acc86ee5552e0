"""FSR samples → per-pose CoP: closed forms, rejections, standard errors, bad input."""

from __future__ import annotations

import csv
import math

import numpy as np
import pytest
from click.testing import CliRunner

import sescid
from sescid.cli import cli
from sescid.errors import SescidError
from sescid.robots import profile_for
from sescid.sensors import REASONS, fsr, load_sensors, measure, read_raw
from sescid.tables import read_table, write_table

# Sensor centres of fsr.md §4–§6 written out by hand (sole frame, m): pads 10 mm in from the
# front/rear and 6.5 mm in from the side edges of the 0.105 × 0.066 m sole → x ±0.0425,
# y ±0.0265. Right: FSR1 inner front, FSR2 outer front, FSR3 inner rear, FSR4 outer rear
# (inner = +y). Left: FSR1 inner rear, FSR2 outer rear,
# FSR3 inner front, FSR4 outer front (inner = −y).
RIGHT = np.array([[0.0425, 0.0265], [0.0425, -0.0265], [-0.0425, 0.0265], [-0.0425, -0.0265]])
LEFT = np.array([[-0.0425, -0.0265], [-0.0425, 0.0265], [0.0425, -0.0265], [0.0425, 0.0265]])
#: l_sole relative to r_sole at the all-zero pose: ankles at y = ±0.037 m, soles 0.0109 m outward
L_SOLE_AT_ZERO = np.array([0.0, 2 * (0.037 + 0.0109)])


@pytest.fixture(scope="module")
def config():
    return load_sensors(profile=profile_for("op2"))


def joints(robot, m, q=None):
    q = np.zeros(robot.nq) if q is None else q
    return {j: np.full(m, q[i]) for i, j in enumerate(robot.joint_names)}


def log_file(path, robot, pose, feet: dict, q=None, extra=None):
    """Write a raw log: pose ids, joints (rad), feet {prefix: (m, 4) counts or (m, 2) regs}."""
    m = len(pose)
    cols = {"pose": np.asarray(pose)} | joints(robot, m, q)
    for prefix, arr in feet.items():
        arr = np.asarray(arr, dtype=float)
        if arr.shape[1] == 4:
            cols |= {f"{prefix}{k + 1}": arr[:, k] for k in range(4)}
        else:
            cols |= {f"{prefix}_x": arr[:, 0], f"{prefix}_y": arr[:, 1]}
    cols |= extra or {}
    write_table(path, cols)
    return path


def run(robot, config, path, min_samples=2):
    return measure(
        robot,
        read_raw(read_table(path), robot.joint_names, config, robot.profile.servo),
        config,
        min_samples,
    )


def test_shipped_positions_are_the_fsr_md_corners(config):
    np.testing.assert_allclose(config.foot("right").sensors, RIGHT, atol=1e-15)
    np.testing.assert_allclose(config.foot("left").sensors, LEFT, atol=1e-15)


def test_cop_from_forces_is_the_weighted_centroid(robot, config, tmp_path):
    rng = np.random.default_rng(1)
    f = rng.uniform(2000, 9000, size=(60, 4))  # mN
    pose = np.repeat([7, 3, 5], 20)
    res = run(robot, config, log_file(tmp_path / "raw.csv", robot, pose, {"r_fsr": f}))
    per_sample = (f @ RIGHT) / f.sum(axis=1, keepdims=True)
    expected = per_sample.reshape(3, 20, 2).mean(axis=1)
    assert res.pose.tolist() == ["7", "3", "5"]  # the log's order
    np.testing.assert_allclose(res.data.cop, expected, atol=1e-14)
    np.testing.assert_allclose(res.force, f.sum(axis=1).reshape(3, 20).mean(axis=1) / 1000)
    assert res.n_used.tolist() == [20, 20, 20]


def test_centroid_registers_right_foot(robot, config, tmp_path):
    reg = np.array([[0, 0], [254, 0], [127, 200], [31, 254], [254, 254]] * 2)
    pose = np.repeat(np.arange(5), 1).tolist() * 2
    res = run(robot, config, log_file(tmp_path / "raw.csv", robot, pose, {"r_fsr": reg}))
    x_reg, y_reg = reg[:5, 0], reg[:5, 1]
    # fsr.md §6, right foot: both board terms negated; s_x = 0.085, s_y = 0.053 m
    expected = np.column_stack([-(y_reg / 254 - 0.5) * 0.085, -(x_reg / 254 - 0.5) * 0.053])
    np.testing.assert_allclose(res.data.cop, expected, atol=1e-15)
    assert res.mode == "centroid"


def test_centroid_registers_left_foot(config, tmp_path):
    left = sescid.load_robot("op2", support="l_sole")
    reg = np.array([[10, 240], [200, 17]] * 2)
    res = run(left, config, log_file(tmp_path / "raw.csv", left, [0, 1, 0, 1], {"l_fsr": reg}))
    expected = np.column_stack([(reg[:2, 1] / 254 - 0.5) * 0.085, (reg[:2, 0] / 254 - 0.5) * 0.053])
    np.testing.assert_allclose(res.data.cop, expected, atol=1e-15)


def test_double_support_weights_each_foot_by_its_force(robot, config, tmp_path):
    rng = np.random.default_rng(2)
    fr = rng.uniform(1000, 6000, size=(10, 4))
    fl = rng.uniform(1000, 6000, size=(10, 4))
    path = log_file(tmp_path / "raw.csv", robot, [0] * 10, {"r_fsr": fr, "l_fsr": fl})
    res = run(robot, config, path)
    cr = fr @ RIGHT / fr.sum(1, keepdims=True)
    cl = fl @ LEFT / fl.sum(1, keepdims=True) + L_SOLE_AT_ZERO
    wr, wl = fr.sum(1, keepdims=True), fl.sum(1, keepdims=True)
    expected = ((wr * cr + wl * cl) / (wr + wl)).mean(axis=0)
    np.testing.assert_allclose(res.data.cop[0], expected, atol=1e-6)  # soles 0.1 mm model rounding


def test_lifted_foot_below_threshold_is_ignored(robot, config, tmp_path):
    fr = np.full((6, 4), 5000.0)
    fr[:, 0] = 8000.0
    fl = np.full((6, 4), 400.0)  # 1.6 N in total: below 4 × 0.493 N, the foot is in the air
    res = run(
        robot, config, log_file(tmp_path / "r.csv", robot, [0] * 6, {"r_fsr": fr, "l_fsr": fl})
    )
    np.testing.assert_allclose(res.data.cop[0], fr[0] @ RIGHT / fr[0].sum(), atol=1e-15)


def test_rejections_are_counted_by_reason(robot, config, tmp_path):
    rng = np.random.default_rng(3)
    m = 50
    f = 7000 + rng.normal(0, 30, size=(m, 4))
    f[0:3] = 0.0  # no load
    f[3, 2] = 65535  # saturated
    f[4, 0] = 65535
    f[5] = [20000, 100, 100, 100]  # CoP far in the front-inner corner: an outlier
    f[6] = [100, 100, 100, 20000]
    path = log_file(tmp_path / "raw.csv", robot, [0] * m, {"r_fsr": f})
    rows = list(csv.reader(path.open()))
    rows[8][rows[0].index("r_fsr2")] = ""  # two samples with a missing cell (rows 7, 8)
    rows[9][rows[0].index("r_knee")] = "nan"
    with path.open("w", newline="") as fh:
        csv.writer(fh).writerows(rows)
    res = run(robot, config, path)
    counts = dict(zip(("missing", "saturated", "no_load", "outlier"), [2, 2, 3, 2], strict=True))
    got = {r: int(res.rejected[0][i]) for i, r in enumerate(REASONS)}
    for r, c in counts.items():
        assert got[r] == c, (r, got)
    assert res.n_used[0] == m - 9
    good = np.r_[9:m]
    np.testing.assert_allclose(
        res.data.cop[0], np.mean(f[good] @ RIGHT / f[good].sum(1)[:, None], 0)
    )
    assert res.reasons()[0] == "missing=2 saturated=2 no_load=3 outlier=2"


def test_standard_error_is_noise_over_sqrt_n(robot, config, tmp_path):
    rng = np.random.default_rng(4)
    n_pose, n = 200, 25
    f0 = np.array([9000.0, 6000.0, 8000.0, 5000.0])
    f = f0 + rng.normal(0, 400, size=(n_pose * n, 4))
    res = run(
        robot,
        config,
        log_file(tmp_path / "r.csv", robot, np.repeat(np.arange(n_pose), n), {"r_fsr": f}),
    )
    # the reported standard error predicts the scatter of the pose means (same true CoP)
    spread = res.data.cop.std(axis=0, ddof=1)
    np.testing.assert_allclose(res.data.cop_se.mean(axis=0), spread, rtol=0.12)
    # and equals the per-sample CoP noise / √n
    per_sample = (f @ RIGHT) / f.sum(1, keepdims=True)
    np.testing.assert_allclose(
        res.data.cop_se.mean(axis=0), per_sample.std(axis=0) / math.sqrt(n), rtol=0.05
    )


def test_readbacks_in_ticks_and_degrees(robot, config, tmp_path):
    f = np.full((4, 4), 5000.0)
    cols = {"pose": np.zeros(4)}
    ticks = np.array([2048, 2050, 2046, 2060])
    for i, j in enumerate(robot.joint_names):
        if i % 2:
            cols[f"{j}_ticks"] = ticks + i
        else:
            cols[f"{j}_deg"] = np.full(4, float(i))
    cols |= {f"r_fsr{k + 1}": f[:, k] for k in range(4)}
    write_table(tmp_path / "r.csv", cols)
    res = run(robot, config, tmp_path / "r.csv")
    for i in range(robot.nq):
        want = (ticks.mean() + i - 2048) * 2 * math.pi / 4096 if i % 2 else math.radians(i)
        assert res.data.q[0, i] == pytest.approx(want, abs=1e-14)


# --- bad input (issue 3 §5) ---------------------------------------------------------------
def test_mixed_units_for_a_joint_is_an_error(robot, config, tmp_path):
    path = log_file(
        tmp_path / "r.csv",
        robot,
        [0, 0],
        {"r_fsr": np.full((2, 4), 5e3)},
        extra={"r_knee_ticks": np.full(2, 2048.0)},
    )
    with pytest.raises(SescidError, match="'r_knee' is given in two units"):
        run(robot, config, path)


def test_zero_load_pose_is_dropped_and_reported(robot, config, tmp_path):
    f = np.full((20, 4), 5000.0)
    f[10:] = 0.0
    res = run(
        robot, config, log_file(tmp_path / "r.csv", robot, np.repeat([1, 2], 10), {"r_fsr": f})
    )
    assert res.pose.tolist() == ["1"]
    assert res.dropped == [("2", "0 usable of 10 samples (need 2; rejected: no_load=10)")]


def test_saturated_pose_is_dropped_not_averaged(robot, config, tmp_path):
    f = np.full((10, 4), 5000.0)
    f[5:, 3] = 65535
    res = run(
        robot, config, log_file(tmp_path / "r.csv", robot, np.repeat([1, 2], 5), {"r_fsr": f})
    )
    assert res.pose.tolist() == ["1"]
    assert "saturated=5" in res.dropped[0][1]


def test_unknown_pose_id_is_an_error(robot, config, tmp_path):
    raw = log_file(tmp_path / "r.csv", robot, [0, 0, 9, 9], {"r_fsr": np.full((4, 4), 5e3)})
    write_table(tmp_path / "poses.csv", joints(robot, 3))  # ids 0, 1, 2 (row numbers)
    with pytest.raises(SescidError, match="pose id '9' is not in the pose list"):
        fsr(robot, read_table(raw), config, 2, read_table(tmp_path / "poses.csv"))
    # measured ⊂ list: fine, and the unmeasured poses are reported
    raw = log_file(tmp_path / "r2.csv", robot, [0, 0, 2, 2], {"r_fsr": np.full((4, 4), 5e3)})
    assert fsr(robot, read_table(raw), config, 2, read_table(tmp_path / "poses.csv"))[1] == ["1"]


@pytest.mark.parametrize(
    ("feet", "message"),
    [
        ({"r_fsr": np.array([[5e3, 5e3, -1, 5e3]] * 2)}, "negative force count"),
        ({"r_fsr": np.array([[300, 20]] * 2)}, "is not a centroid register"),
        ({"r_fsr": np.full((2, 4), 5e3), "l_fsr": np.array([[3, 4]] * 2)}, "same kind"),
        ({}, "no foot-sensor columns"),
    ],
)
def test_malformed_sensor_columns(robot, config, tmp_path, feet, message):
    with pytest.raises(SescidError, match=message):
        run(robot, config, log_file(tmp_path / "r.csv", robot, [0, 0], feet))


def test_registers_of_two_loaded_feet_are_rejected(robot, config, tmp_path):
    reg_r = np.array([[100, 100]] * 4)
    reg_l = np.array([[100, 100], [255, 255], [100, 100], [255, 255]])
    res = run(
        robot,
        config,
        log_file(tmp_path / "r.csv", robot, [0] * 4, {"r_fsr": reg_r, "l_fsr": reg_l}),
    )
    assert res.rejected[0].sum() == 2 and "two_feet_no_force=2" in res.reasons()[0]


def test_bad_sensor_configuration(tmp_path):
    p = tmp_path / "s.json"
    p.write_text(
        '{"format": "sescid-fsr/1", "feet": {"right": {"sole_frame": "r_sole", '
        '"columns": "r_fsr", "sensors_m": [[0, 0], [1, 0], [0, 1], [1, 2]]}}}'
    )
    with pytest.raises(SescidError, match="must form a rectangle"):
        load_sensors(p)
    p.write_text("{not json")
    with pytest.raises(SescidError, match="not a JSON file"):
        load_sensors(p)


def test_corrected_sensor_positions_are_used(robot, tmp_path):
    p = tmp_path / "s.json"
    pts = [[0.04, 0.02], [0.04, -0.025], [-0.045, 0.02], [-0.045, -0.025]]
    p.write_text(
        '{"format": "sescid-fsr/1", "feet": {"right": {"sole_frame": "r_sole", '
        f'"columns": "r_fsr", "sensors_m": {pts}}}}}}}'
    )
    cfg = load_sensors(p)
    f = np.array([[1000.0, 2000.0, 3000.0, 4000.0]] * 2)
    res = run(robot, cfg, log_file(tmp_path / "r.csv", robot, [0, 0], {"r_fsr": f}))
    np.testing.assert_allclose(res.data.cop[0], f[0] @ np.array(pts) / f[0].sum(), atol=1e-15)


def test_cli_fsr_writes_per_pose_table(robot, tmp_path):
    f = np.full((10, 4), 5000.0) + np.arange(10)[:, None] * 10
    raw = log_file(tmp_path / "r.csv", robot, np.repeat([4, 8], 5), {"r_fsr": f})
    out = tmp_path / "m.csv"
    res = CliRunner().invoke(cli, ["fsr", str(raw), "--out", str(out)])
    assert res.exit_code == 0, res.output
    tab = read_table(out)
    assert tab.get("pose").tolist() == [4, 8]
    assert tab.get("n_used").tolist() == [5, 5]
    for c in ("cop_x", "cop_y", "cop_se_x", "cop_se_y", "n_rejected", *robot.joint_names):
        assert c in tab
    assert tab.text["reject_reasons"] == ["none", "none"]


def test_cli_fsr_bad_input_is_one_line_and_no_file(robot, tmp_path):
    raw = log_file(tmp_path / "r.csv", robot, [0, 0, 1, 1], {"r_fsr": np.zeros((4, 4))})
    out = tmp_path / "m.csv"
    res = CliRunner().invoke(cli, ["fsr", str(raw), "--out", str(out)])
    assert res.exit_code == 2
    lines = res.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("sescid: error: ")
    assert "no pose has a usable CoP" in lines[0] and "no_load=2" in lines[0]
    assert not out.exists() and not list(tmp_path.glob(".m*"))


def test_parquet_log_with_text_ids_and_missing_values(robot, config, tmp_path):
    f = np.full((6, 4), 6000.0)
    f[1, 2] = np.nan  # a missing value (null in Parquet)
    cols = {"pose": np.array(["a", "a", "a", "b", "b", "b"])} | joints(robot, 6)
    cols |= {f"r_fsr{k + 1}": f[:, k] for k in range(4)}
    write_table(tmp_path / "raw.parquet", cols)
    res, _ = fsr(robot, read_table(tmp_path / "raw.parquet"), config, 2)
    assert res.pose.tolist() == ["a", "b"]
    assert res.n_used.tolist() == [2, 3] and res.reasons() == ["missing=1", "none"]
    np.testing.assert_allclose(res.data.cop, 0.0, atol=1e-15)  # equal forces: the sole centre


def test_load_on_a_foot_the_model_puts_in_the_air_is_rejected(robot, config, tmp_path):
    from op2_stance import stable_poses

    q = stable_poses(robot, 1, seed=0)[0]  # left foot lifted several cm in the model
    assert robot.link_poses(q[None], "l_sole")[1][0, 2] > 0.03
    fr, fl = np.full((8, 4), 5000.0), np.zeros((8, 4))
    fl[:3] = 3000.0  # yet the left board reports load in 3 samples
    path = log_file(tmp_path / "r.csv", robot, [0] * 8, {"r_fsr": fr, "l_fsr": fl}, q=q)
    res = run(robot, config, path)
    assert res.reasons() == ["off_floor=3"] and res.n_used.tolist() == [5]
    np.testing.assert_allclose(res.data.cop[0], 0.0, atol=1e-15)


# --- a logged CoP per foot (ankle F/T sensor, force plate, CoP topic) ----------------------------
def _pads_and_cop(rng, m, sensors, lifted=(), spread=1000.0):
    """Pad counts (m, 4) mN and the CoP (m, 2) m, fz (m,) N they produce; lifted rows 0.4 N/pad."""
    f = rng.uniform(4000 - spread, 4000 + spread, size=(m, 4))
    f[list(lifted)] = 100.0
    fz = f.sum(axis=1) / 1000
    cop = (f @ sensors) / f.sum(axis=1, keepdims=True)
    return f, cop, fz


def cop_cols(prefix, cop, fz=None):
    cols = {f"{prefix}_cop_x": cop[:, 0], f"{prefix}_cop_y": cop[:, 1]}
    return cols if fz is None else cols | {f"{prefix}_fz": fz}


def test_logged_cop_with_force_matches_the_pads_that_produce_it(robot, config, tmp_path):
    """Both feet's <p>_cop_x/_y and <p>_fz give the per-pose CoP, force and counts of their pads."""
    rng = np.random.default_rng(7)
    m = 24
    fr, cr, zr = _pads_and_cop(rng, m, RIGHT)
    fl, cl, zl = _pads_and_cop(rng, m, LEFT, lifted=[3, 4, 15])
    fr[9, 2] = np.nan  # a missing pad: a missing force on the CoP side
    zr[9], cr[9] = np.nan, np.nan
    cl[[3, 4, 15]] = np.nan  # a lifted foot has no CoP (wrench.py gives NaN below min_force)
    pose = np.repeat(["a", "b", "c"], 8)
    pads = run(robot, config, log_file(tmp_path / "p.csv", robot, pose, {"r_fsr": fr, "l_fsr": fl}))
    extra = cop_cols("r", cr, zr) | cop_cols("l", cl, zl)
    cops = run(robot, config, log_file(tmp_path / "c.csv", robot, pose, {}, extra=extra))
    assert cops.mode == pads.mode == "forces"
    np.testing.assert_allclose(cops.data.cop, pads.data.cop, atol=1e-15)
    np.testing.assert_allclose(cops.data.cop_se, pads.data.cop_se, rtol=1e-9)
    np.testing.assert_allclose(cops.force, pads.force, rtol=1e-12)
    assert cops.reasons() == pads.reasons() and "missing=1" in cops.reasons()[1]
    assert cops.n_used.tolist() == pads.n_used.tolist()


def test_logged_cop_without_force_is_one_loaded_foot(robot, config, tmp_path):
    """Without _fz a given CoP is a loaded foot of weight 1: one foot as its pads, no force."""
    rng = np.random.default_rng(8)
    _, cr, _ = _pads_and_cop(rng, 10, RIGHT, spread=100.0)
    pose = np.repeat([0, 1], 5)
    cl = np.full((10, 2), np.nan)
    cl[[2, 7]] = 0.01  # the left foot touches down twice: two loaded feet, no force to weigh
    cr[4] = np.nan  # neither foot loaded
    extra = cop_cols("r", cr) | cop_cols("l", cl)
    res, _ = fsr(
        robot, read_table(log_file(tmp_path / "c.csv", robot, pose, {}, extra=extra)), config, 2
    )
    keep = np.ones(10, dtype=bool)
    keep[[2, 4, 7]] = False
    want = np.array([cr[keep & (pose == k)].mean(axis=0) for k in range(2)])
    assert res.mode == "cop" and "force_n" not in res.columns(robot.joint_names)
    np.testing.assert_allclose(res.data.cop, want, atol=1e-15)
    assert res.reasons() == ["no_load=1 two_feet_no_force=1", "two_feet_no_force=1"]


def test_logged_cop_force_threshold_and_pads_on_the_other_foot(robot, config, tmp_path):
    """A CoP foot is loaded from fz ≥ min_foot_force; beside a pads foot both weigh by force."""
    rng = np.random.default_rng(9)
    fr, cr, zr = _pads_and_cop(rng, 6, RIGHT)
    fl, cl, zl = _pads_and_cop(rng, 6, LEFT)
    zr[0], cr[0] = 1.0, [0.02, 0.0]  # below 1.972 N: not loaded, even with a CoP
    zr[1], cr[1] = 0.5, np.nan  # too little force and no CoP: merely unloaded, not missing
    extra = cop_cols("r", cr, zr)
    mixed = run(
        robot, config, log_file(tmp_path / "m.csv", robot, [0] * 6, {"l_fsr": fl}, extra=extra)
    )
    fr[[0, 1]] = 100.0  # 0.4 N: the right foot lifted in both
    both = run(
        robot, config, log_file(tmp_path / "p.csv", robot, [0] * 6, {"r_fsr": fr, "l_fsr": fl})
    )
    assert mixed.mode == "forces" and mixed.reasons() == both.reasons()
    assert mixed.n_used.tolist() == both.n_used.tolist() and "missing" not in mixed.reasons()[0]
    np.testing.assert_allclose(mixed.data.cop, both.data.cop, atol=1e-15)
    np.testing.assert_allclose(mixed.force, both.force, rtol=1e-12)


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        ({"r_cop_x": [0.0, 0.0]}, "missing column 'r_cop_y' .right foot CoP."),
        ({"r_fz": [1.0, 1.0]}, "column 'r_fz' without 'r_cop_x', 'r_cop_y'"),
        ({"r_cop_x": [0.0, 30.0], "r_cop_y": [0.0, 0.0]}, "row 3, column 'r_cop_x'.*in metres"),
        (
            {"r_cop_x": [0.0, 0.0], "r_cop_y": [0.0, 0.0], "r_fsr1": [1.0, 1.0]},
            "right foot logs both a CoP .'r_cop_x'. and its sensor board .'r_fsr1'.",
        ),
    ],
)
def test_malformed_cop_columns(robot, config, tmp_path, extra, message):
    """Half a CoP, a force without CoP, millimetres, or two sources for a foot: one line each."""
    extra = {k: np.asarray(v, dtype=float) for k, v in extra.items()}
    with pytest.raises(SescidError, match=message) as exc:
        run(robot, config, log_file(tmp_path / "r.csv", robot, [0, 0], {}, extra=extra))
    assert "\n" not in str(exc.value)


def test_cop_prefix_default_and_configured(robot, tmp_path):
    """cop_columns defaults to the board prefix without _fsr and can be set in the JSON."""
    from sescid.sensors.pads import Foot

    assert Foot("right", "r_sole", "r_fsr", RIGHT).cop_prefix == "r"
    assert Foot("right", "r_sole", "rfoot", RIGHT).cop_prefix == "rfoot"
    p = tmp_path / "s.json"
    p.write_text(
        '{"format": "sescid-fsr/1", "feet": {"right": {"sole_frame": "r_sole", '
        f'"columns": "r_fsr", "cop_columns": "ft_r", "sensors_m": {RIGHT.tolist()}}}}}}}'
    )
    cfg = load_sensors(p)
    cop = np.array([[0.01, -0.005]] * 3)
    res = run(
        robot,
        cfg,
        log_file(
            tmp_path / "r.csv", robot, [0] * 3, {}, extra=cop_cols("ft_r", cop, np.full(3, 20.0))
        ),
    )
    np.testing.assert_allclose(res.data.cop[0], cop[0], atol=1e-15)
    p.write_text(p.read_text().replace('"ft_r"', "3"))
    with pytest.raises(SescidError, match="cop_columns: expected a column prefix"):
        load_sensors(p)
