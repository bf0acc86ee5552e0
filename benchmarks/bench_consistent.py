"""Benchmark: one consistent fit (masses/CoMs by two Clarabel QPs) against plain least squares.

Prints, for the embedded OP2 and n simulated poses, the best-of-5 wall time of
``sescid.identify`` (least squares) and of ``identify --method consistent --via fit``
(least squares + the two QPs), their ratio, and the QP part alone.
Usage: ``python benchmarks/bench_consistent.py [--poses 1000]``.
"""

from __future__ import annotations

import argparse

from timing import best_of

import sescid
from sescid import ConsistentOptions
from sescid.estimation.solvers.consistent import consistent_from_fit


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--poses", type=int, default=1000)
    args = parser.parse_args()
    robot = sescid.load_robot("op2")
    sim = sescid.simulate(robot, args.poses, noise=0.00493, seed=0)
    ls = sescid.identify(robot, sim.q, sim.cop)  # warm-up (compiled kernels, imports)
    consistent_from_fit(ls)
    t_ls = best_of(lambda: sescid.identify(robot, sim.q, sim.cop))
    via_fit = ConsistentOptions(via="fit")
    t_all = best_of(lambda: sescid.identify(robot, sim.q, sim.cop, method=via_fit))
    t_qp = best_of(lambda: consistent_from_fit(ls))
    t_sym = best_of(lambda: consistent_from_fit(ls, symmetric=True, mass_floor=0.01))
    t_map = best_of(lambda: consistent_from_fit(ls, prior_std=0.05))
    print(f"OP2, {args.poses} poses (best of 5)")
    print(f"  least squares              {t_ls * 1e3:8.1f} ms")
    print(f"  consistent (LS + 2 QPs)    {t_all * 1e3:8.1f} ms  ({t_all / t_ls:.2f}× LS)")
    print(f"  the 2 QPs alone            {t_qp * 1e3:8.1f} ms")
    print(f"  … symmetric, floor 10 g    {t_sym * 1e3:8.1f} ms")
    print(f"  … one QP with CAD prior    {t_map * 1e3:8.1f} ms")


if __name__ == "__main__":
    main()
