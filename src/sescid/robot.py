"""The user-facing robot: a URDF re-rooted at its support frame, with CoM and SESC helpers."""

from __future__ import annotations

from functools import cached_property
from pathlib import Path

import numpy as np

from . import kinematics, sesc
from .errors import SescidError
from .model import RobotModel, build_model
from .robots import EMBEDDED, embedded_path


class Robot:
    """A kinematic tree of rigid bodies rooted at a support frame (e.g. a sole).

    Joint angles ``q`` are arrays shaped ``(n, nq)`` in radians, columns in ``joint_names`` order.
    Everything returned is in the support frame (x forward, y left, z up for a sole), metres.
    """

    def __init__(self, model: RobotModel, source: str):
        self.model = model
        #: what ``load_robot`` was given: an embedded name (``"op2"``) or a URDF path
        self.source = source
        self.tree = kinematics.Tree.from_model(model)

    # --- description -------------------------------------------------------------------
    @property
    def name(self) -> str:
        return self.model.name

    @property
    def urdf_path(self) -> Path:
        return self.model.urdf_path

    @property
    def support(self) -> str:
        return self.model.support

    @property
    def joint_names(self) -> list[str]:
        """Independent joints, in the column order of q."""
        return list(self.model.joint_names)

    @property
    def nq(self) -> int:
        return len(self.model.joint_names)

    @property
    def joint_limits(self) -> np.ndarray:
        """(nq, 2) lower/upper limits in rad (±inf for continuous joints)."""
        return self.model.joint_limits.copy()

    @property
    def body_names(self) -> list[str]:
        """Bodies (fixed links merged), named by their main URDF link; index 0 = support body."""
        return [b.name for b in self.model.bodies]

    @property
    def masses(self) -> np.ndarray:
        """(N,) body masses in kg."""
        return np.array([b.mass for b in self.model.bodies])

    @property
    def total_mass(self) -> float:
        """kg."""
        return float(self.masses.sum())

    @property
    def d(self) -> np.ndarray:
        """(3,) constant term of CoM = d + Σ B_i r_i: the support body's origin, m."""
        return self.tree.root_o.copy()

    def __repr__(self) -> str:
        return (
            f"Robot({self.name!r}, support={self.support!r}, {self.nq} joints, "
            f"{len(self.body_names)} bodies, {self.total_mass:.4f} kg)"
        )

    # --- SESC ---------------------------------------------------------------------------
    @cached_property
    def _r(self) -> np.ndarray:
        return sesc.sesc_vectors(self.model)

    @cached_property
    def reduction(self) -> kinematics.Reduction:
        """Reduced x/y regressor coordinates (see ``kinematics.reduction``)."""
        return kinematics.reduction(self.tree, np.array([b.axis for b in self.model.bodies]))

    def sesc_vectors(self) -> np.ndarray:
        """(N, 3) SESC vectors r_i of this model (m), each in its body's frame."""
        return self._r.copy()

    def regressor(self, q, rows=(0, 1)) -> np.ndarray:
        """Φ(q) shaped (n, len(rows), 3N): CoM[rows] = d[rows] + Φ · vec(r)."""
        return kinematics.regressor(self.tree, q, rows)

    def com(self, q, r: np.ndarray | None = None) -> np.ndarray:
        """Whole-body CoM (n, 3) in m; ``r`` overrides the model's SESC vectors."""
        return sesc.com_from_sesc(self.tree, q, self._r if r is None else r, (0, 1, 2))

    def cop(self, q, r: np.ndarray | None = None) -> np.ndarray:
        """Static CoP (n, 2) in m: the ground projection of the CoM."""
        return sesc.com_from_sesc(self.tree, q, self._r if r is None else r, (0, 1))

    # --- kinematics -----------------------------------------------------------------------
    def forward(self, q) -> tuple[np.ndarray, np.ndarray]:
        """Body rotations (n, N, 3, 3) and origins (n, N, 3) [m] in the support frame."""
        return kinematics.forward(self.tree, q)

    def link_poses(self, q, link: str) -> tuple[np.ndarray, np.ndarray]:
        """Rotation (n, 3, 3) and position (n, 3) [m] of a URDF link's frame."""
        if link not in self.model.link_frames:
            raise SescidError(f"unknown link '{link}' in {self.urdf_path.name}")
        b, x = self.model.link_frames[link]
        rot, org = self.forward(q)
        rb, ob = rot[:, b], org[:, b]
        return rb @ x[:3, :3], ob + rb @ x[:3, 3]


def load_robot(name_or_path: str | Path = "op2", support: str | None = None) -> Robot:
    """Load the embedded model (``"op2"``) or any URDF, rooted at the link ``support``.

    ``support`` defaults to ``r_sole`` for the embedded OP2 and is required for other URDFs.
    Fixed-joint links are merged into their parents (their mass counts); revolute, continuous
    and mimic joints are supported; prismatic, floating and planar joints raise SescidError.
    """
    key = str(name_or_path)
    if key in EMBEDDED:
        path = embedded_path(key)
        support = support or EMBEDDED[key][1]
    else:
        path = Path(key)
        if path.suffix.lower() not in (".urdf", ".xml") and not path.exists():
            raise SescidError(
                f"unknown robot '{key}': give an embedded name ({', '.join(EMBEDDED)}) "
                "or a URDF file"
            )
        if support is None:
            raise SescidError(f"{path}: name the support link (e.g. --support r_sole)")
    return Robot(build_model(path, support), key if key in EMBEDDED else str(path.resolve()))
