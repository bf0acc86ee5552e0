"""Benchmark: SESC regressor + normal-equation accumulation, and memory for 1e6 poses.

Prints poses/s for sescid's compiled, fused accumulation, for the whole in-memory
``sescid.identify`` (idle and with two busy processes loading the cores) and for a per-pose
Pinocchio loop measured in the same run (``computeStaticRegressor`` per pose, then the same
compiled product per block — the best a per-pose API allows), their ratio, and the peak memory
of identifying 1e6 poses from a stream of chunks.
Usage: ``python benchmarks/bench_regressor.py [--poses 1000000]``.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time

import numpy as np
from timing import best_of, best_of_both

import sescid
import sescid.base.threads
from sescid.estimation import accumulate
from sescid.kinematics import Workspace, gram_upper, padded, regressor_columns
from sescid.kinematics import compile as kcompile


def sescid_rate(robot, q, cop, repeat=3) -> float:
    accumulate(robot, [(q[:4096], cop[:4096])])  # warm-up (compiled kernels are cached)
    return len(q) / best_of(lambda: accumulate(robot, [(q, cop)]), repeat)


def identify_rate(robot, q, cop, repeat=3) -> tuple[float, float]:
    """Poses/s of the whole in-memory ``sescid.identify`` (accumulate, solve, MAE pass), by
    wall time and by the process's CPU time."""
    sescid.identify(robot, q[:4096], cop[:4096])
    wall, cpu = best_of_both(lambda: sescid.identify(robot, q, cop), repeat)
    return len(q) / wall, len(q) / cpu


class CoreLoad:
    """Two busy processes (one per core of this machine) for the duration of a ``with``."""

    def __enter__(self):
        code = "while True: pass"
        self.procs = [subprocess.Popen([sys.executable, "-c", code]) for _ in range(2)]
        time.sleep(0.3)
        return self

    def __exit__(self, *exc):
        for p in self.procs:
            p.kill()
            p.wait()


def sescid_full_columns_rate(robot, q, cop, repeat=3) -> float:
    """The same without reduced coordinates (63 columns), for reference."""

    def run():
        ws = Workspace(robot.tree, 2048)
        ata = np.zeros((63, 63))
        atb = np.zeros(63)
        for s in range(0, len(q), 2048):
            x = regressor_columns(robot.tree, q[s : s + 2048], (0, 1), ws)
            ata += x @ x.T
            atb += x @ cop[s : s + 2048].T.reshape(-1)

    run()
    return len(q) / best_of(run, repeat)


def pinocchio_rate(robot, q, cop, block=2048) -> float:
    """Poses/s (wall) of the per-pose Pinocchio loop; see ``pinocchio_rates``."""
    return pinocchio_rates(robot, q, cop, block)[0]


def pinocchio_rates(robot, q, cop, block=2048) -> tuple[float, float]:
    """Poses/s by wall time and by the process's CPU time of ``computeStaticRegressor`` per
    pose, rows copied into blocks, then the same compiled product as sescid's."""
    run = pinocchio_loop(robot, q, cop, block)
    t, c = time.perf_counter(), time.process_time()
    run()
    return len(q) / (time.perf_counter() - t), len(q) / (time.process_time() - c)


def pinocchio_loop(robot, q, cop, block=2048):
    """The Pinocchio loop as a function of no arguments (model and buffers set up here)."""
    import pinocchio as pin

    model = pin.buildModelFromUrdf(str(robot.model_path), pin.JointModelFreeFlyer())
    data = model.createData()
    # map our joint columns to Pinocchio's configuration vector (all OP2 joints are revolute)
    idx = [model.joints[model.getJointId(n)].idx_q for n in robot.joint_names]
    qp = np.tile(pin.neutral(model), (len(q), 1))
    qp[:, idx] = q
    nv = 4 * (model.njoints - 1)
    ata = np.zeros((padded(nv), padded(nv)))
    atb = np.zeros(padded(nv))
    rows = np.empty((2 * block, nv))

    def run():
        for s in range(0, len(q), block):
            m = min(block, len(q) - s)
            for k in range(m):
                reg = pin.computeStaticRegressor(model, data, qp[s + k])
                rows[2 * k : 2 * k + 2] = reg[:2]
            x = rows[: 2 * m]
            gram_upper(np.ascontiguousarray(x.T), cop[s : s + m].reshape(-1), ata, atb)

    return run


def single_pose_com(robot, n=20000) -> tuple[float, float]:
    """µs per call of ``robot.com`` on one pose and of Pinocchio's ``centerOfMass``."""
    import pinocchio as pin

    kcompile.NUMPY_BUDGET = 0.0  # a long session: the compiled single-pose path
    rng = np.random.default_rng(1)
    qs = rng.uniform(-0.5, 0.5, (n, robot.nq))
    robot.com(qs[0])
    model = pin.buildModelFromUrdf(str(robot.model_path))
    data = model.createData()
    idx = [model.joints[model.getJointId(j)].idx_q for j in robot.joint_names]
    qp = np.tile(pin.neutral(model), (n, 1))
    qp[:, idx] = qs

    def ours():
        for k in range(n):
            robot.com(qs[k])

    def theirs():
        for k in range(n):
            pin.centerOfMass(model, data, qp[k])

    return best_of(ours, 3) / n * 1e6, best_of(theirs, 3) / n * 1e6


