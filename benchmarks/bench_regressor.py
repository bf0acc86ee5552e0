"""Benchmark: the fused regressor + normal-equation pass, ``sescid.identify``, the measurement
kinds' cost per pose, and memory for 10⁶ poses — each beside its target and a reference measured
in the same run.

References, measured in turn with sescid (rounds that run each once, best of 5, so all see the
same moments of a shared machine):
- the bare Pinocchio loop: ``computeStaticRegressor`` per pose, nothing else (the least a user
  of a per-pose API pays);
- that loop plus the same compiled accumulation of its rows (what the normal equations cost
  through a per-pose API);
- the BLAS ceiling: the plain product X Xᵀ + X y of one block's reduced columns, one BLAS thread
  (no accumulation of these normal equations can beat it on one core).
Per core = CPU time of all this process's threads; wall = sescid on its default threads.
Usage: ``python benchmarks/bench_regressor.py [--poses 1000000]``.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time

import numpy as np
from timing import best_of, environment, load, verdict

import sescid
from sescid.estimation import Measurements, accumulate
from sescid.estimation.sums.system import Accumulator, RowOptions
from sescid.kinematics import gram_columns, load_kernels

TARGET_CEILING = 0.70  #: fused pass per core / BLAS ceiling
TARGET_IDENTIFY = 10.0  #: identify (wall) / bare Pinocchio loop
TARGET_TORQUE = 1.5  #: a torque pose (20 joints) / a CoP pose, fused pass
TARGET_MB = 300  #: peak RSS of 10⁶ streamed poses


def pinocchio(robot, q):
    """(bare loop, loop + accumulation) as functions of no arguments, for poses q."""
    import pinocchio as pin

    model = pin.buildModelFromUrdf(str(robot.model_path), pin.JointModelFreeFlyer())
    data = model.createData()
    idx = [model.joints[model.getJointId(n)].idx_q for n in robot.joint_names]
    qp = np.tile(pin.neutral(model), (len(q), 1))
    qp[:, idx] = q
    nv = 4 * (model.njoints - 1)
    block = 2048
    rows = np.empty((2 * block + 1, nv))
    y = np.random.default_rng(0).normal(0, 0.02, 2 * len(q))

    def bare():
        for k in range(len(q)):
            pin.computeStaticRegressor(model, data, qp[k])

    def with_accumulation():
        for s in range(0, len(q), block):
            m = min(block, len(q) - s)
            for k in range(m):
                rows[2 * k : 2 * k + 2] = pin.computeStaticRegressor(model, data, qp[s + k])[:2]
            x = np.empty((nv + 1, 2 * m))
            x[:nv] = rows[: 2 * m].T
            x[nv] = y[2 * s : 2 * s + 2 * m]
            gram_columns(x, True)  # the same compiled product as sescid's (FMA tiles)

    return bare, with_accumulation


def ceiling(robot, block=2048, reps=20):
    """(run, poses): ``reps`` products X Xᵀ + X y of one block's reduced columns (call with
    BLAS on one thread)."""
    p = robot.reduction.g.shape[0]
    rng = np.random.default_rng(1)
    x = rng.standard_normal((p, 2 * block))
    y = rng.standard_normal(2 * block)

    def run():
        for _ in range(reps):
            _ = x @ x.T
            _ = x @ y

    return run, block * reps


def interleaved(runs: dict, rounds: int = 5) -> tuple[dict, dict]:
    """Best wall and best CPU time (all threads) of each function over rounds that call them in
    turn."""
    wall = dict.fromkeys(runs, np.inf)
    cpu = dict.fromkeys(runs, np.inf)
    for _ in range(rounds):
        for name, f in runs.items():
            t, c = time.perf_counter(), time.process_time()
            f()
            wall[name] = min(wall[name], time.perf_counter() - t)
            cpu[name] = min(cpu[name], time.process_time() - c)
    return wall, cpu


def kinds(robot, n: int) -> None:
    """CPU time per pose of the fused pass and of ``identify`` for CoP, torque and mixed data."""
    rng = np.random.default_rng(2)
    q = rng.uniform(-0.52, 0.52, (n, robot.nq))
    cop = robot.cop(q) + rng.normal(0, 0.005, (n, 2))
    tau = robot.torques(q) + rng.normal(0, 0.05, (n, robot.nq))
    names = tuple(robot.joint_names)
    data = {
        "CoP": Measurements(q=q, cop=cop),
        "torque (20 joints)": Measurements(q=q, tau=tau, tau_joints=names),
        "mixed (CoP + 20 torques)": Measurements(q=q, cop=cop, tau=tau, tau_joints=names),
    }
    checked = {k: m.checked(robot) for k, m in data.items()}
    opts = RowOptions(total_mass=robot.total_mass)

    def fused(m):
        acc = Accumulator(robot, opts)
        acc.add(m)
        acc.finish()

    runs = {}
    for k, m in checked.items():
        runs[("pass", k)] = lambda m=m: fused(m)
        runs[("identify", k)] = lambda m=data[k]: sescid.identify(
            robot, m, total_mass=robot.total_mass, robust=False
        )
        # the default: torques without an approach side get the Huber loss (IRLS, ~5 passes)
        runs[("default", k)] = lambda m=data[k]: sescid.identify(
            robot, m, total_mass=robot.total_mass
        )
    for f in runs.values():
        f()
    _, cpu = interleaved(runs, 4)
    base = cpu[("pass", "CoP")]
    print(
        f"measurement kinds, {n} OP2 poses, CPU time per pose (all threads); identify "
        "least squares (robust=False), and its default (the Huber loss for torques without an "
        "approach column)"
    )
    for k in data:
        p, i, d = cpu[("pass", k)], cpu[("identify", k)], cpu[("default", k)]
        print(
            f"  {k:<26} fused pass {p / n * 1e9:6.0f} ns ({p / base:4.2f}× CoP)   identify "
            f"{i / n * 1e9:6.0f} ns ({i / cpu[('identify', 'CoP')]:4.2f}× CoP)   default "
            f"{d / n * 1e9:6.0f} ns"
        )
    ratio = cpu[("pass", "torque (20 joints)")] / base
    print(
        f"  a torque pose (20 joints) / a CoP pose, fused pass: {ratio:.2f}×  (target ≤ "
        f"{TARGET_TORQUE}×: {verdict(ratio <= TARGET_TORQUE)})"
    )


_MEMORY_CHILD = """
import sys, json
import numpy as np
import sescid
from sescid.estimation import Measurements
n, chunk = int(sys.argv[1]), int(sys.argv[2])
robot = sescid.load_robot("op2")
def hwm():  # peak RSS of this process image in MB (VmHWM resets at exec, ru_maxrss does not)
    for line in open("/proc/self/status"):
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) / 1024
sescid.kinematics.load_kernels()
base = hwm()
rng = np.random.default_rng(0)
def chunks():
    for s in range(0, n, chunk):
        q = rng.uniform(-0.52, 0.52, (min(chunk, n - s), robot.nq))
        yield Measurements(q=q, cop=robot.cop(q) + rng.normal(0, 0.00493, (len(q), 2)))
