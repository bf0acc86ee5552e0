"""Torque noise per joint against one shared noise level, on the bench: issue 36's figures.

    python tools/torque_noise_study.py [--robots op2 romeo] [--seeds 10] [--folder DIR]
                                       [--models joint shared]

For each robot and seed, through the ``sescid`` command line (kept in ``--folder``, reused when
present): plan poses for the torques (``poses --kinds tau``), stand the bench's "real" robot
(the model plus unmodelled masses, ±1° joint play, torque noise 0.05 N·m per sample, random
per-joint offsets, no friction) in them with a torque sensor on every joint, reduce the log
(``measure``); then fit the torques in process with each noise model (``tau_noise_model``, the
default method, the weighed mass) and print, per robot, the mean over seeds of: the CoM error
against the truth on 2000 fresh poses (``compare_truth``: xy RMS, ±5° of the actual poses,
mm), the CAD model's, the share of draws worse than CAD, the number of joints whose residual RMS
(report's rule: each model net of its own best sensor terms) exceeds CAD's by over 10 %, and
the torque kind's σ̂ (a scale ≈ 1 for per-joint noise), and how many fits warn of a negative
friction band (the bench's friction is 0), with the former 2σ rule's count beside it. A model
"joint-weighted" / "shared-weighted" also weighs the rows by measure's tau_se (``--weighted``).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

import numpy as np

import sescid
from sescid.bench import compare_truth, load_truth
from sescid.estimation import IdentifyOptions
from sescid.estimation.data.measurements import concatenate
from sescid.io.measurements import read_measurements
from sescid.report.numbers import CAD, IDENTIFIED, torque_numbers

SESCID = str(Path(sys.executable).with_name("sescid"))
#: robot → (model, support, poses)
ROBOTS = {
    "op2": ("op2", "r_sole", 38),
    "romeo": ("romeo_description/urdf/romeo.urdf", "r_sole", 60),
}


def _model(name: str) -> str:
    if name == "op2":
        return "op2"
    import importlib.metadata

    dist = importlib.metadata.distribution("example-robot-data")
    return str(dist.locate_file(f"cmeel.prefix/share/example-robot-data/robots/{name}"))


def run(*args: str, cwd: Path) -> None:
    """One ``sescid`` command; its error output on failure."""
    res = subprocess.run([SESCID, *args], cwd=cwd, capture_output=True, text=True, check=False)
    if res.returncode != 0:
        raise SystemExit(f"sescid {' '.join(args)}\n{res.stdout}\n{res.stderr}")


def bench(folder: Path, robot: str, seed: int) -> Path:
    """poses → experiment → measure in folder/robot/seed (skipped when done)."""
    model, support, count = ROBOTS[robot]
    where = folder / robot / str(seed)
    if (where / "measured.csv").exists():
        return where
    where.mkdir(parents=True, exist_ok=True)
    r = ["--robot", _model(model), "--support", support]
    run("poses", *r, "--kinds", "tau", "--count", str(count), "--seed", str(seed),
        "--out", "poses.csv", cwd=where)  # fmt: skip
    run("experiment", *r, "--poses", "poses.csv", "--torques", "all", "--samples", "20",
        "--seed", str(seed), "--out", "raw.csv", "--truth", "truth.json", cwd=where)  # fmt: skip
    run("measure", "raw.csv", *r, "--poses", "poses.csv", "--out", "measured.csv", cwd=where)
    return where


def one(where: Path, robot: str, noise_model: str) -> dict:
    """The figures of one fit."""
    model, support, _ = ROBOTS[robot]
    rob = sescid.load_robot(_model(model), support=support)
    truth = load_truth(where / "truth.json")
    m = concatenate(list(read_measurements(where / "measured.csv", rob))).checked(rob)
    model, _, weighted = noise_model.partition("-")
    opts = IdentifyOptions(kinds=("tau",), total_mass=truth.true_mass,
                           tau_noise_model=model, weighted=weighted == "weighted")  # fmt: skip
    fit = sescid.identify(rob, m, options=opts)
    c = compare_truth(fit, where / "truth.json", seed=0)
    k = torque_numbers(fit, m)
    assert k is not None
    fit_rms = np.array([s.rms for s in k.stats[IDENTIFIED][:-1]])
    cad_rms = np.array([s.rms for s in k.stats[CAD][:-1]])
    tau = fit.kind("tau")
    return {
        "com": c.fresh_identified * 1e3,
        "cad": c.fresh_manufacturer * 1e3,
        "worse_joints": int(np.sum(fit_rms > 1.1 * cad_rms)),
        "joints": len(fit_rms),
        "sigma": tau.sigma if tau is not None else float("nan"),
        "friction_warning": any(w.startswith("negative static-friction") for w in fit.warnings),
        "friction_2sigma": any(
            e.what == "friction" and e.determined and e.value < -2 * e.std for e in fit.nuisance
        ),
    }


def main() -> None:
    """Run the study and print the table."""
    ap = argparse.ArgumentParser()
    ap.add_argument("--robots", nargs="+", default=list(ROBOTS))
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--folder", type=Path, default=Path("/tmp/torque_noise_study"))
    ap.add_argument("--models", nargs="*", default=["joint", "shared"])
    args = ap.parse_args()
    print("| robot | noise model | CoM error mm | CAD mm | draws worse than CAD | "
          "joints worse than CAD (>10 %) | σ̂ | friction warning (2σ rule) |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|")
    for robot in args.robots:
        rows: dict[str, list[dict]] = {nm: [] for nm in args.models}
        for seed in range(args.seeds):
            where = bench(args.folder, robot, seed)
            for nm in args.models:
                rows[nm].append(one(where, robot, nm))
                print(json.dumps({"robot": robot, "seed": seed, "model": nm, **rows[nm][-1]}),
                      file=sys.stderr)  # fmt: skip
        for nm, rs in rows.items():
            if not rs:
                continue
            com = np.array([r["com"] for r in rs])
            cad = np.array([r["cad"] for r in rs])
            worse = np.array([r["worse_joints"] for r in rs])
            print(
                f"| {robot} | {nm} | {com.mean():.3f} | {cad.mean():.3f} | "
                f"{int(np.sum(com > cad))}/{len(rs)} | {worse.mean():.1f} of {rs[0]['joints']} | "
                f"{np.mean([r['sigma'] for r in rs]):.3g} | "
                f"{sum(r['friction_warning'] for r in rs)}/{len(rs)} "
                f"({sum(r['friction_2sigma'] for r in rs)}/{len(rs)}) |"
            )


if __name__ == "__main__":
    main()
