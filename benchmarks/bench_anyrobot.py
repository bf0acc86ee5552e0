"""Benchmark: sescid on the public humanoids of example-robot-data (and the OP2 for reference).

Per robot: load time, rank of least squares and of the default method (``auto``, and the
method it chose) on 400 simulated poses, ``poses`` time (``plan_poses`` with 40 poses, or the
robot's minimum when that is more, and the CLI's default candidate count for its sampler) and
what its checks gave (lowest free-sole corner and lowest checked body above the floor over the
chosen poses), the sole used, and how closely the export of a MAP fit reproduces that fit's CoP
on 2000 fresh poses. Reference measured in the same run: the acceptance of plain uniform draws
on TALOS and the time they would take for the same number of candidates.
Usage: ``python benchmarks/bench_anyrobot.py [--robots talos icub g1 ...]``.
"""

from __future__ import annotations

import argparse
import importlib.metadata
import tempfile
import time
from pathlib import Path

import numpy as np

import sescid
from sescid.estimation import min_poses
from sescid.planning import CandidateOptions, candidates
from sescid.planning.feasibility.ground import lowest_heights

ROBOTS = {
    "op2": ("op2", None),
    "talos": ("talos_data/robots/talos_reduced.urdf", "right_sole_link"),
    "icub": ("icub_description/robots/icub.urdf", "r_sole"),
    "g1": ("g1_description/urdf/g1_29dof_rev_1_0.urdf", "right_ankle_roll_link"),
    "romeo": ("romeo_description/urdf/romeo.urdf", "r_sole"),
    "human": ("human_description/robots/human.urdf", "right_foot"),
}


def erd() -> Path:
    dist = importlib.metadata.distribution("example-robot-data")
    return Path(dist.locate_file("cmeel.prefix/share/example-robot-data/robots"))


def lowest(robot, q) -> tuple[float, float]:
    """(lowest free-sole corner, lowest checked body point) above the floor over poses q, m."""
    rot, org = robot.forward(q)
    free = robot.free_sole
    sole = np.nan
    if free is not None:
        c = org[:, None, free.body] + np.einsum("nij,cj->nci", rot[:, free.body], free.corners)
        sole = float(c[..., 2].min() - robot.floor)
    body = float(lowest_heights(robot, rot, org).min())
    return sole, body - robot.floor


def run(name: str, tmp: Path) -> dict:
    path, support = ROBOTS[name]
    t0 = time.perf_counter()
    robot = sescid.load_robot(path if name == "op2" else erd() / path, support)
    t_load = time.perf_counter() - t0
    sim = sescid.simulate(robot, 400, 20, 0.002, seed=0, clip=name != "op2")
    fit = sescid.identify(robot, sim.q, sim.cop, method="ls")
    auto = sescid.identify(robot, sim.q, sim.cop)
    n_cand = 20_000 if robot.profile.pose_sampler == "uniform" else 5_000
    t0 = time.perf_counter()
    plan = sescid.plan_poses(robot, count=max(40, min_poses(robot)), n_candidates=n_cand)
    t_poses = time.perf_counter() - t0
    sole_low, body_low = lowest(robot, plan.q)
    mfit = sescid.identify(robot, sim.q, sim.cop, method="map")
    out = tmp / f"{name}{robot.model_path.suffix}"
    sescid.export_model(sescid.to_consistent(mfit), out)
    exp = sescid.load_robot(out, robot.support)
    q = sescid.simulate(robot, 2000, 20, 0.0, seed=9, clip=name != "op2").q
    err = float(np.abs(exp.cop(q) - mfit.predict_cop(q)).max())
    s = robot.sole
    return {
        "robot": name,
        "load_s": t_load,
        "rank": fit.rank,
        "rank_auto": auto.rank,
        "auto_method": auto.method,
        "n_poses": len(plan.q),
        "poses_s": t_poses,
        "accept": plan.candidates.acceptance,
        "sole": "none"
        if s is None
        else f"{s.size[0]:.3f}x{s.size[1]:.3f} ({'derived' if s.derived else 'profile'})",
        "free_sole_mm": sole_low * 1e3,
        "body_mm": body_low * 1e3,
        "export_um": err * 1e6,
    }


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--robots", nargs="*", default=list(ROBOTS))
    args = ap.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as d:
        for name in args.robots:
            try:
                rows.append(run(name, Path(d)))
            except sescid.SescidError as exc:  # a robot sescid refuses: say why, go on
                print(f"{name:6s} refused: {exc}", flush=True)
                continue
            r = rows[-1]
            print(
                f"{r['robot']:6s} load {r['load_s']:.2f} s  rank ls {r['rank']}, auto "
                f"{r['rank_auto']} ({r['auto_method']})  poses({r['n_poses']}) "
                f"{r['poses_s']:.1f} s (acceptance {r['accept']:.1%})  sole {r['sole']}  "
                f"free sole ≥ {r['free_sole_mm']:.1f} mm, bodies ≥ {r['body_mm']:.1f} mm above "
                f"floor  export vs fit CoP {r['export_um']:.3f} µm",
                flush=True,
            )
    # reference: plain uniform draws on TALOS, same run
    talos = sescid.load_robot(erd() / ROBOTS["talos"][0], ROBOTS["talos"][1])
    t0 = time.perf_counter()
    try:
        uniform = CandidateOptions(sampler="uniform", max_sampled=2_000_000, chunk=50_000)
        c = candidates(talos, 20, 0, uniform)
        rate, n = c.acceptance, c.n_sampled
    except sescid.SescidError:
        rate, n = 0.0, 2_000_000
    dt = time.perf_counter() - t0
    need = 7_000 / rate * dt / n if rate > 0 else float("inf")
    print(
        f"reference: uniform draws on TALOS: acceptance {rate:.2e} over {n} draws ({dt:.1f} s); "
        f"7000 candidates would take ≈ {need:.0f} s"
    )


if __name__ == "__main__":
    main()
