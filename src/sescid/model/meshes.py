"""Mesh files of a URDF's shapes: resolve ``package://`` (the model's own package folders, then
``ROS_PACKAGE_PATH``), ``file://`` and relative paths, and load the vertices (in the body frame)
on demand: STL files (binary or ASCII) with numpy, their distinct vertices; other formats with
trimesh, their convex hull's vertices. Collada files are turned to Z up from their
``<asset><up_axis>`` (trimesh and pycollada return the file's coordinates as written, and so
does Pinocchio's Assimp loader: iCub's Y-up legs would stick out sideways). Either set has the
hull's vertices, so the lowest point in any direction is exact.

Loading is lazy (``with_mesh_vertices`` is called by the robot when a consumer needs geometry:
the sole, ground clearance, self-collision); a visual mesh is loaded only on a body without
collision shapes (nothing else uses it). A mesh that cannot be found or read keeps
``vertices=None`` and is named in the returned notes (with how to resolve ``package://``); a
mesh that needs the ``meshes`` extra (trimesh, and pycollada for Collada) raises
``MissingExtraError``: a floor check without the geometry would pass poses through the floor.
MJCF shapes carry MuJoCo's compiled vertices already and pass through unchanged.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass, replace
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from sescid.errors import MissingExtraError
from sescid.model.geometry import MESH, Shape


def resolve_mesh(filename: str, model_path: Path) -> Path | None:
    """The file a mesh name refers to, or None when it does not exist.

    ``package://PKG/rest``: the first ancestor directory of the model file named PKG, or holding
    a directory PKG, that contains ``rest``; else the package PKG on ``ROS_PACKAGE_PATH``
    (``ros_package``); ``file://`` and absolute paths as they are; other names relative to the
    model file's directory.
    """
    if not filename:
        return None
    if filename.startswith(PACKAGE):
        pkg, _, rest = filename[len(PACKAGE) :].partition("/")
        for d in Path(model_path).resolve().parents:
            for cand in (d / rest if d.name == pkg else None, d / pkg / rest):
                if cand is not None and cand.is_file():
                    return cand
        root = ros_package(pkg)
        return root / rest if root is not None and (root / rest).is_file() else None
    name = filename[len("file://") :] if filename.startswith("file://") else filename
    p = Path(name)
    if not p.is_absolute():
        p = Path(model_path).resolve().parent / p
    return p if p.is_file() else None


#: the URI scheme of a mesh inside a ROS package
PACKAGE = "package://"
#: directories below a ``ROS_PACKAGE_PATH`` root searched for a package's ``package.xml``
ROS_DEPTH = 4


def ros_package(pkg: str) -> Path | None:
    """The folder of ROS package ``pkg`` on ``ROS_PACKAGE_PATH`` (roots separated by
    ``os.pathsep``), as ROS finds it: a root that is the package, ``ROOT/PKG``, or a folder
    below a root (at most ``ROS_DEPTH`` deep) whose ``package.xml`` names it; None if none."""
    env = os.environ.get("ROS_PACKAGE_PATH", "")
    return _ros_packages(env).get(pkg) if env else None


@lru_cache(maxsize=8)
def _ros_packages(env: str) -> dict[str, Path]:
    """Package name → folder for the roots of ``env`` (the first root to hold a name wins)."""
    out: dict[str, Path] = {}
    for root in (Path(r).expanduser() for r in env.split(os.pathsep) if r):
        if not root.is_dir():
            continue
        found: dict[str, Path] = {}
        for d, dirs, files in os.walk(root):
            here = Path(d)
            depth = len(here.relative_to(root).parts)
            if "package.xml" in files:
                found.setdefault(_package_name(here / "package.xml") or here.name, here)
            if depth <= 1:  # the root itself, or ROOT/PKG, by its folder's name
                found.setdefault(here.name, here)
            if "package.xml" in files or depth >= ROS_DEPTH:
                dirs[:] = []  # ROS does not look inside a package for others
            else:
                dirs[:] = sorted(x for x in dirs if not x.startswith("."))
        for name, where in found.items():
            out.setdefault(name, where)
    return out


def _package_name(path: Path) -> str | None:
    """The ``<name>`` of a ROS ``package.xml`` (None when unreadable or without one)."""
    try:
        m = re.search(r"<name>\s*([^<\s]+)\s*</name>", path.read_text(errors="replace"))
    except OSError:
        return None
    return m.group(1) if m else None


def _stl_vertices(path: str) -> np.ndarray | None:
    """(k, 3) distinct vertices of an STL file (binary or ASCII), None if it is neither."""
    data = Path(path).read_bytes()
    if len(data) >= 84:
        n = int(np.frombuffer(data, "<u4", 1, 80)[0])
        if len(data) == 84 + 50 * n:
            rec = np.dtype([("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")])
            return np.frombuffer(data, rec, n, 84)["v"].reshape(-1, 3).astype(np.float64)
    text = data.decode("ascii", errors="replace")
    if not text.lstrip().startswith("solid"):
        return None
    nums = re.findall(r"vertex\s+(\S+)\s+(\S+)\s+(\S+)", text)
    try:
        return np.array(nums, dtype=np.float64).reshape(-1, 3)
    except ValueError:
        return None


def _distinct_rows(v: np.ndarray) -> np.ndarray:
    """``np.unique(v, axis=0)`` for finite (k, 3) rows — sorted by x, then y, then z, each row
    once — by one stable sort on the three columns (4× faster: an STL repeats every vertex in
    about six triangles, and G1's 51 files hold 1.5·10⁶)."""
    s = v[np.lexsort((v[:, 2], v[:, 1], v[:, 0]))]
    first = np.ones(len(s), dtype=bool)
    first[1:] = np.any(s[1:] != s[:-1], axis=1)
    return s[first]


@lru_cache(maxsize=512)
def _hull_vertices(path: str) -> np.ndarray | None:
    """(k, 3) vertices of a mesh file in its own frame, at least its convex hull's (None if
    unreadable): an STL's distinct vertices, else trimesh's convex hull."""
    if path.lower().endswith(".stl"):
        try:
            verts = _stl_vertices(path)
        except OSError:
            return None
        if verts is not None and len(verts) and np.all(np.isfinite(verts)):
            return _distinct_rows(verts)
    try:
        import trimesh  # lazy: only needed for mesh geometry
    except ImportError:
        raise MissingExtraError(f"reading mesh files ({Path(path).name})", "meshes") from None
    if path.lower().endswith(".dae"):
        try:
            import collada  # noqa: F401 - trimesh reads Collada through pycollada
        except ImportError:
            what = f"reading Collada meshes ({Path(path).name})"
            raise MissingExtraError(what, "meshes") from None

    try:
        mesh: Any = trimesh.load(path, force="mesh", process=False)
        verts = np.asarray(mesh.vertices, dtype=np.float64)
        if len(verts) >= 4:
            try:
                verts = np.asarray(mesh.convex_hull.vertices, dtype=np.float64)
            except Exception:  # noqa: BLE001 - degenerate meshes: keep all vertices
                pass
    except Exception:  # noqa: BLE001 - any reader failure is reported as "not loaded"
        return None
    if not (len(verts) and np.all(np.isfinite(verts))):
        return None
    if path.lower().endswith(".dae"):
        verts = verts @ _collada_up(path).T
    return verts


#: Collada up axis → Z up, from the axes the COLLADA spec gives each (right, up, in): Y_UP
#: (+x, +y, +z), X_UP (−y, +x, +z), Z_UP (+x, +z, −y)
_UP = {
    "Y_UP": np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]]),
    "X_UP": np.array([[0.0, -1.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]]),
}


