"""Mesh files of a URDF's shapes: resolve ``package://``, ``file://`` and relative paths, load
the vertices (convex hull, in the body frame) on demand with trimesh (Collada files turned to
Z up from their ``<up_axis>``, as Assimp does).

Loading is lazy (``with_mesh_vertices`` is called by the robot when a consumer needs geometry:
the sole, ground clearance, self-collision); a mesh that cannot be found or read keeps
``vertices=None`` and is named in the returned notes. MJCF shapes carry MuJoCo's compiled
vertices already and pass through unchanged.
"""

from __future__ import annotations

import re
from dataclasses import replace
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from sescid.errors import MissingExtraError
from sescid.model.geometry import MESH, Shape


def resolve_mesh(filename: str, model_path: Path) -> Path | None:
    """The file a mesh name refers to, or None when it does not exist.

    ``package://PKG/rest``: the first ancestor directory of the model file named PKG, or holding
    a directory PKG, that contains ``rest``; ``file://`` and absolute paths as they are; other
    names relative to the model file's directory.
    """
    if not filename:
        return None
    if filename.startswith("package://"):
        pkg, _, rest = filename[len("package://") :].partition("/")
        for d in Path(model_path).resolve().parents:
            for cand in (d / rest if d.name == pkg else None, d / pkg / rest):
                if cand is not None and cand.is_file():
                    return cand
        return None
    name = filename[len("file://") :] if filename.startswith("file://") else filename
    p = Path(name)
    if not p.is_absolute():
        p = Path(model_path).resolve().parent / p
    return p if p.is_file() else None


@lru_cache(maxsize=512)
def _hull_vertices(path: str) -> np.ndarray | None:
    """(k, 3) convex-hull vertices of a mesh file in its own frame (None if unreadable)."""
    try:
        import trimesh  # lazy: only needed for mesh geometry
    except ImportError:  # pragma: no cover - depends on the environment
        raise MissingExtraError("reading mesh geometry", "meshes") from None

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


#: Collada up axis → Z up, as Assimp (hence Pinocchio/hpp-fcl, RViz) applies it
_UP = {
    "Y_UP": np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]]),
    "X_UP": np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]),
}


def _collada_up(path: str) -> np.ndarray:
    """Rotation taking a Collada file's coordinates to Z up (identity for Z_UP or none)."""
    with open(path, encoding="utf-8", errors="replace") as fh:
        head = fh.read(8192)
    m = re.search(r"<up_axis>\s*([XYZ]_UP)\s*</up_axis>", head)
    return _UP.get(m.group(1) if m else "Z_UP", np.eye(3))


def with_mesh_vertices(shapes: list[Shape], model_path: Path) -> tuple[list[Shape], list[str]]:
    """``shapes`` with each mesh's hull vertices (body frame, scaled) loaded where its file
    resolves; notes name the meshes that could not be found or read."""
    out: list[Shape] = []
    missing: list[str] = []
    unreadable: list[str] = []
    for s in shapes:
        if s.kind != MESH or s.vertices is not None:
            out.append(s)
            continue
        path = resolve_mesh(s.mesh, model_path)
        verts = None if path is None else _hull_vertices(str(path))
        if verts is None:
            (missing if path is None else unreadable).append(f"{s.link} ({s.role}: {s.mesh})")
            out.append(s)
            continue
        v = verts * s.scale
        out.append(replace(s, vertices=v @ s.pose[:3, :3].T + s.pose[:3, 3]))
    notes = []
    if missing:
        notes.append(
            f"{len(missing)} mesh file(s) not found, their shapes ignored: "
            + ", ".join(missing[:3])
            + (" …" if len(missing) > 3 else "")
        )
    if unreadable:
        notes.append(
            f"{len(unreadable)} mesh file(s) unreadable, their shapes ignored: "
            + ", ".join(unreadable[:3])
            + (" …" if len(unreadable) > 3 else "")
        )
    return out, notes
