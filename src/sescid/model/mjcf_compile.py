"""An MJCF file → MuJoCo's ``MjSpec`` and compiled ``MjModel``, with sescid's checks around it.

Before MuJoCo sees the file: strict XML, a ``<mujoco>`` root, and no non-finite number in any
numeric attribute of the file or of the files it ``<include>``s (MuJoCo resolves include and mesh
paths from the main file's folder, whatever the working directory; so does this check). After
parsing: mesh assets whose file is missing are dropped with their geoms when the bodies' masses
do not depend on them. After compiling: every number sescid reads is finite. MuJoCo's own errors
keep their first line and the element they name (``element 'b', line 2``).
"""

from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Any
from xml.etree import ElementTree

import numpy as np

from sescid.errors import MissingExtraError, ModelError

#: attributes whose values are names, files or keywords, never numbers
_TEXT_ATTRS = frozenset(
    "name class childclass file model prefix meshdir texturedir assetdir content_type key "
    "joint joint1 joint2 body body1 body2 site site1 site2 geom geom1 geom2 mesh material "
    "texture hfield target tendon actuator objname refname camera light plugin instance "
    "user type".split()
)
#: compiled MjModel arrays sescid reads, per object kind (all must be finite)
_COMPILED = {
    "body": ("pos", "quat", "ipos", "iquat", "mass", "inertia"),
    "jnt": ("pos", "axis", "range"),
    "geom": ("pos", "quat", "size"),
    "site": ("pos", "quat"),
}
_KIND = {
    "body": ("nbody", "body"),
    "jnt": ("njnt", "joint"),
    "geom": ("ngeom", "geom"),
    "site": ("nsite", "site"),
}


def mujoco_module(what: str = "reading MJCF") -> Any:
    """The ``mujoco`` module, imported on first use (MissingExtraError naming ``what`` needs the
    mujoco extra, without it): the one import of MuJoCo for the model files and the benches."""
    try:
        import mujoco
    except ImportError:
        raise MissingExtraError(what, "mujoco") from None
    return mujoco


def mujoco_message(exc: Exception) -> str:
    """MuJoCo's error as one line: its first line and the element it names, if any."""
    lines = [ln.strip() for ln in str(exc).strip().splitlines() if ln.strip()]
    if not lines:
        return type(exc).__name__
    where = ""
    for ln in lines[1:]:
        m = re.match(r"Element (?:name )?'([^']*)'(?:, id \d+)?(?:, line (\d+))?", ln)
        if m:
            where = f"; element '{m.group(1)}'" + (f", line {m.group(2)}" if m.group(2) else "")
            break
    return lines[0] + where


def _numbers(text: str) -> list[float] | None:
    try:
        return [float(t) for t in text.split()]
    except ValueError:
        return None


def check_finite_xml(path: Path, base: Path, seen: set[Path] | None = None) -> None:
    """ModelError naming the file and element of the first non-finite number in a numeric
    attribute of ``path`` or the files it includes (resolved from ``base``, the main file's
    folder, as MuJoCo does); unreadable includes are left to MuJoCo."""
    seen = set() if seen is None else seen
    try:
        root = ElementTree.parse(path).getroot()
    except (ElementTree.ParseError, OSError, UnicodeDecodeError):
        return
    for el in root.iter():
        for key, value in el.attrib.items():
            nums = None if key in _TEXT_ATTRS else _numbers(value)
            if nums and not all(math.isfinite(v) for v in nums):
                name = el.get("name")
                what = f"<{el.tag}" + (f" name='{name}'" if name else "") + ">"
                raise ModelError(f'{path}: {what} {key}="{value}" has a non-finite number')
    for inc in root.iter("include"):
        f = Path(inc.get("file", ""))
        f = f if f.is_absolute() else base / f
        if f.is_file() and f.resolve() not in seen:
            seen.add(f.resolve())
            check_finite_xml(f, base, seen)


