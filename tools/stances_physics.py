"""Pooled stances on the MuJoCo physics bench: the OP2's joint torques from both feet against
one foot, a CoP-only fit of the same poses, an independent pooled reference and CAD, measured.

    python tools/stances_physics.py [--draws 10]

Each draw plans torque poses (``sescid poses --kinds tau``, each set checked standing on the
MuJoCo bench) on the right sole (two sets of 38: the 76-pose right-foot case) and on the left
sole (38), stands the real robot of ``sescid experiment`` (7 % unmodelled mass, ±1° play,
torque noise and a constant offset per joint, its foot pads; one bench seed per draw, so the
sensors keep their errors from stance to stance) in each in MuJoCo (20 samples a pose), reduces the logs with ``sescid measure`` and fits them with ``sescid.identify`` (the
default method, the weighed mass given). Poses that topple on the bench drop out. Error: RMS of
the whole-body CoM against the real robot's at 2000 fresh random poses (±0.5 rad), mm.

The independent reference is ``tools/stances_study.py``'s dense pooled MAP over the body
parameters and the offsets (prior: ``study_refs.real_bodies``' spread around CAD).
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
from study_refs import body_parameters, pooled_reference, real_bodies

import sescid
from sescid.bench import load_truth
from sescid.estimation import Measurements
from sescid.io.measurements import read_measurements

SAMPLES = 20  #: readings per pose
TAU_SIGMA = 0.05 / np.sqrt(SAMPLES)  #: N·m, a pose's mean torque (the bench's 0.05 per sample)


def sescid_cli(*args) -> None:
    exe = Path(sys.executable).with_name("sescid")
    res = subprocess.run([str(exe), *map(str, args)], capture_output=True, text=True)
    if res.returncode:
        raise SystemExit(f"sescid {' '.join(map(str, args))}: {res.stderr.strip()}")


def stance_data(
    robot,
    d: Path,
    support: str,
    seed: int,
    robot_seed: int,
    engine: str = "mujoco",
    backlash: float = 1.0,
) -> tuple[Measurements, float]:
    """38 torque poses planned on ``support`` (``seed``), stood in MuJoCo and measured; the true
    mass. ``robot_seed`` is the bench's: it draws the sensors' errors (the torque offsets, the
    pads' biases), which one robot keeps from stance to stance."""
    poses, log, out, truth = (
        d / f"{support}{seed}{x}" for x in (".csv", "log.csv", "m.csv", ".json")
    )
    sescid_cli("poses", "--kinds", "tau", "--support", support, "--count", 38, "--seed", seed,
               "--check", "mujoco", "--out", poses)  # fmt: skip
    sescid_cli("experiment", "--engine", engine, "--backlash-deg", backlash, "--support", support, "--poses", poses,
               "--torques", "all", "--samples", SAMPLES, "--seed", robot_seed, "--out", log,
               "--truth", truth)  # fmt: skip
    sescid_cli("measure", log, "--support", support, "--out", out)
    (m,) = list(read_measurements(out, robot, support=support, allow_outside_limits=True))
    return m, load_truth(truth).true_mass


def only(m: Measurements, kind: str) -> Measurements:
    if kind == "cop":
        return Measurements(q=m.q, cop=m.cop, cop_se=m.cop_se, gravity=m.gravity, support=m.support)
    return Measurements(q=m.q, tau=m.tau, tau_joints=m.tau_joints, tau_se=m.tau_se, gravity=m.gravity,
                        approach=m.approach, support=m.support)  # fmt: skip


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--draws", type=int, default=10)
    ap.add_argument("--engine", choices=("mujoco", "kinematic"), default="mujoco")
    ap.add_argument("--backlash-deg", type=float, default=1.0, help="the bench's joint play")
    args = ap.parse_args()
    robot = sescid.load_robot("op2")
    rng = np.random.default_rng(26)
    prior = np.array([body_parameters(real_bodies(robot, rng)) for _ in range(2000)])
    mean, var = prior.mean(axis=0), np.maximum(prior.var(axis=0), 1e-12)
    lim = np.clip(robot.joint_limits, -0.5, 0.5)
    fresh = rng.uniform(lim[:, 0], lim[:, 1], (2000, robot.nq))
    err: dict[str, list[float]] = {}
    ranks: dict[str, int] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for k in range(args.draws):
            d = Path(tmp)
            r1, mass = stance_data(robot, d, "r_sole", 1000 + k, k, args.engine, args.backlash_deg)
            r2, _ = stance_data(robot, d, "r_sole", 2000 + k, k, args.engine, args.backlash_deg)
            left, _ = stance_data(robot, d, "l_sole", 3000 + k, k, args.engine, args.backlash_deg)
            r_true = load_truth(d / f"r_sole{1000 + k}.json").r_true
            tau = [only(m, "tau") for m in (r1, r2, left)]
            fits = {
                "torques, right foot, 2 × 38 poses": sescid.identify(robot, tau[:2], total_mass=mass),
                "torques, both feet, 38 + 38": sescid.identify(robot, [tau[0], tau[2]], total_mass=mass),
                "CoP only, both feet, 38 + 38 (MAP)": sescid.identify(
                    robot, [only(r1, "cop"), only(left, "cop")], method="map"),
            }  # fmt: skip
            rs = {label: fit.r for label, fit in fits.items()}
            rs["independent pooled MAP, both feet"] = pooled_reference(
                robot, [tau[0], tau[2]], TAU_SIGMA, mean, var, mass
            )
            rs["CAD model"] = robot.sesc_vectors()
            for label, r in rs.items():
                dc = robot.com(fresh, r) - robot.com(fresh, r_true)
                err.setdefault(label, []).append(1e3 * float(np.sqrt(np.mean(np.sum(dc * dc, 1)))))
            for label, fit in fits.items():
                ranks[label] = fit.bodies.rank if fit.bodies is not None else fit.rank
            print(
                f"draw {k + 1}: " + ", ".join(f"{v[-1]:.2f}" for v in err.values()), file=sys.stderr
            )
    bench = "MuJoCo" if args.engine == "mujoco" else "kinematic"
    print(f"**OP2 on the {bench} bench** ({args.draws} draws; ranks of {4 * len(robot.body_names)} "
          "body parameters, or of the stance's 63 SESC components for one stance)\n")  # fmt: skip
    print("| data | combinations determined | CoM error, mean mm | worst draw |\n|---|---|---|---|")
    for label, v in err.items():
        print(f"| {label} | {ranks.get(label, '—')} | {np.mean(v):.2f} | {np.max(v):.2f} |")
    both = np.mean(err["torques, both feet, 38 + 38"])
    print(f"\nboth feet / right foot: {both / np.mean(err['torques, right foot, 2 × 38 poses']):.2f}; "
          f"/ CoP-only MAP: {both / np.mean(err['CoP only, both feet, 38 + 38 (MAP)']):.2f}; "
          f"/ independent reference: {both / np.mean(err['independent pooled MAP, both feet']):.2f}")  # fmt: skip


if __name__ == "__main__":
    main()
