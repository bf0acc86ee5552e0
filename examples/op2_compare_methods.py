"""Compare the estimation methods on held-out noise-free CoP error (OP2 simulation).

The "true" robot differs from the CAD model by 4 % of its mass (``--fraction``), added as point
masses on 6 random bodies at up to 3 cm (``--offset``) from their CoMs
(``sescid.estimation.perturbed_sesc``). Each method fits n random ±30° poses with CoP noise
σ = 4.93 mm; the error is the RMS of predicted minus noise-free CoP over 5000 fresh poses of the
true robot. Prints a Markdown table (mean over seeds, mm) and the MAP / least-squares ratio.

    .venv/bin/python examples/op2_compare_methods.py [--seeds 5] [--fraction 0.15 --offset 0.05]
"""

from __future__ import annotations

import argparse
import sys

import numpy as np
from threadpoolctl import threadpool_limits

import sescid
from sescid import ConsistentOptions, MapOptions
from sescid.estimation import OnlineEstimator, perturbed_sesc, truth_error
from sescid.simulation import PAPER_NOISE, simulate

ONLINE_TAU = 5e-4  #: m, the online estimator's fixed prior scale


def methods(robot):
    """name → fitter(q, cop) -> Fit."""

    def online(q, cop):
        est = OnlineEstimator(robot, prior_scale=ONLINE_TAU, noise=PAPER_NOISE)
        est.update(q, cop)
        return est.fit()

    def fit(method="ls", **kw):
        return lambda q, c: sescid.identify(robot, q, c, method=method, **kw)

    return {
        "auto (the default)": fit("auto"),
        "ls (least squares)": fit(),
        "map, τ by evidence": fit("map"),
        "map, τ by 5-fold cv": fit(MapOptions(select="cv")),
        "ls + huber (robust)": fit(robust=True),
        f"online, τ = {ONLINE_TAU * 1e3:g} mm, σ known": online,
        "consistent (default: CAD prior by evidence)": fit("consistent"),
        "consistent `--via fit` (masses ≥ 0, CoM in box)": fit(ConsistentOptions(via="fit")),
        "consistent `--cad-std 0.05`": fit(ConsistentOptions(via="fit", prior_std=0.05)),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--sizes", type=int, nargs="+", default=[38, 1000])
    ap.add_argument("--fraction", type=float, default=0.04, help="added mass / total mass")
    ap.add_argument("--offset", type=float, default=0.03, help="max offset of the masses [m]")
    args = ap.parse_args()
    robot = sescid.load_robot("op2")
    table = methods(robot)
    errors = {name: {n: [] for n in args.sizes} for name in table}
    cad = {n: [] for n in args.sizes}
    tty = sys.stderr.isatty()
    for seed in range(args.seeds):
        r_true = perturbed_sesc(robot, args.fraction, offset=args.offset, seed=seed)
        fresh = simulate(robot, 5000, 30.0, 0.0, 10_000 + seed, r_true=r_true)
        for n in args.sizes:
            sim = simulate(robot, n, 30.0, PAPER_NOISE, seed, r_true=r_true)
            cad[n].append(float(np.sqrt(np.mean((robot.cop(fresh.q) - fresh.cop_true) ** 2))))
            for name, fitter in table.items():
                fit = fitter(sim.q, sim.cop)
                errors[name][n].append(truth_error(fit, fresh.q, fresh.cop_true))
        if tty:
            print(f"\rseed {seed + 1}/{args.seeds}", end="", file=sys.stderr, flush=True)
    if tty:
        print(file=sys.stderr)
    head = " | ".join(f"n = {n}" for n in args.sizes)
    print(f"| method | {head} |")
    print("|---|" + "---|" * len(args.sizes))
    for name in table:
        cells = " | ".join(f"{np.mean(errors[name][n]) * 1e3:.2f}" for n in args.sizes)
        print(f"| {name} | {cells} |")
    cells = " | ".join(f"{np.mean(cad[n]) * 1e3:.2f}" for n in args.sizes)
    print(f"| (CAD model, no fit) | {cells} |")
    print(
        f"\nheld-out noise-free CoP RMS error [mm], mean over {args.seeds} seeds; true robot = "
        f"CAD + {args.fraction:.0%} of the mass at ≤ {args.offset * 1e3:g} mm offsets"
    )
    for n in args.sizes:
        ratio = np.mean(errors["map, τ by evidence"][n]) / np.mean(errors["ls (least squares)"][n])
        print(f"MAP (evidence) / LS at n = {n}: {ratio:.2f}")


if __name__ == "__main__":
    with threadpool_limits(1):
        main()