def _mesh_file(spec: Any, mesh: Any, base: Path) -> Path | None:
    """Where MuJoCo would look for a mesh asset's file (None: the mesh has no file)."""
    name = mesh.file
    if not name:
        return None
    f = Path(name)
    if spec.strippath:
        f = Path(f.name)
    if f.is_absolute():
        return f
    meshdir = Path(spec.meshdir or spec.compiler.meshdir or "")
    return base / meshdir / f if not meshdir.is_absolute() else meshdir / f


def _drop_missing_meshes(path: Path, spec: Any, notes: list[str] | None) -> None:
    """Delete mesh assets whose file is missing, and their geoms, from ``spec`` (ModelError if
    a body's mass would come from such a mesh)."""
    mujoco = mujoco_module()
    missing = {}
    for mesh in list(spec.meshes):
        f = _mesh_file(spec, mesh, path.parent)
        if f is not None and not f.is_file():
            missing[mesh.name] = (mesh, f)
    if not missing:
        return
    from_geom = spec.compiler.inertiafromgeom == mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_TRUE
    dropped: dict[str, int] = {}
    for geom in list(spec.geoms):
        if geom.type != mujoco.mjtGeom.mjGEOM_MESH or geom.meshname not in missing:
            continue
        body = geom.parent
        bname = body.name or "<unnamed body>"
        if body.name != "world" and (from_geom or not body.explicitinertial):
            raise ModelError(
                f"{path}: body '{bname}' has a mesh geom whose file "
                f"{missing[geom.meshname][1]} is missing and no explicit <inertial> "
                "(its mass would come from that mesh)"
            )
        dropped[bname] = dropped.get(bname, 0) + 1
        spec.delete(geom)
    for mesh, _ in missing.values():
        spec.delete(mesh)
    if notes is not None:
        example = next(iter(missing.values()))[1]
        notes.append(
            f"{path}: {len(missing)} mesh file(s) not found (e.g. {example}); "
            f"dropped {sum(dropped.values())} mesh geom(s) of {len(dropped)} bodies "
            "(their masses come from explicit <inertial> elements)"
        )


def _check_compiled(path: Path, model: Any) -> None:
    """ModelError naming the object whose compiled numbers (that sescid reads) are not finite."""
    for prefix, fields in _COMPILED.items():
        count, kind = _KIND[prefix]
        n = int(getattr(model, count))
        for field in fields if n else ():
            values = np.asarray(getattr(model, f"{prefix}_{field}")).reshape(n, -1)
            bad = np.flatnonzero(~np.all(np.isfinite(values), axis=1))
            if len(bad):
                i = int(bad[0])
                name = getattr(model, kind)(i).name or f"{kind}{i}"
                raise ModelError(f"{path}: {kind} '{name}' has a non-finite {field} (compiled)")


def compile_mjcf(path: str | Path, notes: list[str] | None = None) -> tuple[Any, Any]:
    """Parse and compile an MJCF file → (MjSpec, MjModel), ModelError naming the file if not.

    ``compiler fusestatic`` and ``alignfree`` are switched off so that every body keeps its own
    frame as written (neither changes the physics). ``notes`` (a list), when given, receives one
    line per dropped mesh.
    """
    mujoco = mujoco_module()
    path = Path(path)
    if not path.is_file():
        raise ModelError(f"{path}: MJCF file not found")
    try:  # strict XML first: one clear line for a broken file
        root = ElementTree.parse(path).getroot()
    except (ElementTree.ParseError, OSError, UnicodeDecodeError) as exc:
        raise ModelError(f"{path}: malformed MJCF (XML: {exc})") from None
    if root.tag != "mujoco":
        raise ModelError(f"{path}: not an MJCF file (root element <{root.tag}>, not <mujoco>)")
    check_finite_xml(path, path.resolve().parent)
    try:
        spec = mujoco.MjSpec.from_file(str(path))
    except Exception as exc:
        raise ModelError(f"{path}: malformed MJCF ({mujoco_message(exc)})") from None
    spec.compiler.fusestatic = False
    spec.compiler.alignfree = False
    _drop_missing_meshes(path, spec, notes)
    try:
        model = spec.compile()
    except Exception as exc:
        msg = mujoco_message(exc)
        raise ModelError(f"{path}: MuJoCo cannot compile the MJCF ({msg})") from None
    _check_compiled(path, model)
    return spec, model
