"""The paper's §3 simulation study on the embedded OP2, through the Python API.

Run: ``python examples/op2_paper_simulation.py [--count 1000]`` (``sescid demo`` does the same
with figures).
"""

from __future__ import annotations

import argparse

import numpy as np

import sescid
from sescid.study import paper_study

ap = argparse.ArgumentParser()
ap.add_argument("--count", type=int, default=1000)
ap.add_argument("--fresh", type=int, default=20000, help="fresh poses for validation")
args = ap.parse_args()
robot = sescid.load_robot("op2", support="r_sole")
study = paper_study(robot, n=args.count, range_deg=30, noise=0.00493, seed=0, n_fresh=args.fresh)
fit = study.fit
print(robot)
print(sescid.fit_summary(fit))
floor = study.noise_floor_mae
print(f"MAE vs measured CoP   {study.mae * 1e3:.3f} mm (noise floor {floor * 1e3:.3f})")
print(f"RMSE vs true CoP      {study.rmse_fresh * 1e3:.3f} mm on fresh poses "
      f"(theory {study.rmse_fresh_theory * 1e3:.3f})")  # fmt: skip
print("first identifiable combinations:")
for comb in fit.base[:5]:
    print(f"  {comb.label():55s} = {comb.value * 1e3:8.3f} ± {comb.std * 1e3:.3f} mm")
print("first unidentifiable directions:")
for comb in fit.unidentifiable[:3]:
    print(f"  {comb.label()}: {comb.reason}")
q = study.fresh.q[:3]
print("CoM at 3 fresh poses [mm]:\n", np.round(fit.predict_com(q) * 1e3, 2))
print("part of CoM height from the prior [mm]:", np.round(fit.com_z_from_prior(q) * 1e3, 2))
