"""The gain of a guided session on the MuJoCo bench: poses needed vs 38 D-optimal / 38 random.

The "real" OP2 of ``ExperimentConfig`` (7 % unmodelled mass, ±1° backlash, noisy biased pads)
stands in MuJoCo. Three ways to choose poses from the same candidate pool (same seed):

* 38 D-optimal poses (``plan_poses``: greedy + exchange, ordered), measured in turn;
* 38 random candidates (``--draws`` draws, the median error);
* a guided session (``run_session``: next-best pose near the current one), run to ``--budget``
  poses without stopping, the fit recomputed after each measured pose.

Error: RMS of (identified − true) CoP on ``--test`` fresh stable poses (noise-free truth
``robot.cop(q, r_true)``), weighted least squares on each design's measured CoPs. Printed: the
error of each design, the poses (commanded, failures included) the guided session needed to
reach the D-optimal and the random error, and where its convergence rule (``--window``,
``--tol``) would have stopped it.

Run: PYTHONPATH=src python benchmarks/bench_session_gain.py [--seeds 0 1] [--budget 80]
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

import sescid
from sescid.planning import candidates, plan_poses
from sescid.sensors import load_sensors, measure, read_raw
from sescid.session import MujocoAdapter, SessionOptions, run_session
from sescid.session.samples import raw_table


def measure_poses(robot, sensors, q, seed, samples):
    """Command each pose on a fresh bench; (q_read (k, nq), cop (k, 2), se (k, 2), failed)."""
    bot = MujocoAdapter(robot, sensors, seed=seed)
    qs, cops, ses, failed = [], [], [], 0
    for i, qi in enumerate(q):
        bot.move(str(i), qi)
        if bot.wait_settled():
            failed += 1
            continue
        cols = bot.read(samples)
        n = len(next(iter(cols.values())))
        part = {"pose": np.full(n, str(i)), "sample": np.arange(n)} | cols
        m = measure(
            robot,
            read_raw(raw_table(part), robot.joint_names, sensors, robot.profile.servo),
            sensors,
        )
        if len(m.pose):
            qs.append(m.data.q[0])
            cops.append(m.data.cop[0])
            ses.append(m.data.cop_se[0])
    return np.array(qs), np.array(cops), np.array(ses), failed, bot.r_true


def cop_error(robot, q, cop, se, q_test, r_true) -> float:
    fit = sescid.identify(robot, q, cop, sigma=se)
    d = fit.predict_cop(q_test) - robot.cop(q_test, r_true)
    return float(np.sqrt(np.mean(d**2)))


def first_reaching(errors: list[tuple[int, float]], target: float) -> int | None:
    """Commanded poses at the first measured pose whose error is ≤ target."""
    return next((k for k, e in errors if e <= target), None)


def run(seed: int, a) -> dict:
    robot = sescid.load_robot("op2")
    sensors = load_sensors(None, robot.profile)
    q_test = candidates(robot, a.test, seed=1000 + seed).q
    t0 = time.perf_counter()
    plan = plan_poses(robot, 38, "d-optimal", seed, n_candidates=a.candidates, n_test=500)
    qd, cd, sd, fd, r_true = measure_poses(robot, sensors, plan.q, seed, a.samples)
    e_d = cop_error(robot, qd, cd, sd, q_test, r_true)
    pool = plan.candidates.q[: a.candidates]
    rng = np.random.default_rng(seed)
    e_rs, f_rs = [], []
    for _ in range(a.draws):
        qr = pool[rng.choice(len(pool), 38, replace=False)]
        q1, c1, s1, f1, _ = measure_poses(robot, sensors, qr, seed, a.samples)
        e_rs.append(cop_error(robot, q1, c1, s1, q_test, r_true))
        f_rs.append(f1)
    e_r = float(np.median(e_rs))
    opt = SessionOptions(
        budget=a.budget,
        samples=a.samples,
        n_candidates=a.candidates,
        seed=seed,
        window=10**6,
        near=a.near,
    )
    res = run_session(robot, MujocoAdapter(robot, sensors, seed=seed), sensors, opt)
    m = res.measured
    commanded = {s.pose: i + 1 for i, s in enumerate(res.steps)}
    errors = []
    for k in range(21, len(m.pose) + 1):
        d = m.data.take(slice(k))
        e = cop_error(robot, d.q, d.cop, d.cop_se, q_test, r_true)
        errors.append((commanded[m.pose[k - 1]], e))
    # where the stated rule (fall < tol over the last window poses) would have stopped
    std = [s.cop_std for s in res.steps if s.status == "measured"]
    stop = None
    for k in range(a.window, len(std)):
        old, new = std[k - a.window], std[k]
        if k + 1 >= 21 and math.isfinite(old) and math.isfinite(new) and (old - new) / new < a.tol:
            stop = k
            break
    stop_at = (commanded[m.pose[stop]], errors[stop - 20][1]) if stop is not None else None
    return {
        "seed": seed,
        "e_d": e_d,
        "fail_d": fd,
        "e_r": e_r,
        "e_r_all": e_rs,
        "fail_r": f_rs,
        "need_d": first_reaching(errors, e_d),
        "need_r": first_reaching(errors, e_r),
        "final": errors[-1],
        "stop": stop_at,
        "wall": time.perf_counter() - t0,
    }


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--seeds", type=int, nargs="+", default=[0])
    p.add_argument("--budget", type=int, default=80)
    p.add_argument("--candidates", type=int, default=5000)
    p.add_argument("--samples", type=int, default=30)
    p.add_argument("--draws", type=int, default=3)
    p.add_argument("--test", type=int, default=1000)
    p.add_argument("--window", type=int, default=10)
    p.add_argument("--tol", type=float, default=0.10)
    p.add_argument("--near", type=float, default=0.8, help="session: gain fraction, 1 = greedy")
    a = p.parse_args()
    for seed in a.seeds:
        r = run(seed, a)
        print(
            f"seed {seed}: 38 D-optimal {r['e_d'] * 1e3:.3f} mm ({r['fail_d']} failed); "
            f"38 random median {r['e_r'] * 1e3:.3f} mm "
            f"({', '.join(f'{e * 1e3:.3f}' for e in r['e_r_all'])}; failed {r['fail_r']})"
        )
        print(
            f"  guided: reaches the D-optimal error after {r['need_d']} commanded poses, "
            f"the random error after {r['need_r']}; after {r['final'][0]}: "
            f"{r['final'][1] * 1e3:.3f} mm"
        )
        if r["stop"] is not None:
            print(
                f"  its convergence rule (fall < {a.tol:.0%} over {a.window} poses) stops at "
                f"{r['stop'][0]} commanded poses, error {r['stop'][1] * 1e3:.3f} mm"
            )
        else:
            print(f"  its convergence rule did not stop it within {a.budget} poses")
        print(f"  wall {r['wall']:.0f} s")


if __name__ == "__main__":
    main()
