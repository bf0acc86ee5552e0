"""Joint torques on the physics bench: the figures of issue 20's "Done means", measured.

    python tools/torque_study.py [--engine mujoco|kinematic] [--samples 20] [--seeds 3]
                                 [--plan cop|tau|both]

For each seed, through the ``sescid`` command line in a temporary folder: plan 38 single-support
poses (``poses --kinds PLAN``: D-optimal for the CoP, the torques or both), stand the "real" robot (the model plus unmodelled masses, joint play, sensor
errors) in them on the bench with joint torque sensors on every joint (noise 0.05 N·m per sample,
random per-joint offsets) and the foot pads (``experiment``), reduce the log (``measure``), then
fit from the file and compare each fit's CoM with the real robot's on 2000 fresh poses (rigid
statics of the truth file's SESC vectors; xy RMS):

- torques (least squares, offsets estimated) against an independent least squares of the same
  rows (numpy ``lstsq`` on the dense torque regressor with offset columns): ratio ≤ 1.5;
- torques with the CAD prior (MAP) against a CoP-only MAP fit of the same poses: ratio ≤ 0.4;
- a friction band f_j ~ U(0.1, 0.3) N·m with one random approach side per pose: the fit that
  estimates the band, against a reference that ignores it and one that knows it;
- the torso held in a fixture (``--mount gantry``), torques alone, MAP: against the CAD model;
- ranks: torques alone, CoP alone, both pooled.
Prints one Markdown table per figure with the mean over seeds.
"""

from __future__ import annotations

import argparse
import csv
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

import sescid
from sescid import identify
from sescid.bench import load_truth
from sescid.estimation import MapOptions, Measurements
from sescid.estimation.data.measurements import concatenate
from sescid.io.measurements import read_measurements

SESCID = str(Path(sys.executable).with_name("sescid"))


def run(*args: str, cwd: Path) -> None:
    """One ``sescid`` command; its error output on failure."""
    res = subprocess.run([SESCID, *args], cwd=cwd, capture_output=True, text=True, check=False)
    if res.returncode != 0:
        raise SystemExit(f"sescid {' '.join(args)}\n{res.stdout}\n{res.stderr}")


def com_error(robot, r, r_true, q) -> float:
    """xy RMS of the CoM of r against the truth's at poses q, m."""
    d = robot.com(q, r)[:, :2] - robot.com(q, r_true)[:, :2]
    return float(np.sqrt(np.mean(np.sum(d**2, axis=1))))


def lstsq_reference(robot, m: Measurements, mass: float, friction: bool) -> np.ndarray:
    """An independent least squares of the torque rows: numpy lstsq on the dense regressor with
    an offset column per joint (and a friction column when asked), the CAD model filling the
    null space; returns r (N, 3)."""
    n, nj = m.tau.shape
    phi = robot.torque_regressor(m.q, m.tau_joints, m.gravity) * mass
    nx = phi.shape[2]
    cols = nx + nj * (2 if friction else 1)
    a = np.zeros((n * nj, cols))
    for j in range(nj):
        a[j * n : (j + 1) * n, :nx] = phi[:, j]
        a[j * n : (j + 1) * n, nx + j] = 1.0
        if friction:
            a[j * n : (j + 1) * n, nx + nj + j] = m.approach
    x0 = robot.sesc_vectors().reshape(-1)
    dx = np.linalg.lstsq(a, m.tau.T.reshape(-1) - a[:, :nx] @ x0, rcond=1e-10)[0]
    return (x0 + dx[:nx]).reshape(-1, 3)


def bench(folder: Path, seed: int, args, extra: list[str], support: str | None = None):
    """poses → experiment → measure; the measured data and the truth."""
    robot_args = ["--robot", "op2"] + (["--support", support] if support else [])
    if support is None:
        run("poses", *robot_args, "--count", "38", "--select", "d-optimal", "--seed", str(seed),
            "--kinds", args.plan, "--out", "poses.csv", "--force", cwd=folder)  # fmt: skip
    run("experiment", *robot_args, "--poses", "poses.csv", "--samples", str(args.samples),
        "--seed", str(seed), "--engine", args.engine, "--torques", "all", "--torque-noise", "0.05",
        "--torque-offset", "0.05", *extra, "--out", "raw.csv", "--truth", "truth.json",
        "--force", cwd=folder)  # fmt: skip
    run("measure", "raw.csv", *robot_args, "--poses", "poses.csv", "--out", "measured.csv",
        "--force", cwd=folder)  # fmt: skip
    robot = sescid.load_robot("op2", support=support)
    data = concatenate(list(read_measurements(folder / "measured.csv", robot,
                                              allow_outside_limits=True)))  # fmt: skip
    return robot, data, load_truth(folder / "truth.json")


