"""What pooling stances buys: ranks and accuracy, one stance against several, measured.

    python tools/stances_study.py [--draws 40]           # prints the tables
    python tools/stances_study.py --write                # rewrites them in docs/stances.md

Each draw takes a "real" robot (``study_refs.real_bodies``: masses ±10 %, CoMs ±5 mm,
5 % of the mass unmodelled on heavy bodies), its body parameters θ shared by every stance
(``Robot.sesc_matrix``), and measures it through ``sescid.identify`` (the default method):

- **torques, one foot or both** (OP2, TALOS, Unitree G1): 76 poses on the right foot against
  38 + 38 on each foot, every joint's torque with a random offset per joint (the same sensor
  in both stances) and noise, both 0.05 N·m × M / 3 kg; beside them a CoP-only MAP fit of the
  same 38 + 38 poses (CoP noise 4.93 mm, the paper's) and an independent pooled MAP reference
  (a dense numpy solve over θ and the offsets, the draws' own distribution as its prior);
- **torques, a gantry and a foot** (the torso held, 38 poses, and 38 on the right foot);
- **CoP, one sole or both** (OP2, 4.93 mm): 76 poses on the right sole against 38 + 38.

Error: RMS of the whole-body CoM against the truth's at 2000 fresh poses of the right-foot
stance, mm; ranks over the 4N body parameters (pooled) or the stance's own.
"""

from __future__ import annotations

import argparse
import zlib
from pathlib import Path

import numpy as np
from doc_blocks import spliced
from study_refs import TORQUE_ROBOTS, body_parameters, model_path, pooled_reference, real_bodies

import sescid
from sescid.estimation import Measurements

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "stances.md"
START, END = "<!-- stances-study: tools/stances_study.py -->", "<!-- /stances-study -->"
LEFT = {"OP2": "l_sole", "TALOS": "left_sole_link", "Unitree G1": "left_ankle_roll_link"}


def poses(robot, k, rng):
    lim = np.clip(robot.joint_limits, -0.5, 0.5)
    return rng.uniform(lim[:, 0], lim[:, 1], (k, robot.nq))


def measure(ref, theta, support, k, rng, offsets, sigma, kind):
    """k poses of the stance ``support``: torques (with the joints' offsets) or the CoP."""
    robot = ref.at(support)
    mass = theta[: len(ref.body_names)].sum()
    r = (robot.sesc_matrix(ref) @ theta / mass).reshape(-1, 3)
    q = poses(robot, k, rng)
    stance = None if support == ref.support else support
    if kind == "cop":
        cop = robot.cop(q, r) + rng.normal(0, 0.00493, (k, 2))
        return Measurements(q=q, cop=cop, support=stance)
    tau = robot.torques(q, r, total_mass=mass) + offsets + rng.normal(0, sigma, (k, robot.nq))
    return Measurements(q=q, tau=tau, tau_joints=tuple(robot.joint_names), support=stance)


def torque_case(name: str, draws: int) -> list[str]:
    rel, sole, held = TORQUE_ROBOTS[name]
    ref = sescid.load_robot(model_path(rel), sole)
    rng = np.random.default_rng(zlib.crc32(name.encode()))
    sigma = 0.05 * ref.total_mass / 3.0
    prior = np.array([body_parameters(real_bodies(ref, rng)) for _ in range(2000)])
    mean, var = prior.mean(axis=0), np.maximum(prior.var(axis=0), 1e-12)
    fresh = poses(ref, 2000, rng)
    err: dict[str, list[float]] = {}
    ranks: dict[str, int] = {}
    for _ in range(draws):
        theta = body_parameters(real_bodies(ref, rng))
        mass = float(theta[: len(ref.body_names)].sum())
        r_true = (ref.sesc_matrix() @ theta / mass).reshape(-1, 3)
        off = rng.normal(0, sigma, ref.nq)
        one = measure(ref, theta, sole, 76, rng, off, sigma, "tau")
        both = [measure(ref, theta, s, 38, rng, off, sigma, "tau") for s in (sole, LEFT[name])]
        held_foot = [measure(ref, theta, s, 38, rng, off, sigma, "tau") for s in (held, sole)]
        cop = [measure(ref, theta, s, 38, rng, off, sigma, "cop") for s in (sole, LEFT[name])]
        fits = {
            "torques, right foot, 76 poses": sescid.identify(ref, one, total_mass=mass),
            "torques, both feet, 38 + 38": sescid.identify(ref, both, total_mass=mass),
            "torques, gantry + right foot, 38 + 38": sescid.identify(
                ref, held_foot, total_mass=mass
            ),
            "CoP only, both feet, 38 + 38 (MAP)": sescid.identify(ref, cop, method="map"),
        }
        for label, fit in fits.items():
            d = ref.com(fresh, fit.r) - ref.com(fresh, r_true)
            err.setdefault(label, []).append(1e3 * float(np.sqrt(np.mean(np.sum(d * d, 1)))))
            ranks[label] = fit.bodies.rank if fit.bodies is not None else fit.rank
        r_ref = pooled_reference(ref, both, sigma, mean, var, mass)
        d = ref.com(fresh, r_ref) - ref.com(fresh, r_true)
        err.setdefault("independent pooled MAP, both feet", []).append(
            1e3 * float(np.sqrt(np.mean(np.sum(d * d, 1))))
        )
        d = ref.com(fresh, ref.sesc_vectors()) - ref.com(fresh, r_true)
        err.setdefault("CAD model", []).append(1e3 * float(np.sqrt(np.mean(np.sum(d * d, 1)))))
    n = 4 * len(ref.body_names)
    lines = [f"**{name}** ({draws} draws; ranks of {n} body parameters, or of the stance's "
             f"{3 * len(ref.body_names)} SESC components for one stance)", "",
             "| data | combinations determined | CoM error, mean mm | worst draw |",
             "|---|---|---|---|"]  # fmt: skip
    for label, v in err.items():
        rank = ranks.get(label, "—")
        lines.append(f"| {label} | {rank} | {np.mean(v):.2f} | {np.max(v):.2f} |")
    pooled = np.mean(err["torques, both feet, 38 + 38"])
    lines += ["", f"both feet / right foot: {pooled / np.mean(err['torques, right foot, 76 poses']):.2f}; "
              f"/ CoP-only MAP: {pooled / np.mean(err['CoP only, both feet, 38 + 38 (MAP)']):.2f}; "
              f"/ independent reference: {pooled / np.mean(err['independent pooled MAP, both feet']):.2f}", ""]  # fmt: skip
    return lines


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("--draws", type=int, default=40)
    p.add_argument("--write", action="store_true")
    args = p.parse_args()
    lines: list[str] = []
    for name in TORQUE_ROBOTS:
        lines += torque_case(name, args.draws)
        print("\n".join(lines[-12:]), flush=True)
    text = "\n".join(lines).rstrip()
    if args.write:
        DOC.write_text(spliced(DOC.read_text(), START, END, text))
    print(text)


if __name__ == "__main__":
    main()