_MEMORY_CHILD = """
import sys, tracemalloc, json
import numpy as np
import sescid
from sescid.estimation import Measurements
n, chunk = int(sys.argv[1]), int(sys.argv[2])
robot = sescid.load_robot("op2")
def hwm():  # peak RSS of this process image in MB (VmHWM resets at exec, ru_maxrss does not)
    for line in open("/proc/self/status"):
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) / 1024
robot.cop(np.zeros((1, robot.nq)))                      # compile/load kernels before measuring
base = hwm()
tracemalloc.start()
rng = np.random.default_rng(0)
def chunks():
    for s in range(0, n, chunk):
        q = rng.uniform(-0.52, 0.52, (min(chunk, n - s), robot.nq))
        yield q, robot.cop(q) + rng.normal(0, 0.00493, (len(q), 2))
fit = sescid.identify(robot, (Measurements(q=q, cop=c) for q, c in chunks()))
peak_py = tracemalloc.get_traced_memory()[1] / 2**20
peak = hwm()
print(json.dumps({"rank": fit.rank, "n": fit.n_poses, "sigma_hat": fit.sigma_hat,
                  "rss_after_imports_mb": base, "peak_rss_mb": peak, "peak_traced_mb": peak_py}))
"""


def flop_ceiling(robot, block=2048, repeat=5) -> tuple[float, float]:
    """(poses/s, GFLOP/s) of the plain product X Xᵀ + X y alone, X of the accumulation's shape
    (reduced columns × 2 rows per pose, one block), by BLAS on one thread: the rate no
    accumulation of these normal equations can beat on one core."""
    from threadpoolctl import threadpool_limits

    with threadpool_limits(1):
        run, poses, flops = ceiling_run(robot, block)
        run()
        t = best_of(run, repeat)
    return poses / t, flops / t / 1e9


def ceiling_run(robot, block=2048, reps=50):
    """(run, poses, flops): 50 products X Xᵀ + X y of one block's shape, the poses and the
    floating-point operations they stand for (call ``run`` with BLAS on one thread)."""
    p = robot.reduction.g.shape[0]
    rng = np.random.default_rng(1)
    x = rng.standard_normal((p, 2 * block))
    y = rng.standard_normal(2 * block)

    def run():
        for _ in range(reps):
            _ = x @ x.T
            _ = x @ y

    flops = (2.0 * p * p * 2 * block + 2.0 * p * 2 * block) * reps
    return run, block * reps, flops