#: characters of a Collada file searched for its ``<asset>`` (long contributor notes included)
ASSET_CHARS = 1 << 16


def _collada_up(path: str) -> np.ndarray:
    """Rotation taking a Collada file's coordinates to Z up (identity for Z_UP or none): the
    ``<up_axis>`` of its ``<asset>``, which opens the file (read up to ``ASSET_CHARS``)."""
    with open(path, encoding="utf-8", errors="replace") as fh:
        head = fh.read(ASSET_CHARS)
    head = head[: head.find("</asset>")] if "</asset>" in head else head
    m = re.search(r"<up_axis>\s*([XYZ]_UP)\s*</up_axis>", head)
    return _UP.get(m.group(1) if m else "Z_UP", np.eye(3))


@dataclass(frozen=True)
class UnloadedMesh:
    """A mesh file a model names whose shape could not be loaded."""

    link: str
    role: str  #: "collision" or "visual"
    mesh: str  #: the file as the model names it (a path or a package:// URI)
    found: bool  #: False: not found; True: found but unreadable

    @property
    def in_package(self) -> bool:
        """A ``package://`` mesh (resolved from the model's folders or ROS_PACKAGE_PATH)."""
        return PACKAGE in self.mesh

    def __str__(self) -> str:
        return f"{self.link} ({self.role}: {self.mesh})"


def with_mesh_vertices(
    shapes: list[Shape], model_path: Path
) -> tuple[list[Shape], list[str], list[UnloadedMesh]]:
    """``shapes`` with each mesh's vertices (body frame, scaled) loaded where its file resolves
    (visual meshes only on bodies without a usable collision shape); notes name the meshes that
    could not be found or read; and those meshes."""
    out = list(shapes)
    missing: list[UnloadedMesh] = []
    unreadable: list[UnloadedMesh] = []
    for role in ("collision", "visual"):
        solid = {s.body for s in out if s.role == "collision" and _usable(s)}
        for k, s in enumerate(out):
            if s.role != role or s.kind != MESH or s.vertices is not None:
                continue
            if role == "visual" and s.body in solid:
                continue
            path = resolve_mesh(s.mesh, model_path)
            verts = None if path is None else _hull_vertices(str(path))
            if verts is None:
                (missing if path is None else unreadable).append(
                    UnloadedMesh(s.link, role, s.mesh, path is not None)
                )
                continue
            v = verts * s.scale
            out[k] = replace(s, vertices=v @ s.pose[:3, :3].T + s.pose[:3, 3])
    notes = []
    for what, names in (("not found", missing), ("unreadable", unreadable)):
        if names:
            notes.append(
                f"{len(names)} mesh file(s) {what}, their shapes ignored: "
                + ", ".join(map(str, names[:3]))
                + (" …" if len(names) > 3 else "")
            )
    pkgs = sorted({m.mesh.split(PACKAGE, 1)[1].split("/", 1)[0] for m in missing if m.in_package})
    if pkgs:
        count = sum(m.in_package for m in missing)
        notes.append(
            f"{count} of them are {PACKAGE} meshes of package(s) {', '.join(pkgs)} found neither "
            "in a folder above the model file nor on ROS_PACKAGE_PATH: add the folder that holds "
            "each package to ROS_PACKAGE_PATH (folders separated by ':'), or keep the model "
            "inside its package"
        )
    return out, notes, missing + unreadable


def _usable(s: Shape) -> bool:
    """A primitive, or a mesh whose vertices are loaded."""
    return s.kind != MESH or s.vertices is not None
