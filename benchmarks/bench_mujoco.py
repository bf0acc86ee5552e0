"""Physics bench figures on the OP2: statics errors, foot tilt, servo sag, servo torques
against rigid statics, time per pose.

Run: PYTHONPATH=src python benchmarks/bench_mujoco.py [n_poses]
"""

from __future__ import annotations

import sys
import time
from collections import Counter

import numpy as np

import sescid
from sescid.bench import ExperimentConfig, TorqueConfig, holding_torques, real_bodies
from sescid.bench.mujoco import MujocoBenchConfig, run_mujoco_experiment
from sescid.planning import candidates
from sescid.robots.profile import mx28_kp
from sescid.sensors import load_sensors

#: ideal torque sensors on every joint: the truth then holds the servos' torques at rest
CONFIG = ExperimentConfig(torque=TorqueConfig("all", noise=0.0, offset=0.0))


def summary(robot, label: str, ex, wall: float) -> None:
    t = ex.truth
    ph = t.physics
    n = len(t.pose)
    why = Counter(w.split(":")[0] if "toppled" in w else w.split(" (")[0] for _, w in ex.skipped)
    print(f"{label}: {n} measured, skipped {dict(why)}, {wall / (n + len(ex.skipped)):.2f} s/pose")
    pads, flat, grav = ph.cop_pads, t.cop_true, ph.cop_gravity
    d_flat = np.linalg.norm(pads - flat, axis=1)
    d_grav = np.linalg.norm(pads - grav, axis=1)
    sag = np.abs(ph.servo_sag)
    print(
        f"  pads − flat statics: RMS {np.sqrt(np.mean(d_flat**2)) * 1e3:.3f} mm, "
        f"max {d_flat.max() * 1e3:.3f} mm; pads − gravity-aware: RMS "
        f"{np.sqrt(np.mean(d_grav**2)) * 1e6:.2f} µm, max {d_grav.max() * 1e6:.2f} µm"
    )
    print(
        f"  foot tilt {np.min(ph.foot_tilt) * 1e3:.2f}–{np.max(ph.foot_tilt) * 1e3:.2f} mrad;"
        f" servo sag max {sag.max():.4f} rad, RMS {np.sqrt(np.mean(sag**2)):.4f} rad; "
        f"settle {np.mean(ph.settle_s):.2f} s sim (max {np.max(ph.settle_s):.2f})"
    )
    bodies, _ = real_bodies(robot, CONFIG)
    statics = holding_torques(robot, t.q_actual, bodies, t.grav)
    d_tau = np.abs(t.torque.tau - statics)
    print(
        f"  servo torques − rigid statics (foot held, its gravity): max {d_tau.max():.1e} N·m, "
        f"RMS {np.sqrt(np.mean(d_tau**2)):.1e} N·m (largest torque {np.abs(statics).max():.2f})"
    )
    if ph.cop_ft is not None:
        err = np.abs(ph.cop_ft - flat).max()
        print(f"  welded: F/T CoP − statics max {err:.1e} m")


def main(n: int = 40) -> None:
    robot = sescid.load_robot("op2")
    sensors = load_sensors(None, robot.profile)
    q = candidates(robot, n, seed=0).q
    for label, bench in (
        ("welded, profile gains", MujocoBenchConfig(weld_foot=True, vel_tol=1e-3)),
        ("free, profile gains (kp 320)", MujocoBenchConfig()),
        ("free, kp 150", MujocoBenchConfig(kp=150.0)),
        ("free, MX-28 P=254", MujocoBenchConfig(kp=mx28_kp(254))),
        ("free, MX-28 P=32", MujocoBenchConfig(kp=mx28_kp(32))),
    ):
        t0 = time.perf_counter()
        try:
            ex = run_mujoco_experiment(robot, q, sensors, 100, 0, CONFIG, bench)
        except sescid.SescidError as exc:
            print(f"{label}: {exc}")
            continue
        summary(robot, label, ex, time.perf_counter() - t0)


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 40)