def gantry_poses(folder: Path, robot, seed: int) -> None:
    """38 random poses within the joint limits (±45° at most): no balance on a gantry."""
    rng = np.random.default_rng(seed)
    lim = np.clip(robot.joint_limits, -np.pi / 4, np.pi / 4)
    q = rng.uniform(lim[:, 0], lim[:, 1], (38, robot.nq))
    with (folder / "poses.csv").open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["pose", *robot.joint_names])
        for i, row in enumerate(q):
            w.writerow([i, *map(repr, row.tolist())])


def one_seed(seed: int, args) -> dict[str, float]:
    out: dict[str, float] = {}
    with tempfile.TemporaryDirectory(prefix="sescid-torque-") as tmp:
        folder = Path(tmp)
        robot, data, truth = bench(folder, seed, args, [])
        mass, r_true = truth.true_mass, truth.r_true
        fresh = sescid.simulate(robot, 2000, 30, 0.0, 1000 + seed).q
        tau = data.without("cop")
        cop = data.without("tau")
        opts = {"total_mass": mass, "robust": False, "tau_noise_model": args.tau_noise_model}
        ls = identify(robot, tau, method="ls", **opts)
        out["torques, least squares"] = com_error(robot, ls.r, r_true, fresh)
        ref = lstsq_reference(robot, tau, mass, friction=False)
        out["independent lstsq, same rows"] = com_error(robot, ref, r_true, fresh)
        tmap = identify(robot, tau, method=MapOptions(prior="sesc"), **opts)
        out["torques, MAP"] = com_error(robot, tmap.r, r_true, fresh)
        body = identify(robot, tau, method=MapOptions(prior="bodies"), **opts)
        out["torques, MAP (per-body prior)"] = com_error(robot, body.r, r_true, fresh)
        cmap = identify(robot, cop, method="map")
        out["CoP only, MAP"] = com_error(robot, cmap.r, r_true, fresh)
        cbody = identify(robot, cop, method=MapOptions(prior="bodies"))
        out["CoP only, MAP (per-body prior)"] = com_error(robot, cbody.r, r_true, fresh)
        both = identify(robot, data, method="map", **opts)
        out["CoP + torques, MAP"] = com_error(robot, both.r, r_true, fresh)
        out["CAD model"] = com_error(robot, robot.sesc_vectors(), r_true, fresh)
        out["rank: torques"] = ls.rank
        out["rank: CoP"] = identify(robot, cop, method="ls", allow_exact=True).rank
        out["poses measured"] = data.n
        out["rank: pooled"] = identify(robot, data, method="ls", **opts).rank
        # friction band with one random approach side per pose
        robot, data, truth = bench(folder, seed, args, ["--friction", "0.1", "0.3"])
        tau = data.without("cop")
        tau = Measurements(q=tau.q, tau=tau.tau, tau_joints=tau.tau_joints, tau_se=tau.tau_se,
                           approach=data.approach, source=tau.source)  # fmt: skip
        band = identify(
            robot,
            tau,
            method="ls",
            total_mass=truth.true_mass,
            robust=False,
            tau_noise_model=args.tau_noise_model,
        )
        out["friction: estimated band"] = com_error(robot, band.r, truth.r_true, fresh)
        ref = lstsq_reference(robot, tau, truth.true_mass, friction=True)
        out["friction: reference lstsq with the band"] = com_error(robot, ref, truth.r_true, fresh)
        blind = Measurements(q=tau.q, tau=tau.tau, tau_joints=tau.tau_joints)
        ign = identify(
            robot,
            blind,
            method="ls",
            total_mass=truth.true_mass,
            robust=False,
            tau_noise_model=args.tau_noise_model,
        )
        out["friction: band ignored (LS)"] = com_error(robot, ign.r, truth.r_true, fresh)
        rob = identify(
            robot,
            blind,
            method="ls",
            total_mass=truth.true_mass,
            robust=True,
            tau_noise_model=args.tau_noise_model,
        )
        out["friction: band ignored (robust)"] = com_error(robot, rob.r, truth.r_true, fresh)
        est = {e.name: e.value for e in band.nuisance if e.what == "friction" and e.determined}
        true_f = dict(zip(truth.joint_names, truth.torque.friction, strict=True))
        out["friction: band error RMS [N·m]"] = float(np.sqrt(np.mean(
            [(est[j] - true_f[j]) ** 2 for j in est])))  # fmt: skip
        # gantry: the torso held
        torso = robot.model.model_root
        held = sescid.load_robot("op2", support=torso)
        gantry_poses(folder, held, seed)
        held, data, truth = bench(folder, seed, args, ["--mount", "gantry"], support=torso)
        gopts = {"total_mass": truth.true_mass, "robust": False,
                 "tau_noise_model": args.tau_noise_model}  # fmt: skip
        gfit = identify(held, data.without("cop"), method=MapOptions(prior="sesc"), **gopts)
        gbody = identify(held, data.without("cop"), method=MapOptions(prior="bodies"), **gopts)
        rng = np.random.default_rng(2000 + seed)
        lim = np.clip(held.joint_limits, -np.pi / 4, np.pi / 4)
        qg = rng.uniform(lim[:, 0], lim[:, 1], (1000, held.nq))
        out["gantry: MAP, torque RMS [N·m]"] = float(
            np.sqrt(
                np.mean(
                    (
                        gfit.predict_torque(qg)
                        - held.torques(qg, truth.r_true, total_mass=truth.true_mass)
                    )
                    ** 2
                )
            )
        )
        out["gantry: CAD, torque RMS [N·m]"] = float(
            np.sqrt(
                np.mean(
                    (held.torques(qg) - held.torques(qg, truth.r_true, total_mass=truth.true_mass))
                    ** 2
                )
            )
        )
        out["gantry: MAP, CoM"] = com_error(held, gfit.r, truth.r_true, qg)
        out["gantry: MAP (per-body prior), CoM"] = com_error(held, gbody.r, truth.r_true, qg)
        out["gantry: CAD, CoM"] = com_error(held, held.sesc_vectors(), truth.r_true, qg)
    return out  # fmt: skip


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--engine", default="mujoco", choices=["mujoco", "kinematic"])
    ap.add_argument("--samples", type=int, default=20)
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument(
        "--plan",
        default="cop",
        choices=["cop", "tau", "both"],
        help="the kinds the 38 standing poses are planned for (poses --kinds)",
    )
    ap.add_argument(
        "--tau-noise-model",
        default="joint",
        choices=["joint", "shared"],
        help="torque noise per joint (the default; least squares is then a weighted one, not "
        "the unweighted lstsq reference's) or one shared level",
    )
    args = ap.parse_args()
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    rows: dict[str, list[float]] = {}
    for seed in range(args.seeds):
        for k, v in one_seed(seed, args).items():
            rows.setdefault(k, []).append(v)
        print(f"seed {seed} done", file=sys.stderr, flush=True)
    print(
        f"engine {args.engine}, poses for {args.plan}, {args.seeds} seeds, 38 poses, "
        f"{args.samples} samples/pose, torque noise {args.tau_noise_model}\n"
    )
    print("| figure | mean | per seed |\n|---|---|---|")
    for k, v in rows.items():
        plain = "[" in k or "rank" in k or "poses" in k
        scale, unit = (1.0, "") if plain else (1e3, " mm")
        fmt = "{:.0f}" if ("rank" in k or "poses" in k) else "{:.3f}"
        vals = ", ".join(fmt.format(x * scale) for x in v)
        print(f"| {k} | {fmt.format(np.mean(v) * scale)}{unit} | {vals} |")
    ratio = np.mean(rows["torques, least squares"]) / np.mean(rows["independent lstsq, same rows"])
    print(f"\ntorques LS / independent lstsq: {ratio:.3f} (target ≤ 1.5)")
    r2 = np.mean(rows["torques, MAP"]) / np.mean(rows["CoP only, MAP"])
    print(f"torques MAP / CoP-only MAP, the SESC prior both: {r2:.3f} (target ≤ 0.4)")
    r3 = np.mean(rows["torques, MAP (per-body prior)"]) / np.mean(rows["CoP only, MAP"])
    r4 = np.mean(rows["torques, MAP (per-body prior)"]) / np.mean(
        rows["CoP only, MAP (per-body prior)"]
    )
    print(
        f"each with its default prior (torques: per-body, CoP: SESC): {r3:.3f} (target ≤ 0.4); "
        f"the per-body prior both: {r4:.3f}"
    )


if __name__ == "__main__":
    main()
