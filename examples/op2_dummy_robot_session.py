"""A guided session on your own robot: a Python class with four methods (here a dummy OP2).

Write a class with ``move``, ``wait_settled``, ``read`` and ``stop`` (the protocol in
``sescid.session.adapters``) that talks to your robot, then run

    sescid session --adapter python:examples/op2_dummy_robot_session.py:DummyRobot \\
        --out-dir session/ --no-view

``DummyRobot`` stands in for a real one: its true mass distribution is the model's plus 40 g on
the torso, each commanded angle lands within ±0.5° (its read-backs see the actual angle), and it
reports a CoP per sample from an ankle force/torque sensor (``r_cop_x``, ``r_cop_y`` in m,
``r_fz`` in N) with 1 mm noise. Run as a script, it does the same through the Python API and
prints how close the identified CoP gets to the truth.
"""

from __future__ import annotations

import argparse
import math

import numpy as np

import sescid
from sescid.sensors import load_sensors
from sescid.session.loop import SessionOptions, run_session


class DummyRobot:
    """A simulated robot behind the session protocol (move, wait_settled, read, stop)."""

    def __init__(self, robot, seed: int = 0, noise: float = 0.001):
        self.robot = robot
        self.rng = np.random.default_rng(seed)
        self.noise = noise
        self.r_true = robot.sesc_vectors()
        torso = robot.body_names.index("MP_BODY")
        self.r_true[torso] += np.array([-0.03, 0.01, 0.0]) * 0.040 / robot.total_mass
        self.q = np.zeros(robot.nq)
        self.commands: list[np.ndarray] = []

    def move(self, pose: str, q: np.ndarray) -> None:
        """Command q (rad); the joints land within ±0.5° of it."""
        self.commands.append(np.array(q))
        self.q = q + self.rng.uniform(-1, 1, size=q.shape) * math.radians(0.5)

    def wait_settled(self) -> str:
        """A real robot would wait for its joint velocities to vanish; '' = settled."""
        cop = self.robot.cop(self.q[None], self.r_true)[0]
        if np.any(np.abs(cop) > 0.03):
            return f"toppled: CoP {cop * 1e3} mm off the sole"
        return ""

    def read(self, n: int) -> dict[str, np.ndarray]:
        """n samples: joint read-backs (rad) and the sole CoP (m) with its normal force (N)."""
        cop = self.robot.cop(self.q[None], self.r_true)[0]
        cols = {j: np.full(n, self.q[k]) for k, j in enumerate(self.robot.joint_names)}
        noisy = cop + self.rng.normal(0.0, self.noise, size=(n, 2))
        return cols | {
            "r_cop_x": noisy[:, 0],
            "r_cop_y": noisy[:, 1],
            "r_fz": np.full(n, self.robot.total_mass * 9.80665),
        }

    def stop(self) -> None:
        """Release the robot (torque off, or a safe pose)."""


def main(budget: int = 60, candidates: int = 3000, samples: int = 20) -> float:
    """Run a guided session on the dummy robot; RMS CoP error of the fit vs truth [m]."""
    robot = sescid.load_robot("op2")
    bot = DummyRobot(robot)
    opt = SessionOptions(budget=budget, samples=samples, n_candidates=candidates)
    res = run_session(robot, bot, load_sensors(None, robot.profile), opt)
    q_test = sescid.planning.candidates(robot, 500, seed=99).q
    err = res.fit.predict_cop(q_test) - robot.cop(q_test, bot.r_true)
    rms = float(np.sqrt(np.mean(err**2)))
    print(
        f"{res.stop_reason}: {res.n_measured} of {len(res.steps)} poses measured; "
        f"predicted CoP std {res.cop_std * 1e3:.3f} mm; RMS CoP error vs truth on 500 fresh "
        f"poses {rms * 1e3:.3f} mm"
    )
    return rms


if __name__ == "__main__":
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--budget", type=int, default=60)
    p.add_argument("--candidates", type=int, default=3000)
    p.add_argument("--samples", type=int, default=20)
    a = p.parse_args()
    main(a.budget, a.candidates, a.samples)
