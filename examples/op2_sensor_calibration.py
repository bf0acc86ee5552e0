"""Foot-pad gains/offsets calibrated with the masses on the virtual bench, against its truth.

Right- and left-foot sessions of D-optimal poses, 5 % gain and 0.1 N offset errors per pad;
prints per seed the held-out CoP error of the joint fit and of the same fit with the true
sensor values, then the share of gains and offsets within 2σ of the truth.

    python examples/op2_sensor_calibration.py --seeds 6
"""

from __future__ import annotations

import argparse
import math

import numpy as np

import sescid
from sescid.bench import ExperimentConfig, real_robot, run_experiment
from sescid.sensors import (
    KnownSensors,
    calibrate_sensors,
    load_sensors,
    pad_session,
    table_from_columns,
)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=6)
    ap.add_argument("--poses", type=int, default=38)
    ap.add_argument("--candidates", type=int, default=4000)
    ap.add_argument("--offset-prior", type=float, default=0.1, help="N")
    args = ap.parse_args()
    right = sescid.load_robot("op2")
    left = sescid.load_robot("op2", support="l_sole")
    cfg = load_sensors(profile=right.profile)
    kw = {"n_candidates": args.candidates, "n_test": 200, "random_draws": 2}
    q_r = sescid.plan_poses(right, count=args.poses, seed=0, **kw).q
    q_l = sescid.plan_poses(left, count=args.poses, seed=1, **kw).q
    bench = ExperimentConfig(fsr_gain=0.05, fsr_bias=0.1)
    r_true, mass, _ = real_robot(right, bench)
    hold = sescid.plan_poses(right, count=200, select="random", seed=7, **kw).q
    cop_true = right.cop(hold, r_true)
    cad = math.sqrt(np.mean((right.cop(hold) - cop_true) ** 2))
    zg, zo, ratio = [], [], []
    for seed in range(args.seeds):
        sessions, truth = [], {}
        for foot, robot, q in (("right", right, q_r), ("left", left, q_l)):
            ex = run_experiment(robot, q, cfg, samples=100, seed=seed, config=bench)
            sessions.append(pad_session(right, table_from_columns(ex.columns), cfg, foot))
            truth[foot] = ex.truth
        cal = calibrate_sensors(right, sessions, total_mass=mass, offset_prior=args.offset_prior)
        gains = truth["right"].pad_gain
        for foot in ("right", "left"):
            v, s = cal.gain("default", foot)
            zg += list((v - np.array(gains[foot])) / s)
            v, s = cal.offset(foot, foot)
            zo += list((v - np.array(truth[foot].pad_bias[foot])) / s)
        known = KnownSensors(
            gains={("default", f): np.array(g) for f, g in gains.items()},
            offsets={(f, f): np.array(truth[f].pad_bias[f]) for f in ("right", "left")},
        )
        ideal = calibrate_sensors(right, sessions, total_mass=mass, known=known)
        e1, e0 = (
            math.sqrt(np.mean((c.fit.predict_cop(hold) - cop_true) ** 2)) for c in (cal, ideal)
        )
        ratio.append(e1 / e0)
        gstd = np.mean([p.std for p in cal.gains])
        ostd = np.mean([p.std for p in cal.offsets])
        print(
            f"seed {seed}: held-out CoP RMS joint {e1 * 1e3:.3f} mm, known sensors "
            f"{e0 * 1e3:.3f} mm, CAD {cad * 1e3:.3f} mm; mean σ gain {100 * gstd:.2f} %, "
            f"offset {ostd:.3f} N"
        )
    zg, zo = np.abs(zg), np.abs(zo)
    print(f"gains within 2σ of the truth: {100 * np.mean(zg < 2):.1f} % of {zg.size}")
    print(f"offsets within 2σ of the truth: {100 * np.mean(zo < 2):.1f} % of {zo.size}")
    print(f"held-out CoP error joint / known sensors: mean {np.mean(ratio):.3f}, "
          f"max {np.max(ratio):.3f}")  # fmt: skip


if __name__ == "__main__":
    main()
