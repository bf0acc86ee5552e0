"""What a handful of poses tell about a payload: errors and coverage against known truth.

    python tools/payload_study.py [--draws 25]           # prints the tables
    python tools/payload_study.py --write                # rewrites them in docs/payload.md

Each draw puts a 1.2 kg box 80 mm from a hand's origin (along the link's x axis) on a robot
and measures it at k random poses (uniform in the joint limits clipped to ±0.5 rad): the CoP
(noise 2 mm per axis) or every joint's holding torque (a random offset per joint and noise, both
0.05 N·m × M / 3 kg), with the right sole held. ``sescid.identify_payload`` then fits the payload
on the robot's model (the base), with or without its weighed mass. Two bases:

- **calibrated**: the robot is its model plus the box (the base is exact, as after a fit);
- **CAD**: the robot differs from its model as in ``study_refs.real_bodies`` (masses ±10 %,
  CoMs ±5 mm, 5 % of the mass unmodelled on heavy bodies): what using the model file as the base
  costs when it is not the robot.

Columns: RMS over draws of the mass error [g]; the median (and 90th percentile) of the CoM
error's norm [mm] (a fitted mass near 0 makes c = h / m, and its error, unbounded); the share of
errors within 2 stated standard errors (all identified components; 95 % is ideal, fewer rows
than 3 × parameters widen the t-tails); the RMS prediction error at 500 fresh poses of the
payload fit and of the base alone (the CoP in mm, or the torques in N·m, against the noise-free
truth); the median time of one fit. The truth's payload is put on the body parameters θ with
``estimation.solvers.payload_rows.payload_map`` (tests check that map against the model file
with the box added as a link, and against Pinocchio).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
from doc_blocks import spliced
from study_refs import body_parameters, model_path, real_bodies

import sescid
from sescid.estimation import Measurements
from sescid.estimation.solvers.payload_rows import payload_map

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "payload.md"
START, END = "<!-- payload-study: tools/payload_study.py -->", "<!-- /payload-study -->"
#: name: (model, support, hand link)
ROBOTS = {
    "OP2": ("op2", None, "MP_ARM_LOW_R"),
    "TALOS": ("talos_data/robots/talos_reduced.urdf", "right_sole_link", "gripper_right_base_link"),
}
MASS, OFFSET = 1.2, 0.08
COP_NOISE = 2e-3
POSES = (4, 8, 16)
FRESH = 500


def poses(robot, k, rng):
    lim = np.clip(robot.joint_limits, -0.5, 0.5)
    return rng.uniform(lim[:, 0], lim[:, 1], (k, robot.nq))


def one(robot, hand, kind, k, weighed, cad, rng, tau_noise):
    """One draw: (mass error kg, CoM error m, z-scores, fit's and base's fresh errors, s)."""
    n = len(robot.body_names)
    theta = body_parameters(real_bodies(robot, rng)) if cad else robot.body_parameters()
    p_true = np.array([MASS, MASS * OFFSET, 0.0, 0.0])
    theta_t = theta + payload_map(robot, hand) @ p_true
    mass_t = float(theta_t[:n].sum())
    r_true = (robot.sesc_matrix() @ theta_t / mass_t).reshape(-1, 3)
    q = poses(robot, k, rng)
    if kind == "cop":
        data = Measurements(q=q, cop=robot.cop(q, r_true) + rng.normal(0, COP_NOISE, (k, 2)))
    else:
        tau = robot.torques(q, r_true, total_mass=mass_t)
        tau = tau + rng.normal(0, tau_noise, robot.nq) + rng.normal(0, tau_noise, tau.shape)
        data = Measurements(q=q, tau=tau, tau_joints=tuple(robot.joint_names))
    t0 = time.perf_counter()
    fit = sescid.identify_payload(robot, data, hand, mass=MASS if weighed else None)
    dt = time.perf_counter() - t0
    p = fit.payload
    est = np.concatenate([[p.mass], p.com])
    std = np.concatenate([[p.mass_std], p.com_std])
    truth = np.array([MASS, OFFSET, 0.0, 0.0])
    with np.errstate(invalid="ignore", divide="ignore"):  # a weighed mass: 0 / 0
        z = ((est - truth) / std)[1:] if weighed else (est - truth) / std
    fresh = poses(robot, FRESH, rng)
    if kind == "cop":
        ref = robot.cop(fresh, r_true)
        err_fit = np.sqrt(np.mean((fit.predict_cop(fresh) - ref) ** 2))
        err_base = np.sqrt(np.mean((robot.cop(fresh) - ref) ** 2))
    else:
        ref = robot.torques(fresh, r_true, total_mass=mass_t)
        err_fit = np.sqrt(np.mean((fit.predict_torque(fresh) - ref) ** 2))
        err_base = np.sqrt(np.mean((robot.torques(fresh) - ref) ** 2))
    return est[0] - MASS, np.linalg.norm(est[1:] - truth[1:]), z, err_fit, err_base, dt


def study(draws: int) -> str:
    lines = []
    for name, (model, support, hand) in ROBOTS.items():
        robot = sescid.load_robot(model_path(model), support)
        tau_noise = 0.05 * robot.total_mass / 3.0
        lines += [
            "",
            f"**{name}** ({robot.total_mass:.1f} kg, payload on `{hand}`, support "
            f"`{robot.support}`; CoP noise {COP_NOISE * 1e3:g} mm, torque noise and offsets "
            f"{tau_noise:.3g} N·m; {draws} draws each)",
            "",
            "| base | data | mass | poses | mass error [g] | CoM error [mm] (90 %) | within 2σ | "
            "fresh error: fit / base alone | unseen | time [s] |",
            "|---|---|---|---:|---:|---:|---:|---|---:|---:|",
        ]
        for cad in (False, True):
            for kind in ("cop", "tau"):
                for weighed in (False, True):
                    for k in POSES:
                        rng = np.random.default_rng([k, int(cad), int(weighed), len(kind), 33])
                        rows = [one(robot, hand, kind, k, weighed, cad, rng, tau_noise)
                                for _ in range(draws)]  # fmt: skip
                        dm = np.array([r[0] for r in rows])
                        dc = np.array([r[1] for r in rows])
                        z = np.concatenate([r[2] for r in rows])
                        unseen = int(np.sum([np.any(np.isnan(r[2])) for r in rows]))
                        ef = np.sqrt(np.mean([r[3] ** 2 for r in rows]))
                        eb = np.sqrt(np.mean([r[4] ** 2 for r in rows]))
                        unit, scale = ("mm", 1e3) if kind == "cop" else ("N·m", 1.0)
                        ok = z[np.isfinite(z)]
                        cover = f"{np.mean(np.abs(ok) < 2):.0%}" if ok.size else "—"
                        lines.append(
                            f"| {'CAD' if cad else 'calibrated'} | "
                            f"{'CoP' if kind == 'cop' else 'torques'} | "
                            f"{'weighed' if weighed else 'fitted'} | {k} | "
                            + ("—" if weighed else f"{np.sqrt(np.nanmean(dm**2)) * 1e3:.0f}")
                            + f" | {np.nanmedian(dc) * 1e3:.1f} ({np.nanpercentile(dc, 90) * 1e3:.0f})"
                            f" | {cover} | "
                            f"{ef * scale:.3g} / {eb * scale:.3g} {unit} | {unseen} | "
                            f"{np.median([r[5] for r in rows]):.3f} |"
                        )
                        print(lines[-1], flush=True)
    return "\n".join(lines).strip()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--draws", type=int, default=25)
    ap.add_argument("--write", action="store_true", help="rewrite docs/payload.md's tables")
    args = ap.parse_args()
    text = study(args.draws)
    if args.write:
        DOC.write_text(spliced(DOC.read_text(), START, END, text))
        print(f"wrote {DOC}")


if __name__ == "__main__":
    main()
