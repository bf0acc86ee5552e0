"""A guided session's files: the same as the step-by-step path, plus its decisions.

``poses.csv`` (every commanded pose in order: ``pose``, joints in rad, ``_deg``, ``_ticks``,
model ``cop_x``/``cop_y``; what ``sescid poses`` writes), ``raw.csv`` (the raw log, as
``sescid experiment``/a robot writes it), ``measured.csv`` (as ``sescid fsr``), ``fit.json`` (as
``sescid identify --weighted``, with the online record) and ``session.json`` (each step's
decision, status, reason and predicted CoP std, and why the session stopped). Over stances:
``poses.csv``, ``measured.csv`` and ``raw.csv`` carry each pose's ``support``, ``fit.json`` is
the pooled fit (``identify --weighted`` of ``measured.csv``) and ``session.json`` adds the
session's own pooled estimate of the body parameters.
"""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import numpy as np

from sescid.base.files import atomic_open, read_json
from sescid.estimation.result.fit_json import save_fit
from sescid.io.pose_table import pose_table
from sescid.robot import Robot
from sescid.tables import write_table

SESSION_FORMAT = "sescid-session/1"
#: file names inside a session's output folder
SESSION_FILES = ("poses.csv", "raw.csv", "measured.csv", "fit.json", "session.json")


def _num(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


def session_paths(out_dir: str | Path) -> dict[str, Path]:
    """Name → path of each file a session writes into ``out_dir``."""
    out = Path(out_dir)
    return {n.split(".")[0]: out / n for n in SESSION_FILES}


def read_session_reasons(folder: Path) -> dict[str, str]:
    """Pose → why it failed, from a session folder's ``session.json`` ({} when absent)."""
    path = Path(folder) / "session.json"
    if not path.is_file():
        return {}
    doc = read_json(path, SESSION_FORMAT, "a session record")
    return {str(s["pose"]): str(s["reason"]) for s in doc.get("steps", []) if s.get("reason")}


def write_session(result, robot: Robot, out_dir: str | Path) -> dict[str, Path]:
    """Write the session's five files into ``out_dir`` (atomically); their paths."""
    paths = session_paths(out_dir)
    Path(out_dir).mkdir(parents=True, exist_ok=True)
    names = robot.joint_names
    q = result.poses
    stance = {s.pose: s.stance for s in result.steps}
    support = None
    if result.stances:  # over stances: each pose's stance, its model CoP in that frame
        support = np.array([stance[p] for p in result.pose_ids])
    cop = robot.cop(q) if support is None else _stance_cops(robot, result, support)
    cols = pose_table(robot, q, pose=result.pose_ids, support=support, cop=cop).columns
    write_table(paths["poses"], cols)
    write_table(paths["raw"], result.raw)
    measured = result.measured.columns(names)
    if result.stances:
        measured = (
            {"pose": measured["pose"]}
            | {"support": np.array([stance[str(p)] for p in measured["pose"]])}
            | measured
        )
    write_table(paths["measured"], measured)
    save_fit(result.fit, paths["fit"])
    doc = {
        "format": SESSION_FORMAT,
        "units": "m, rad",
        "robot": robot.source,
        "support": robot.support,
        "options": {
            k: (v.tolist() if isinstance(v, np.ndarray) else v)
            for k, v in dataclasses.asdict(result.options).items()
        },
        "candidates": result.candidates.summary(),
        "stop_reason": result.stop_reason,
        "n_commanded": len(result.steps),
        "n_measured": result.n_measured,
        "cop_std_m": _num(result.cop_std),
        "stances": [s.label for s in result.stances],
        "pooled": None if result.pooled is None else _pooled(result),
        "steps": [
            {
                "pose": s.pose,
                "candidate": s.candidate,
                "status": s.status,
                "reason": s.reason,
                "gain": _num(s.gain),
                "distance_rad": s.distance,
                "cop_std_m": _num(s.cop_std),
                "rank": s.rank,
                "converged": s.converged,
                "stance": s.stance,
            }
            for s in result.steps
        ],
        "rejected_before_command": [
            {"candidate": int(i), "reason": why} for i, why in result.rejected
        ],
    }
    with atomic_open(paths["session"], "w") as fh:
        json.dump(doc, fh, indent=1)
        fh.write("\n")
    return paths


def _stance_cops(robot: Robot, result, labels: np.ndarray) -> np.ndarray:
    """(k, 2) each commanded pose's model CoP [m] in its stance's frame (nan: held)."""
    out = np.full((len(labels), 2), np.nan)
    for st in result.stances:
        rows = labels == st.label
        if rows.any() and st.mount != "gantry":
            rb = robot if st.mount == "double" else robot.at(st.support)
            out[rows] = rb.cop(result.poses[rows])
    return out


def _pooled(result) -> dict:
    """The pooled body parameters of a session over stances, per body (reference frames)."""
    theta, sd = result.pooled
    n = len(result.body_names)
    return {
        "units": "kg, kg·m (first moments in each body's frame of the reference robot)",
        "bodies": [
            {
                "body": name,
                "mass": float(theta[i]),
                "mass_sd": float(sd[i]),
                "first_moment": theta[n + 3 * i : n + 3 * i + 3].tolist(),
                "first_moment_sd": sd[n + 3 * i : n + 3 * i + 3].tolist(),
            }
            for i, name in enumerate(result.body_names)
        ],
    }
