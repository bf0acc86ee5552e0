"""Is the default fit ever worse than the CAD model it replaces? Measured per case and draw.

    python tools/defaults_study.py [--draws 20] [--cases all|cop|tau] [--work DIR]
    python tools/defaults_study.py --write      # rewrites the tables in docs/defaults.md

Cases (each ``--draws`` random draws; every fit through ``sescid.identify``, the user's path):

- **CoP on the physics bench** (OP2): four "real" robots, each the model plus 3–10 % of its
  mass unmodelled on four random bodies at a few centimetres (``ExperimentConfig.extra``);
  each stands in 200 planned poses on the MuJoCo bench (servos on a compliant floor, the foot
  tilting, joint play), the log reduced by ``measure``; a draw takes 38 of those poses and adds
  the paper's CoP noise (4.93 mm). Error: RMS of the predicted CoP against the truth's (rigid
  statics, level) on 2000 fresh stable poses, mm.
- **Joint torques on a foot / on a gantry** (OP2, TALOS, Unitree G1 from example-robot-data):
  each draw a "real" robot (every body's mass ±10 %, its CoM ±5 mm per axis, and 5 % of the
  mass unmodelled on four of the eight heaviest bodies at ±2 cm), 40 random poses within the
  joint limits (±0.5 rad at most), every joint's torque with a random offset per joint and noise
  (both 0.05 N·m × M / 3 kg), the weighed mass given. Error: RMS of the whole-body CoM against
  the truth's on 2000 fresh poses (3-D, support frame), mm.

Beside the CAD model and the methods, the torque cases carry an **independent MAP reference**:
a dense numpy solve of the same rows over body masses and first moments (torque regressor ×
the map from body parameters to SESC vectors), the torque offsets free, the noise known, the
weighed total mass given (as ``identify`` is), and a Gaussian prior equal to the draws' own
distribution (mean and per-parameter variance of 2000
draws of the real-robot generator): the best a linear-Gaussian estimator can do here.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import zlib
from pathlib import Path

import numpy as np
from doc_blocks import spliced
from study_refs import (
    TORQUE_ROBOTS,
    body_parameters,
    model_path,
    real_bodies,
    reference_map,
    to_sesc,
)

import sescid
from sescid.estimation import Measurements

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "defaults.md"
METHODS = {"default": {}, "least squares": {"method": "ls"}, "MAP": {"method": "map"}}


# --- the torque cases ---------------------------------------------------------------------
def torque_case(name: str, mount: str, draws: int, rows: list) -> None:
    rel, sole, held = TORQUE_ROBOTS[name]
    robot = sescid.load_robot(model_path(rel), held if mount == "gantry" else sole)
    rng = np.random.default_rng(zlib.crc32(f"{name} {mount}".encode()))
    sigma = 0.05 * robot.total_mass / 3.0
    lim = np.clip(robot.joint_limits, -0.5, 0.5)
    fresh = rng.uniform(lim[:, 0], lim[:, 1], (2000, robot.nq))
    draws_theta = np.array([body_parameters(real_bodies(robot, rng)) for _ in range(2000)])
    mean, var = draws_theta.mean(axis=0), np.maximum(draws_theta.var(axis=0), 1e-12)
    errors: dict[str, list[float]] = {}
    for _ in range(draws):
        bodies = real_bodies(robot, rng)
        theta = body_parameters(bodies)
        r_true, mass = to_sesc(robot, theta), float(theta[: len(bodies)].sum())
        q = rng.uniform(lim[:, 0], lim[:, 1], (40, robot.nq))
        tau = robot.torques(q, r_true, total_mass=mass)
        tau = tau + rng.normal(0, sigma, robot.nq) + rng.normal(0, sigma, tau.shape)
        m = Measurements(q=q, tau=tau, tau_joints=tuple(robot.joint_names))

        def err(r, r_true=r_true):
            d = robot.com(fresh, r) - robot.com(fresh, r_true)
            return 1e3 * float(np.sqrt(np.mean(np.sum(d * d, axis=1))))

        fits = {"CAD model": robot.sesc_vectors()}
        for label, kw in METHODS.items():
            fits[label] = sescid.identify(robot, m, total_mass=mass, **kw).r
        fits["independent MAP reference"] = reference_map(robot, m, sigma, mean, var, mass)
        for label, r in fits.items():
            errors.setdefault(label, []).append(err(r))
    rows.append(
        (
            f"{name}, joint torques, {'on a gantry' if mount == 'gantry' else 'on a foot'}",
            "CoM",
            errors,
        )
    )


# --- the physics-bench CoP case -----------------------------------------------------------
def cop_case(draws: int, work: Path, rows: list) -> None:
    from click.testing import CliRunner

    from sescid.bench import ExperimentConfig, ExtraMass, load_truth, run_mujoco_experiment
    from sescid.cli import cli
    from sescid.estimation.data.measurements import concatenate
    from sescid.io.measurements import read_measurements
    from sescid.sensors import load_sensors
    from sescid.tables import read_poses, read_table, write_table

    robot = sescid.load_robot("op2")
    rng = np.random.default_rng(4930)
    pools = []
    for k, fraction in enumerate((0.03, 0.05, 0.07, 0.10)):
        folder = work / f"op2-cop-{k}"
        folder.mkdir(parents=True, exist_ok=True)
        names = rng.choice(robot.body_names, 4, replace=False)
        extra = tuple(
            ExtraMass(str(b), float(s), tuple(float(x) for x in o))
            for b, s, o in zip(
                names, rng.dirichlet(np.ones(4)), rng.normal(0, 0.03, (4, 3)), strict=True
            )
        )
        if not (folder / "m.csv").exists():
            here = os.getcwd()
            os.chdir(folder)
            try:
                res = CliRunner().invoke(
                    cli,
                    f"poses --robot op2 --count 200 --select random --seed {k} --out pool.csv".split(),
                )
                if res.exit_code != 0:
                    raise SystemExit(res.output)
                q = read_poses(read_table("pool.csv"), robot.joint_names)
                cfg = ExperimentConfig(extra_mass_fraction=fraction, extra=extra)
                ex = run_mujoco_experiment(robot, q, load_sensors(None, robot.profile), 100, k, cfg)
                write_table("raw.csv", ex.columns)
                ex.truth.save("truth.json")
                res = CliRunner().invoke(cli, "measure raw.csv --robot op2 --out m.csv".split())
                if res.exit_code != 0:
                    raise SystemExit(res.output)
            finally:
                os.chdir(here)
        data = concatenate(list(read_measurements(folder / "m.csv", robot)))
        pools.append((data, load_truth(folder / "truth.json").r_true))
    q = rng.uniform(-np.radians(30), np.radians(30), (60000, robot.nq))
    fresh = q[np.all(np.abs(robot.cop(q)) < 0.023, axis=1)][:2000]
    errors: dict[str, list[float]] = {}
    for d in range(draws):
        data, r_true = pools[d % len(pools)]
        take = data.take(np.sort(rng.choice(data.n, 38, replace=False)))
        m = Measurements(
            q=take.q, cop=take.cop + rng.normal(0, 0.00493, take.cop.shape), gravity=take.gravity
        )

        def err(r, r_true=r_true):
            e = robot.cop(fresh, r) - robot.cop(fresh, r_true)
            return 1e3 * float(np.sqrt(np.mean(np.sum(e * e, axis=1))))

        errors.setdefault("CAD model", []).append(err(robot.sesc_vectors()))
        for label, kw in METHODS.items():
            errors.setdefault(label, []).append(err(sescid.identify(robot, m, **kw).r))
    rows.append(("OP2, CoP on the physics bench (38 poses, 4.93 mm)", "CoP", errors))


# --- tables ---------------------------------------------------------------------------------
def table(rows: list) -> str:
    out = []
    for case, what, errors in rows:
        cad = np.array(errors["CAD model"])
        ref = errors.get("independent MAP reference")
        out += [f"**{case}** ({what} RMS error on fresh poses, mm; {len(cad)} draws)", "",
                "| model | mean | worst draw | draws no worse than CAD | mean / reference |",
                "|---|---|---|---|---|"]  # fmt: skip
        for label, v in errors.items():
            v = np.array(v)
            better = (
                "—" if label == "CAD model" else f"{int(np.sum(v <= cad * (1 + 1e-6)))} of {len(v)}"
            )
            ratio = "—" if ref is None else f"{v.mean() / np.mean(ref):.2f}"
            out.append(f"| {label} | {v.mean():.2f} | {v.max():.2f} | {better} | {ratio} |")
        out.append("")
    return "\n".join(out).rstrip()


START, END = "<!-- defaults-study: tools/defaults_study.py -->", "<!-- /defaults-study -->"


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("--draws", type=int, default=20)
    p.add_argument("--cases", choices=["all", "cop", "tau"], default="all")
    p.add_argument("--work", type=Path, default=None)
    p.add_argument("--write", action="store_true")
    args = p.parse_args()
    rows: list = []
    with tempfile.TemporaryDirectory(prefix="sescid-defaults-") as tmp:
        work = args.work or Path(tmp)
        if args.cases in ("all", "cop"):
            cop_case(args.draws, work, rows)
        if args.cases in ("all", "tau"):
            for name in TORQUE_ROBOTS:
                for mount in ("foot", "gantry"):
                    torque_case(name, mount, args.draws, rows)
                    print(table(rows[-1:]), flush=True)
    text = table(rows)
    if args.write:
        DOC.write_text(spliced(DOC.read_text(), START, END, text))
    print(text)
    sys.stdout.flush()


if __name__ == "__main__":
    main()
