"""The two-wheeled humanoid balancing on its axle: how well 40 balanced poses identify it.

    python tools/balance_study.py            # rewrites the table in docs/balance.md
    python tools/balance_study.py --check    # exit 1 when the page quotes other figures

Each of DRAWS draws takes a "real" robot (every body's mass ±10 %, its CoM moved ±1 cm; the
wheels stay balanced on the axle), 40 balanced poses (joints uniform in ±40°, clipped to the
limits) whose tilt an IMU reads with 0.5° of noise (``sescid.simulation.simulate_balance``), and
fits them through ``sescid.identify`` (least squares, MAP); the balancing tilt of 1000 fresh poses
is then predicted and compared with the truth's, beside the CAD model's, and the CoM's distance
from the axle at the zero pose with the truth's.
"""

from __future__ import annotations

import dataclasses
import math
import sys
from pathlib import Path

import numpy as np
from doc_blocks import spliced

import sescid
from sescid.estimation import Measurements
from sescid.estimation.data.anchor import com_distance
from sescid.robots import EXAMPLES
from sescid.sesc import balance_tilt, sesc_vectors
from sescid.simulation import simulate_balance

ROOT = Path(__file__).resolve().parents[1]
MODEL = EXAMPLES["wheeled_humanoid"]
DOC = ROOT / "docs" / "balance.md"
START, END = "<!-- balance-study: tools/balance_study.py -->", "<!-- /balance-study -->"
DRAWS, POSES, RANGE_DEG, NOISE_DEG = 20, 40, 40.0, 0.5


def real_robot(robot, rng) -> np.ndarray:
    """True SESC vectors of one draw (module docstring)."""
    bodies = []
    for b in robot.model.bodies:
        keep = b.name.startswith("wheel") or b.mass == 0
        com = b.com if keep else b.com + rng.normal(0, 0.01, 3)
        bodies.append(dataclasses.replace(b, mass=b.mass * (1 + 0.1 * rng.normal()), com=com))
    return sesc_vectors(dataclasses.replace(robot.model, bodies=bodies))


def study() -> dict[str, np.ndarray]:
    """Per model: (DRAWS, 2) fresh-pose tilt RMS error [rad] and CoM distance ratio."""
    robot = sescid.load_robot(MODEL, "axle", line="y")
    rng = np.random.default_rng(2026)
    out: dict[str, list] = {"CAD model": [], "least squares": [], "MAP": []}
    for d in range(DRAWS):
        r_true = real_robot(robot, rng)
        sim = simulate_balance(robot, POSES, RANGE_DEG, math.radians(NOISE_DEG), d, r_true)
        fresh = simulate_balance(robot, 1000, RANGE_DEG, 0.0, 1000 + d, r_true)
        data = Measurements(q=sim.q, balance=np.zeros(POSES), gravity=sim.gravity)
        fits = {
            "CAD model": robot.sesc_vectors(),
            "least squares": sescid.identify(robot, data, method="ls").r,
            "MAP": sescid.identify(robot, data, method="map").r,
        }
        true_d = com_distance(robot, r_true)
        for name, r in fits.items():
            assert robot.line is not None
            pred = balance_tilt(robot.tree, robot.line, fresh.q, r)[0]
            err = float(np.sqrt(np.mean((pred - fresh.tilt) ** 2)))
            out[name].append((err, com_distance(robot, r) / true_d))
    return {k: np.array(v) for k, v in out.items()}


def table(res: dict[str, np.ndarray]) -> str:
    """The Markdown table the page quotes."""
    cad = res["CAD model"][:, 0]
    lines = [
        "| model | tilt error, mean | worst draw | draws no worse than CAD | CoM distance / truth |",
        "|---|---|---|---|---|",
    ]
    for name, v in res.items():
        err, ratio = np.degrees(v[:, 0]), v[:, 1]
        better = "—" if name == "CAD model" else f"{np.sum(v[:, 0] <= cad)} of {len(cad)}"
        lines.append(
            f"| {name} | {err.mean():.3f}° | {err.max():.3f}° | {better} | "
            f"{ratio.min():.3f}–{ratio.max():.3f} |"
        )
    return "\n".join(lines)


def main() -> None:
    text = DOC.read_text()
    quoted = table(study())
    new = spliced(text, START, END, quoted)
    if "--check" in sys.argv:
        if new != text:
            print("docs/balance.md quotes other figures than tools/balance_study.py gives")
            sys.exit(1)
        return
    DOC.write_text(new)
    print(quoted)


if __name__ == "__main__":
    main()
