"""The user-facing robot: a model file re-rooted at its support frame, with its profile, CoM,
CoP and SESC helpers.

``Robot`` sits above ``model``, ``kinematics`` and ``sesc`` (it is their facade), below everything
that uses a robot.
"""

from __future__ import annotations

from dataclasses import replace
from functools import cached_property
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike

from sescid import kinematics, sesc
from sescid.base import G0
from sescid.errors import ModelError, SescidError
from sescid.model import RobotModel, Shape, load_model
from sescid.model.meshes import UnloadedMesh, with_mesh_vertices
from sescid.model.sole import Sole
from sescid.robots import EMBEDDED, EXAMPLES, RobotProfile, generic_profile, profile_for

__all__ = ["DOUBLE", "Robot", "line_direction", "load_robot"]

#: the stance of a robot on both feet: the CoP of the whole robot in its support foot's frame
DOUBLE = "double"


class Robot:
    """A kinematic tree of rigid bodies rooted at a support frame (e.g. a sole).

    Joint angles ``q`` are arrays shaped ``(n, nq)`` in radians, columns in ``joint_names`` order.
    Everything returned is in the support frame (x forward, y left, z up for a sole), metres.
    """

    def __init__(
        self,
        model: RobotModel,
        source: str,
        profile: RobotProfile | None = None,
        line: ArrayLike | None = None,
    ):
        self.model = model
        #: what ``load_robot`` was given: an embedded name (``"op2"``) or a model file path
        self.source = source
        #: robot-specific facts (sole, servo, sensors, …); generic for an arbitrary model file
        self.profile = profile or generic_profile(model.name)
        self.tree = kinematics.Tree.from_model(model)
        if line is None:
            line = self.profile.support_lines.get(model.support)
        #: (3,) unit direction of the support line (a wheel axle, an edge) through the support
        #: frame's origin, in that frame; None for a support that is a sole or a held link
        self.line = None if line is None else line_direction(line, f"{model.path.name}: line")

    # --- description -------------------------------------------------------------------
    @property
    def name(self) -> str:
        """The model's name."""
        return self.model.name

    @property
    def model_path(self) -> Path:
        """The model file (URDF or MJCF)."""
        return self.model.path

    @property
    def support(self) -> str:
        """The support frame (sole link, foot link or site) the tree is rooted at."""
        return self.model.support

    @property
    def joint_names(self) -> list[str]:
        """Independent joints, in the column order of q."""
        return list(self.model.joint_names)

    @property
    def nq(self) -> int:
        """Number of independent joints (columns of q)."""
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
        """Kg."""
        return float(self.masses.sum())

    @property
    def d(self) -> np.ndarray:
        """(3,) constant term of CoM = d + Σ B_i r_i: the support body's origin, m."""
        return self.tree.root_o.copy()

    def __repr__(self) -> str:
        line = "" if self.line is None else f", line={self.line.round(6).tolist()}"
        return (
            f"Robot({self.name!r}, support={self.support!r}{line}, {self.nq} joints, "
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

    def regressor(self, q: ArrayLike, rows: tuple[int, ...] = (0, 1)) -> np.ndarray:
        """Φ(q) shaped (n, len(rows), 3N): CoM[rows] = d[rows] + Φ · vec(r)."""
        return kinematics.regressor(self.tree, q, rows)

    def com(self, q: ArrayLike, r: np.ndarray | None = None) -> np.ndarray:
        """Whole-body CoM (n, 3) in m; ``r`` overrides the model's SESC vectors."""
        return sesc.com_from_sesc(self.tree, q, self._r if r is None else r, (0, 1, 2))

    def cop(
        self, q: ArrayLike, r: np.ndarray | None = None, gravity: ArrayLike | None = None
    ) -> np.ndarray:
        """Static CoP (n, 2) in m: the CoM projected along gravity (n, 3; None: −z) onto z = 0."""
        rr = self._r if r is None else r
        if gravity is None:
            return sesc.com_from_sesc(self.tree, q, rr, (0, 1))
        com = sesc.com_from_sesc(self.tree, q, rr, (0, 1, 2))
        return sesc.tilted_cop(com, sesc.gravity_ratios(gravity, com.shape[0]))

    def regressor_tilted(self, q: ArrayLike, gravity: ArrayLike) -> np.ndarray:
        """Φ (n, 2, 3N) with CoP = d_xy − d_z g_xy/g_z + Φ·vec(r) under gravity (n, 3)."""
        phi = self.regressor(q, (0, 1, 2))
        t = sesc.gravity_ratios(gravity, phi.shape[0])
        return phi[:, :2] - t[:, :, None] * phi[:, 2:3]

    def d_tilted(self, gravity: ArrayLike, n: int) -> np.ndarray:
        """Constant term (n, 2) of the tilted CoP: d_xy − d_z g_xy / g_z."""
        return self.d[:2] - self.d[2] * sesc.gravity_ratios(gravity, n)

    def joint_columns(self, joints: list[str] | tuple[str, ...] | None = None) -> np.ndarray:
        """(J,) q columns of the named joints (all joints when None); ModelError for a name
        that is not one of ``joint_names``."""
        if joints is None:
            return np.arange(self.nq)
        index = {name: k for k, name in enumerate(self.model.joint_names)}
        missing = [j for j in joints if j not in index]
        if missing:
            raise ModelError(
                f"{self.model_path.name}: no joint named {', '.join(map(repr, missing))} "
                f"(joints: {', '.join(self.joint_names)})"
            )
        return np.array([index[j] for j in joints], dtype=np.int64)

    def torque_regressor(
        self,
        q: ArrayLike,
        joints=None,
        gravity: ArrayLike | None = None,
        g0: float = G0,
    ) -> np.ndarray:
        """Φ_τ (n, J, 3N) [m/s²]: holding torques τ = M · Φ_τ · vec(r) [N·m] of ``joints``
        (names; None: all) with the support link fixed, gravity (n, 3) directions (None: level)
        of magnitude g0 [m/s²]."""
        return sesc.torque_regressor(self.tree, q, self.joint_columns(joints), gravity, g0)

    def torques(
        self,
        q: ArrayLike,
        r: np.ndarray | None = None,
        *,
        joints=None,
        gravity: ArrayLike | None = None,
        total_mass: float | None = None,
        g0: float = G0,
    ) -> np.ndarray:
        """Holding torques (n, J) [N·m] of ``joints`` (None: all) with the support link fixed:
        each balances the gravity moment of the bodies beyond its joint. ``r`` and
        ``total_mass`` override the model's SESC vectors and mass; ``g0`` is |g| [m/s²]."""
        rr = self._r if r is None else r
        mass = self.total_mass if total_mass is None else float(total_mass)
        cols = self.joint_columns(joints)
        return sesc.torques(self.tree, q, rr, mass, cols, gravity, g0)

    # --- stances: the same robot rooted elsewhere ----------------------------------------
    def at(self, support: str, line: ArrayLike | str | None = None) -> Robot:
        """The same model and profile rooted at another support frame (a stance: the other
        foot, a held link, a line); ``line`` as in ``load_robot``."""
        if support == self.support and line is None:
            return self
        key = self.source if self.source in EMBEDDED else self.model_path
        return load_robot(key, support, line)

    def stance(self, support: str | None) -> Robot:
        """The robot of a stance's label (``sescid.stance.Stance.label``): itself for None,
        its own support or "double" (both feet, the CoP in this support's frame), else this
        model rooted at that frame (kept for the next call); ModelError naming an unknown
        frame."""
        if support is None or support == self.support or support == DOUBLE:
            return self
        cache = self.__dict__.setdefault("_stances", {})
        if support not in cache:
            if support not in self.model.link_frames:
                raise ModelError(
                    f"{self.model_path.name}: unknown support '{support}' (a stance is a frame "
                    f"of the model, or '{DOUBLE}' for both feet)"
                )
            cache[support] = self.at(support, self.profile.support_lines.get(support))
        return cache[support]

    def body_parameters(self) -> np.ndarray:
        """θ (4N,) = [m (N) kg; vec(m c) (3N) kg·m]: each body's mass and first moment about
        its frame's origin, in its frame (the parameters every stance shares)."""
        bodies = self.model.bodies
        first = np.array([b.mass * b.com for b in bodies]).reshape(-1)
        return np.concatenate([[b.mass for b in bodies], first])

    def sesc_matrix(self, reference: Robot | None = None) -> np.ndarray:
        """E (3N, 4N) with vec(r) = E θ / M: this support's SESC vectors from the body
        parameters θ of ``reference`` (the same model rooted elsewhere: its bodies, its body
        frames; default this robot), M = Σ m. Bodies are matched by the model links they
        hold; ModelError when the two are not the same model."""
        from sescid.model.tree import inv_transform

        ref = reference or self
        mine, theirs = self.model.bodies, ref.model.bodies
        n = len(mine)
        where = {lk: j for j, b in enumerate(theirs) for lk in b.links}
        if len(theirs) != n or any(b.links[0] not in where for b in mine):
            raise ModelError(
                f"{self.model_path.name}: the stances '{self.support}' and '{ref.support}' are "
                "not the same model (different bodies)"
            )
        p = np.zeros((4 * n, 4 * n))  # own-frame parameters from the reference's
        for i, b in enumerate(mine):
            link = b.links[0]
            j = where[link]
            x = self.model.link_frames[link][1] @ inv_transform(ref.model.link_frames[link][1])
            p[i, j] = 1.0
            p[n + 3 * i : n + 3 * i + 3, j] = x[:3, 3]
            p[n + 3 * i : n + 3 * i + 3, n + 3 * j : n + 3 * j + 3] = x[:3, :3]
        return sesc.sesc_matrix(self.model) @ p

    # --- geometry and soles (lazy; see sescid.model.sole) ---------------------------------
    @cached_property
    def _geometry(self) -> tuple[list[Shape], list[str], list[UnloadedMesh]]:
        if self.model.format == "urdf":
            return with_mesh_vertices(self.model.shapes, self.model.path)
        return list(self.model.shapes), [], []

    @property
    def shapes(self) -> list[Shape]:
        """The model's shapes with mesh vertices loaded where the files resolve (body frames)."""
        return self._geometry[0]

    @property
    def geometry_notes(self) -> list[str]:
        """What could not be loaded of the shapes (missing or unreadable mesh files)."""
        return list(self._geometry[1])

    @property
    def unloaded_meshes(self) -> list[UnloadedMesh]:
        """The mesh files the model names that could not be found or read: their shapes are
        missing from ``shapes``."""
        return list(self._geometry[2])

    @cached_property
    def sole(self) -> Sole | None:
        """The support foot's sole: the profile's sole size around the support frame, else
        derived from the support body's lowest geometry; None when neither exists."""
        from sescid.model.sole import derive_sole, profile_sole

        b, x = self.model.link_frames[self.support]
        size = self.profile.sole_size
        soles = set(self.profile.free_sole) | set(self.profile.free_sole.values())
        if size is not None and (self.support in soles or not soles):  # the profile's soles only
            return profile_sole(self.support, b, x, size, f"sole {size[0]} x {size[1]} m (profile)")
        return derive_sole(
            self.support, b, self.shapes, self.model.root_rotation, self.model.root_origin, 0.0
        )

    @cached_property
    def free_sole(self) -> Sole | None:
        """The other foot's sole: the profile's free sole, else the foot found from the tree and
        the geometry (``model.sole.free_foot``), derived from its geometry; None if unknown."""
        from sescid.model.sole import derive_sole, free_foot, point_sole, profile_sole

        link = self.profile.free_sole.get(self.support)
        rot, org = self.forward(np.zeros((1, self.nq)))
        if link is not None and link in self.model.link_frames:
            b, x = self.model.link_frames[link]
            size = self.profile.sole_size
            if size is not None:
                return profile_sole(link, b, x, size, f"free sole {link} (profile)")
            frame_z = float(org[0, b, 2] + rot[0, b, 2] @ x[:3, 3])
            return derive_sole(link, b, self.shapes, rot[0, b], org[0, b], frame_z)
        parents = [bd.parent for bd in self.model.bodies]
        b, how = free_foot(parents, self.masses, self.shapes, (rot[0], org[0]), self.floor)
        if b is None:
            return None
        name = self.body_names[b]
        sole = derive_sole(name, b, self.shapes, rot[0, b], org[0, b])
        if sole is None:
            return point_sole(name, b, np.zeros(3), f"free foot '{name}' ({how}): its origin")
        return replace(sole, note=f"free foot '{name}' ({how}); {sole.note}")

    def check_support_level(self) -> None:
        """ModelError unless the support frame's z is along the normal of the support foot's
        sole (``model.sole.level_check``) and the zero-pose CoM lies above that sole."""
        from sescid.model.sole import LEVEL_SHARE, level_check

        b, x = self.model.link_frames[self.support]
        frames = {n: f for n, (bb, f) in self.model.link_frames.items() if bb == b}
        chk = level_check(self.shapes, b, x, frames)
        above = float(self.com(np.zeros(self.nq))[0, 2]) > self.floor
        if chk.level and above:
            return
        good = [f for f in chk.frames if f != self.support]
        fix = f"one of: {', '.join(good[:4])}" if good else "none on that body is: add a sole frame"
        why = (
            f"the foot's lowest face under its z axis covers {chk.share:.0%} of its sole "
            f"(level: at least {LEVEL_SHARE:.0%}); the sole's normal is along its {chk.up} axis"
            if not chk.level
            else "the robot's centre of mass lies below the sole at the zero pose"
        )
        raise ModelError(
            f"{self.model_path.name}: support frame '{self.support}' is not level ({why}): "
            f"give --support a sole frame, z along the sole's normal pointing up ({fix})"
        )

    @property
    def floor(self) -> float:
        """Height of the floor in the support frame [m] (0 for a sole frame)."""
        if self.sole is None:
            return 0.0
        return float((self.model.root_rotation @ self.sole.centre + self.model.root_origin)[2])

    @property
    def sole_centre(self) -> np.ndarray:
        """(2,) x/y of the support sole's centre in the support frame [m] (0 without a sole)."""
        if self.sole is None:
            return np.zeros(2)
        return (self.model.root_rotation @ self.sole.centre + self.model.root_origin)[:2]

    # --- kinematics -----------------------------------------------------------------------
    def forward(self, q: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """Body rotations (n, N, 3, 3) and origins (n, N, 3) [m] in the support frame."""
        return kinematics.forward(self.tree, q)

    def link_poses(self, q: ArrayLike, link: str) -> tuple[np.ndarray, np.ndarray]:
        """Rotation (n, 3, 3) and position (n, 3) [m] of a URDF link's frame."""
        if link not in self.model.link_frames:
            raise ModelError(f"unknown link '{link}' in {self.model_path.name}")
        b, x = self.model.link_frames[link]
        rot, org = self.forward(q)
        rb, ob = rot[:, b], org[:, b]
        return rb @ x[:3, :3], ob + rb @ x[:3, 3]


def line_direction(line: ArrayLike | str, what: str = "line") -> np.ndarray:
    """A support line's unit direction (3,) from an axis name ("x", "-y", …) or 3 numbers
    (a string "ax,ay,az" or an array); ModelError for anything else."""
    axes = {"x": (1.0, 0.0, 0.0), "y": (0.0, 1.0, 0.0), "z": (0.0, 0.0, 1.0)}
    if isinstance(line, str):
        text = line.strip().lower()
        sign = -1.0 if text.startswith("-") else 1.0
        if text.lstrip("+-") in axes:
            return sign * np.array(axes[text.lstrip("+-")])
        try:
            line = [float(v) for v in text.split(",")]
        except ValueError:
            raise ModelError(
                f"{what}: {line!r} is not a direction (x, y, z, -y, … or ax,ay,az)"
            ) from None
    v = np.asarray(line, dtype=float).reshape(-1)
    norm = float(np.linalg.norm(v)) if v.shape == (3,) and np.all(np.isfinite(v)) else 0.0
    if norm < 1e-9:
        raise ModelError(f"{what}: a direction needs 3 finite numbers, not all 0 (got {line!r})")
    return v / norm


def load_robot(
    name_or_path: str | Path = "op2",
    support: str | None = None,
    line: ArrayLike | str | None = None,
) -> Robot:
    """Load an embedded robot (``"op2"``), an example model shipped with the package
    (``"wheeled_humanoid"``, ``"humanoid"``: ``sescid.robots.EXAMPLES``) or any URDF/MJCF file,
    rooted at the frame ``support``.

    ``support`` defaults to the profile's (``r_sole`` for the OP2) and is required for other
    model files. Fixed-joint links are merged into their parents (their mass counts); revolute,
    continuous and mimic joints are supported; prismatic and planar joints raise ModelError.
    ``line``: the robot balances on a line through the support frame's origin (a wheel axle, an
    edge) with this direction in the support frame ("x", "-y", "ax,ay,az" or 3 numbers); None:
    the profile's line for this support, if any (else a sole or a held link).
    """
    key = str(name_or_path)
    if key in EMBEDDED:
        profile = profile_for(key)
        assert profile.model_file is not None
        model = load_model(profile.model_file, support or profile.support or "")
        return Robot(model, key, profile, line)
    path = EXAMPLES.get(key, Path(key))  # an example model shipped with the package, by name
    if path.suffix.lower() in (".urdf", ".xml", ".mjcf") and not path.is_file():
        kind = "URDF" if path.suffix.lower() == ".urdf" else "model"
        raise ModelError(f"{path}: {kind} file not found")
    if path.suffix.lower() not in (".urdf", ".xml", ".mjcf") and not path.exists():
        raise ModelError(
            f"unknown robot '{key}': give an embedded name ({', '.join(EMBEDDED)}), an example "
            f"model's ({', '.join(EXAMPLES)}) or a URDF/MJCF file"
        )
    if support is None:
        raise ModelError(
            f"{path}: name the support frame (--support: a sole link, foot link or site)"
            + _feet_hint(path)
        )
    return Robot(load_model(path, support), str(path.resolve()), line=line)


def _feet_hint(path: Path) -> str:
    """'; feet found …: a, b' naming the model's support candidates ('' when none are found or
    the model cannot be read: its own error comes with loading it)."""
    from sescid.model.feet import support_candidates

    try:
        feet = support_candidates(path)
    except SescidError:
        return ""
    if not feet:
        return ""
    return "; feet found from the tree and the geometry: " + ", ".join(f.support for f in feet)
