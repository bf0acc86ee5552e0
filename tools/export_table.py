"""The before/after export table of docs/export.md: one row per (robot, seed).

Run from the repository root with the tree to measure first on PYTHONPATH, e.g.
``PYTHONPATH=src python tools/export_table.py after`` (needs pinocchio, mujoco and
example-robot-data: the dev extra). Columns: exported CoM vs fit.predict_com (mm, max over 100
random poses), Pinocchio holding torques vs fit.predict_torque (max relative), the worst body
mass change (%), the largest change of a body inertia about its CoM (%).
"""

import inspect
import sys
import tempfile
from pathlib import Path

import numpy as np

import sescid
from sescid.estimation.result.validation import perturbed_sesc
from sescid.robots import example_path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "helpers"))
import pinocchio as pin
from mjcf_gen import mujoco_com
from oracle import PinOracle, PinStatics

TALOS = str(
    Path(pin.__file__).parents[4]
    / "share/example-robot-data/robots/talos_data/robots/talos_reduced.urdf"
)
HUM = str(example_path("humanoid"))
tag = sys.argv[1] if len(sys.argv) > 1 else "this tree"


def tensors_urdf(path):
    m = pin.buildModelFromUrdf(str(path), pin.JointModelFreeFlyer())
    return {m.names[i]: (inert.mass, inert.inertia.copy()) for i, inert in enumerate(m.inertias)}


def run(path, support, seed, fraction, noise):
    robot = sescid.load_robot(path, support=support)
    sim = sescid.simulate(
        robot,
        300,
        r_true=perturbed_sesc(robot, fraction, seed=seed),
        seed=2,
        stable=True,
        noise=noise,
    )
    fit = sescid.identify(robot, sim.q, sim.cop)
    cons = sescid.to_consistent(fit)
    out = Path(tempfile.mkdtemp()) / ("x.urdf" if path.endswith(".urdf") else "x.xml")
    kw = (
        {"repair_inertia": True}
        if "repair_inertia" in inspect.signature(sescid.export_model).parameters
        else {}
    )
    sescid.export_model(cons, out, **kw)
    rng = np.random.default_rng(7)
    lo, hi = robot.joint_limits.T
    q = rng.uniform(np.maximum(lo, -1.5), np.minimum(hi, 1.5), (100, robot.nq))
    want = fit.predict_com(q)
    if path.endswith(".urdf"):
        com = PinOracle(out, support, robot.joint_names).com(q)
        tau = PinStatics(out, support, robot.joint_names, fit.gravity_accel).torques(q[:20])
        tw = fit.predict_torque(q[:20])
        trel = np.abs(tau - tw).max() / np.abs(tw).max()
    else:
        com = mujoco_com(out, support, robot.joint_names, q)
        trel = float("nan")
    dcom = np.abs(com - want).max() * 1e3
    m, mc = cons.inertials.masses, robot.masses
    ok = mc > 0
    worst = np.max(np.abs(m[ok] / mc[ok] - 1)) * 100
    # inertia about the CoM vs CAD, per link with mass in both, and consistency
    if path.endswith(".urdf"):
        a, b = tensors_urdf(path), tensors_urdf(out)
        pairs = [(a[k][1], b[k][1]) for k in a if a[k][0] > 0 and k in b]
    else:
        import mujoco

        a, b = mujoco.MjModel.from_xml_path(path), mujoco.MjModel.from_xml_path(str(out))
        pairs = [
            (np.diag(a.body_inertia[i]), np.diag(b.body_inertia[i]))
            for i in range(1, a.nbody)
            if a.body_mass[i] > 0
        ]
    dI = (
        max(np.linalg.norm(y - x) / np.linalg.norm(x) for x, y in pairs if np.linalg.norm(x) > 0)
        * 100
    )
    row = (
        f"| {tag} | {Path(path).stem} | {seed} | {dcom:.3g} | {trel:.2g} | {worst:.1f} | {dI:.0f} |"
    )
    print(row, flush=True)


if __name__ == "__main__":
    for seed in (1, 2, 3):
        run(TALOS, "right_sole_link", seed, 0.04, 0.00493)
    for seed in (1, 2, 3):
        run(HUM, "r_sole", seed, 0.15, 1e-3)
