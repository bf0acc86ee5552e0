"""Plan the OP2 bench poses: D-optimal vs random, expected CoP error vs K, and the figure.

Usage: ``python examples/op2_pose_selection.py [out_dir]`` (writes ``pose_selection.png`` and
``poses.csv`` there; default ``pose_selection_out``). About 20 s.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

import sescid
from sescid import planning as design
from sescid.report import design_figure
from sescid.tables import write_table


def main(out_dir: Path, n_candidates: int = 20_000) -> None:
    out_dir.mkdir(parents=True, exist_ok=True)
    robot = sescid.load_robot("op2")
    plan = design.plan_poses(robot, count=38, select="d-optimal", seed=0, n_candidates=n_candidates)
    cand = plan.candidates
    print(f"candidates: {cand.summary()}")
    print(f"identifiable subspace p = {plan.rank}; CoP noise σ = {plan.sigma * 1e3:g} mm")

    ks = [k for k in (21, 25, 30, 38, 50, 60, 70, 85, 100, 150, 200) if k <= n_candidates]
    curve = design.design_curve(plan, ks, seed=0)
    print(" K   D-optimal   random (median)   [expected noise-free CoP error, mm]")
    for k, d, r in zip(curve["k"], curve["d_optimal"], curve["random_median"], strict=True):
        print(f"{k:3d}   {d * 1e3:8.2f}   {r * 1e3:8.2f}")
    target = curve["d_optimal"][ks.index(38)]
    match = curve["k"][np.argmax(curve["random_median"] <= target)]
    print(f"random poses need K ≈ {match} to match 38 D-optimal ones ({target * 1e3:.2f} mm)")
    print(f"ordering: joint-space path {plan.path_unordered:.1f} rad → {plan.path_ordered:.1f} rad")
    design_figure(curve, out_dir / "pose_selection.png", title="OP2: pose selection")

    pc = design.paper_convention(robot)
    cols = {"pose": np.arange(len(plan.q))}
    cols |= {j: plan.q[:, k] for k, j in enumerate(robot.joint_names)}
    qp = np.degrees(pc.to_paper(plan.q))
    cols |= {f"{j}_paper_deg": qp[:, k] for k, j in enumerate(robot.joint_names)}
    write_table(out_dir / "poses.csv", cols)
    print(f"wrote {out_dir / 'pose_selection.png'} and {out_dir / 'poses.csv'}")


if __name__ == "__main__":
    main(
        Path(sys.argv[1] if len(sys.argv) > 1 else "pose_selection_out"),
        int(sys.argv[2]) if len(sys.argv) > 2 else 20_000,
    )