fit = sescid.identify(robot, chunks())
print(json.dumps({"rank": fit.rank, "n": fit.n_poses, "base": base, "peak": hwm()}))
"""


def memory(n: int) -> None:
    """Peak RSS of identifying n streamed poses (chunks of 50 000) in a fresh process."""
    t = time.perf_counter()
    out = subprocess.run(
        [sys.executable, "-c", _MEMORY_CHILD, str(n), "50000"],
        capture_output=True,
        text=True,
        check=True,
    )
    res = json.loads(out.stdout.strip().splitlines()[-1])
    print(
        f"memory: identify on {res['n']} streamed poses (rank {res['rank']}), "
        f"{time.perf_counter() - t:.1f} s with simulating them: peak RSS {res['peak']:.0f} MB "
        f"(after imports and kernels {res['base']:.0f} MB)  (target ≤ {TARGET_MB} MB: "
        f"{verdict(res['peak'] <= TARGET_MB)}; the CSV path: bench_commands.py)"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--poses", type=int, default=1_000_000, help="poses for the memory run")
    ap.add_argument("--rate-poses", type=int, default=200_000, help="poses per timed run")
    ap.add_argument("--ref-poses", type=int, default=20_000, help="poses for Pinocchio's loops")
    args = ap.parse_args()
    print(environment())
    robot = sescid.load_robot("op2")
    rng = np.random.default_rng(0)
    n, n_ref = args.rate_poses, args.ref_poses
    q = rng.uniform(-0.52, 0.52, (n, robot.nq))
    cop = rng.normal(0, 0.02, (n, 2))
    print(f"OP2, {robot.nq} joints, {len(robot.body_names)} bodies; {n} poses per timed run")
    from threadpoolctl import threadpool_limits

    load_kernels()
    sescid.identify(robot, q[:50_000], cop[:50_000])  # warm-up: kernels compiled or loaded
    bare, pin_acc = pinocchio(robot, q[:n_ref])
    ceil_run, ceil_poses = ceiling(robot)
    with threadpool_limits(1):
        wall, cpu = interleaved(
            {
                "pass": lambda: accumulate(robot, [(q, cop)]),
                "identify": lambda: sescid.identify(robot, q, cop),
                "bare": bare,
                "pin+acc": pin_acc,
                "ceiling": ceil_run,
            }
        )
    size = {"bare": n_ref, "pin+acc": n_ref, "ceiling": ceil_poses}
    rate = {k: size.get(k, n) / v for k, v in wall.items()}  # poses/s, wall
    core = {k: size.get(k, n) / v for k, v in cpu.items()}  # poses/s per core (CPU time)
    print("  poses/s (M), best of 5 rounds      wall   per core")
    for k, label in [
        ("bare", "Pinocchio bare loop (reference)"),
        ("pin+acc", "Pinocchio loop + same accumulation"),
        ("ceiling", "BLAS X Xᵀ + X y, one thread"),
        ("pass", "sescid fused pass"),
        ("identify", "sescid.identify in memory"),
    ]:
        print(f"  {label:<36} {rate[k] / 1e6:6.3f}   {core[k] / 1e6:6.3f}")
    share = core["pass"] / core["ceiling"]
    print(
        f"  fused pass per core at {share:.0%} of the BLAS ceiling  (target ≥ "
        f"{TARGET_CEILING:.0%}: {verdict(share >= TARGET_CEILING)})"
    )
    ratio = rate["identify"] / rate["bare"]
    print(
        f"  identify / bare Pinocchio loop: {ratio:.1f}× wall "
        f"({core['identify'] / core['bare']:.1f}× "
        f"per core)  (target ≥ {TARGET_IDENTIFY:.0f}× wall: {verdict(ratio >= TARGET_IDENTIFY)})"
    )
    print(
        f"  identify / Pinocchio loop + accumulation: {rate['identify'] / rate['pin+acc']:.1f}× "
        f"wall; fused pass / the same: {rate['pass'] / rate['pin+acc']:.1f}×"
    )
    kinds(robot, 50_000)
    single = q[0].copy()
    robot.com(single)
    per = best_of(lambda: [robot.com(single) for _ in range(20_000)], 3) / 20_000
    print(f"robot.com, one pose per call (kernels loaded): {per * 1e6:.2f} µs  (target ≤ 5 µs)")
    memory(args.poses)
    print(f"end: {load()}")


if __name__ == "__main__":
    main()
