"""Benchmark: a pooled fit (poses from several stances, one body-parameter system) against one
stance with the same number of poses — the cost per pose and the peak memory of streamed poses,
each beside its target, measured in the same run.

The reference is sescid itself on one stance (the OP2 on its right sole); the pooled run splits
the same number of poses between the right sole and the left sole. Both run ``identify`` with
least squares (``robust=False``: one pass over the poses) and with the default method ("auto",
the Huber loss for torques). Rounds call each case in turn (best of 4), so all see the same
moments of a shared machine. Each source takes numpy's path or the compiled kernels by its own
size (``kinematics.use_kernels``): two sources each under numpy's budget stay on numpy's path
(about 13 µs per CoP pose) where one source of their total size would not, pooled or not; the
timed sizes keep every source above it. Usage:
``python benchmarks/bench_pooled.py [--poses 200000] [--memory-poses 1000000]``.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time

import numpy as np
from timing import environment, verdict

import sescid
from sescid.estimation import Measurements

TARGET_RATIO = 1.2  #: pooled / one stance, time per pose (the issue's ±20 %)
TARGET_MB_RATIO = 1.2  #: pooled / one stance, peak RSS of streamed poses
STANCES = ("r_sole", "l_sole")


def data(robot, n: int, kind: str, support: str, seed: int) -> Measurements:
    """n random poses (±30°) measured in ``support``'s frame: CoP (noise 4.93 mm) or the 20 joint
    torques (noise 0.05 N·m)."""
    rng = np.random.default_rng(seed)
    at = robot.at(support)
    q = rng.uniform(-0.52, 0.52, (n, robot.nq))
    tag = None if support == robot.support else support
    if kind == "cop":
        return Measurements(q=q, cop=at.cop(q) + rng.normal(0, 0.00493, (n, 2)), support=tag)
    tau = at.torques(q) + rng.normal(0, 0.05, (n, robot.nq))
    return Measurements(q=q, tau=tau, tau_joints=tuple(robot.joint_names), support=tag)


def rates(robot, n: int) -> bool:
    """CPU time per pose of one stance and pooled, per kind and method, as the slope between n
    and 2n poses (the pooled fit's fixed cost, its lift to the body parameters and its ranks,
    printed apart); True when every ratio of slopes is met."""
    cases = {}
    for kind in ("cop", "torque"):
        for size in (n, 2 * n):
            one = data(robot, size, kind, STANCES[0], 1)
            both = [data(robot, size // 2, kind, s, 2 + i) for i, s in enumerate(STANCES)]
            for method, kw in (("ls", {"method": "ls", "robust": False}), ("auto", {})):
                for label, d in (("one stance", one), ("pooled", both)):
                    cases[(kind, method, label, size)] = lambda d=d, kw=kw: sescid.identify(
                        robot, d, total_mass=robot.total_mass, **kw
                    )
    for f in cases.values():
        f()  # compile and warm every path once
    cpu = dict.fromkeys(cases, np.inf)
    for _ in range(4):
        for key, f in cases.items():
            c = time.process_time()
            f()
            cpu[key] = min(cpu[key], time.process_time() - c)
    print(
        f"CPU time (all threads) per pose, the slope between {n} and {2 * n} OP2 poses (pooled: "
        "half on each sole; every source above numpy's budget, so both take the compiled path)"
    )
    ok = True
    for kind in ("cop", "torque"):
        for method in ("ls", "auto"):
            slope, fixed = {}, {}
            for label in ("one stance", "pooled"):
                t1, t2 = cpu[(kind, method, label, n)], cpu[(kind, method, label, 2 * n)]
                slope[label] = (t2 - t1) / n
                fixed[label] = t1 - n * slope[label]
            ratio = slope["pooled"] / slope["one stance"]
            ok &= ratio <= TARGET_RATIO
            print(
                f"  {kind:<6} {method:<4} one stance {slope['one stance'] * 1e6:6.2f} µs/pose   "
                f"pooled {slope['pooled'] * 1e6:6.2f} µs/pose   ratio {ratio:4.2f} (target ≤ "
                f"{TARGET_RATIO}: {verdict(ratio <= TARGET_RATIO)});  fixed cost "
                f"{fixed['one stance'] * 1e3:5.0f} / {fixed['pooled'] * 1e3:5.0f} ms"
            )
    return ok


_MEMORY_CHILD = """
import sys, json
import numpy as np
import sescid
from sescid.estimation import Measurements
n, chunk, stances = int(sys.argv[1]), int(sys.argv[2]), sys.argv[3].split(",")
robot = sescid.load_robot("op2")
def hwm():  # peak RSS of this process image in MB
    for line in open("/proc/self/status"):
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) / 1024
sescid.kinematics.load_kernels()
base = hwm()
def chunks(support, k, seed):
    rng = np.random.default_rng(seed)
    at = robot.at(support)
    tag = None if support == robot.support else support
    for s in range(0, k, chunk):
        q = rng.uniform(-0.52, 0.52, (min(chunk, k - s), robot.nq))
        yield Measurements(q=q, cop=at.cop(q) + rng.normal(0, 0.00493, (len(q), 2)), support=tag)
k = n // len(stances)
sources = [chunks(s, k, i) for i, s in enumerate(stances)]
fit = sescid.identify(robot, sources if len(sources) > 1 else sources[0], method="ls")
rank = fit.bodies.rank if fit.bodies is not None else fit.rank
print(json.dumps({"rank": rank, "n": fit.n_poses, "base": base, "peak": hwm()}))
"""


def memory(n: int) -> bool:
    """Peak RSS of identifying n streamed CoP poses (chunks of 50 000) in a fresh process, one
    stance and pooled over both soles."""
    peaks = {}
    for label, stances in (("one stance", STANCES[:1]), ("pooled", STANCES)):
        t = time.perf_counter()
        out = subprocess.run(
            [sys.executable, "-c", _MEMORY_CHILD, str(n), "50000", ",".join(stances)],
            capture_output=True,
            text=True,
            check=True,
        )
        res = json.loads(out.stdout.strip().splitlines()[-1])
        peaks[label] = res["peak"]
        print(
            f"memory, {label}: {res['n']} streamed CoP poses (rank {res['rank']}), "
            f"{time.perf_counter() - t:.1f} s with simulating them: peak RSS {res['peak']:.0f} MB "
            f"(after imports and kernels {res['base']:.0f} MB)"
        )
    ratio = peaks["pooled"] / peaks["one stance"]
    print(
        f"  pooled / one stance, peak RSS: {ratio:.2f}  (target ≤ {TARGET_MB_RATIO}: "
        f"{verdict(ratio <= TARGET_MB_RATIO)})"
    )
    return ratio <= TARGET_MB_RATIO


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--poses", type=int, default=200_000, help="poses of the smaller timed run")
    ap.add_argument("--memory-poses", type=int, default=1_000_000, help="poses streamed")
    args = ap.parse_args()
    print(environment())
    robot = sescid.load_robot("op2")
    ok = rates(robot, args.poses)
    ok &= memory(args.memory_poses)
    print("all targets met" if ok else "some targets NOT met")


if __name__ == "__main__":
    main()