def machine_ceiling(robot) -> tuple[float, str]:
    """(poses/s, how): the fastest plain product X Xᵀ + X y per pose that this machine's BLAS
    gives for the accumulation's shape, over 1 and all usable threads and a few block sizes."""
    from threadpoolctl import threadpool_limits

    best, how = 0.0, ""
    for threads in sorted({1, sescid.base.threads.usable_cores()}):
        for block in (2048, 8192, 32768):
            with threadpool_limits(threads):
                run, poses, _ = ceiling_run(robot, block, reps=max(1, 100_000 // block))
                run()
                rate = poses / best_of(run, 5)
            if rate > best:
                best, how = rate, f"{threads} thread(s), {block} poses"
    return best, how


def interleaved(runs: dict, rounds: int = 5) -> tuple[dict, dict]:
    """Best wall time and best CPU time of this process (all its threads) in s of each
    function over ``rounds`` rounds that call them in turn, so that all of them see the same
    moments of a noisy (shared, virtual) machine."""
    wall = dict.fromkeys(runs, np.inf)
    cpu = dict.fromkeys(runs, np.inf)
    for _ in range(rounds):
        for name, f in runs.items():
            t, c = time.perf_counter(), time.process_time()
            f()
            wall[name] = min(wall[name], time.perf_counter() - t)
            cpu[name] = min(cpu[name], time.process_time() - c)
    return wall, cpu


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--poses", type=int, default=1_000_000, help="poses for the memory run")
    ap.add_argument("--rate-poses", type=int, default=200_000, help="poses per timed run")
    ap.add_argument("--ref-poses", type=int, default=20_000, help="poses for Pinocchio's loop")
    args = ap.parse_args()

    robot = sescid.load_robot("op2")
    rng = np.random.default_rng(0)
    q = rng.uniform(-0.52, 0.52, (args.rate_poses, robot.nq))
    cop = rng.normal(0, 0.02, (args.rate_poses, 2))
    print(f"OP2, {robot.nq} joints, {len(robot.body_names)} bodies; {args.rate_poses} poses")
    from threadpoolctl import threadpool_limits

    n, n_ref = len(q), args.ref_poses
    sescid.identify(robot, q[:4096], cop[:4096])  # warm-up: kernels loaded
    ceil_run, ceil_poses, ceil_flops = ceiling_run(robot)
    with threadpool_limits(1):
        best, cpu = interleaved(
            {
                "acc": lambda: accumulate(robot, [(q, cop)]),
                "identify": lambda: sescid.identify(robot, q, cop),
                "pin": pinocchio_loop(robot, q[:n_ref], cop[:n_ref]),
                "ceiling": ceil_run,
            }
        )
    ours, whole, ref = n / best["acc"], n / best["identify"], n_ref / best["pin"]
    ceil = ceil_poses / best["ceiling"]
    cores = sescid.base.threads.usable_cores()
    per_core = {k: (n_ref if k == "pin" else n) / v for k, v in cpu.items()}
    per_core["ceiling"] = ceil_poses / cpu["ceiling"]
    print(
        f"  best of 5 rounds running the four in turn; wall time (sescid's blocks on the "
        f"{cores} cores), and per core (CPU time of all threads)"
    )
    print(
        f"  sescid regressor + normal equations : {ours / 1e6:6.3f} M poses/s "
        f"({per_core['acc'] / 1e6:.3f} per core)"
    )
    print(
        f"  Pinocchio per-pose loop + same accum.: {ref / 1e6:6.3f} M poses/s "
        f"({per_core['pin'] / 1e6:.3f} per core)"
    )
    print(
        f"  ratio sescid / Pinocchio loop        : {ours / ref:6.1f}x "
        f"({per_core['acc'] / per_core['pin']:.1f}x per core)  (target >= 10x)"
    )
    print(
        f"  sescid.identify in memory (+ solve, MAE pass): {whole / 1e6:6.3f} M poses/s = "
        f"{whole / ref:.1f}x the Pinocchio loop ({per_core['identify'] / per_core['pin']:.1f}x"
        " per core)  (target >= 10x)"
    )
    print(
        f"  ceiling: plain X Xᵀ + X y, same shape : {ceil / 1e6:6.3f} M poses/s "
        f"({ceil_flops / best['ceiling'] / 1e9:.1f} GFLOP/s, BLAS on one thread); sescid at "
        f"{per_core['acc'] / per_core['ceiling']:.0%} of it per core, {ours / ceil:.0%} by wall "
        "time  (target >= 50%)"
    )
    machine, how = machine_ceiling(robot)
    print(
        f"  the machine's ceiling (best plain product X Xᵀ + X y over BLAS threads and block "
        f"sizes: {how}): {machine / 1e6:.3f} M poses/s; sescid by wall time at "
        f"{ours / machine:.0%} of it  (target >= 50%)"
    )
    full = sescid_full_columns_rate(robot, q, cop)
    print(
        f"  (accumulation with 63 full columns by BLAS, no reduction: {full / 1e6:.3f} M poses/s)"
    )
    with CoreLoad():  # wall time is then the scheduler's share; CPU time shows any spinning
        busy, busy_cpu = identify_rate(robot, q[: n // 2], cop[: n // 2])
        ref_wall, ref_cpu = pinocchio_rates(robot, q[:n_ref], cop[:n_ref])
    print(
        f"  with two busy processes on the {os.cpu_count()} cores: identify "
        f"{busy / 1e6:.3f} M poses/s wall, {busy_cpu / 1e6:.3f} by CPU time; Pinocchio loop "
        f"{ref_wall / 1e6:.3f} wall, {ref_cpu / 1e6:.3f} CPU; ratio {busy / ref_wall:.1f}x wall, "
        f"{busy_cpu / ref_cpu:.1f}x CPU"
    )

    ours_us, pin_us = single_pose_com(robot)
    print(
        f"  robot.com, one pose per call         : {ours_us:6.2f} us  "
        f"(Pinocchio centerOfMass {pin_us:.2f} us; target <= 5 us)"
    )

    print(f"memory: identify (streamed) on {args.poses} poses in chunks of 50000 …", flush=True)
    t = time.perf_counter()
    out = subprocess.run(
        [sys.executable, "-c", _MEMORY_CHILD, str(args.poses), "50000"],
        capture_output=True,
        text=True,
        check=True,
    )
    res = json.loads(out.stdout.strip().splitlines()[-1])
    print(
        f"  rank {res['rank']}, {res['n']} poses, sigma_hat {res['sigma_hat'] * 1e3:.3f} mm, "
        f"{time.perf_counter() - t:.1f} s incl. simulating the data"
    )
    print(
        f"  peak RSS {res['peak_rss_mb']:.0f} MB (after imports {res['rss_after_imports_mb']:.0f}"
        " MB: interpreter, numpy/scipy/numba); peak numpy/Python allocations "
        f"{res['peak_traced_mb']:.0f} MB  (target <= 300 MB)"
    )


if __name__ == "__main__":
    main()
