"""Physics bench under tilted gravity: welded statics, pad CoP vs flat/gravity-aware statics,
identification with and without grav_x/y/z (LS and MAP), CoM-height error, z-row prior share.

Run: PYTHONPATH=src python benchmarks/bench_mujoco_gravity.py
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

import sescid
from sescid import identify
from sescid.bench import ExperimentConfig, real_robot
from sescid.bench.mujoco import MujocoBenchConfig, run_mujoco_experiment
from sescid.planning import candidates
from sescid.sensors import load_sensors, measure, read_raw
from sescid.tables import Table


def rms(e: np.ndarray) -> float:
    return float(np.sqrt(np.mean(e**2)))


def main(n: int = 60) -> None:
    robot = sescid.load_robot("op2")
    sensors = load_sensors(None, robot.profile)
    q = candidates(robot, n, seed=1).q
    r_true = real_robot(robot, ExperimentConfig())[0]
    weld = MujocoBenchConfig(weld_foot=True, min_settle=0.05, still_time=0.01, vel_tol=10.0)
    w = run_mujoco_experiment(robot, q[:20], sensors, samples=5, bench=weld).truth
    err = np.abs(w.physics.cop_ft - robot.cop(w.q_actual, r_true)).max()
    print(f"welded: F/T CoP − statics max {err:.1e} m")

    ex = run_mujoco_experiment(robot, q, sensors, samples=20, seed=0, bench=MujocoBenchConfig())
    t = ex.truth
    pads, flat, grav = t.physics.cop_pads, t.cop_true, t.physics.cop_gravity
    df, dg = np.linalg.norm(pads - flat, axis=1), np.linalg.norm(pads - grav, axis=1)
    print(
        f"free ({len(pads)}/{n} stand): pads − flat statics RMS {rms(df) * 1e3:.3f} mm "
        f"(max {df.max() * 1e3:.3f}); pads − gravity-aware RMS {rms(dg) * 1e6:.2f} µm "
        f"(max {dg.max() * 1e6:.2f}); tilt max {max(t.physics.foot_tilt) * 1e3:.1f} mrad"
    )
    cols = {k: np.asarray(v, dtype=float) for k, v in ex.columns.items() if k != "pose"}
    table = Table(Path("raw"), cols, {"pose": [str(p) for p in ex.columns["pose"]]})
    log = read_raw(table, robot.joint_names, sensors, robot.profile.servo)
    res = measure(robot, log, sensors, 5)
    keep = [t.pose.index(p) for p in res.pose]
    qa, g, pads = t.q_actual[keep], t.grav[keep], pads[keep]
    com_true = robot.com(qa, r_true)
    d = res.data
    for method in ("ls", "map"):
        for label, gg in (("flat", None), ("gravity", d.gravity)):
            f = identify(robot, d.q, d.cop, sigma=d.cop_se, gravity=gg, method=method)
            e = np.linalg.norm(f.predict_cop(qa, g) - pads, axis=1)
            ez = f.predict_com(qa)[:, 2] - com_true[:, 2]
            sv = f.singular_values
            print(
                f"{method} {label}: rank {f.rank} (sv43/sv1 {sv[42] / sv[0]:.1e}), CoP vs pad "
                f"truth RMS {rms(e) * 1e3:.3f} mm, CoM z RMS error {rms(ez) * 1e3:.1f} mm, "
                f"z from prior {np.mean(f.com_z_prior_fraction(qa)):.3f}"
            )


if __name__ == "__main__":
    main()
