"""USD export: the identified masses as a UsdPhysics layer (``usd-core``, the ``usd`` extra).

Every link with mass after export (``parts.exported_parts``) gets ``PhysicsMassAPI`` with
``physics:mass``, ``physics:centerOfMass`` (link frame), and its inertia tensor about the CoM as
``physics:diagonalInertia`` + ``physics:principalAxes`` — the principal decomposition, so that
the off-diagonal terms a simulator keeping only principal moments would drop are kept in the
axes. USD stores them as float32 (mass, CoM, moments, the axes' quaternion: ~1e-7 relative).

- ``over``: the robot's own USD file (as Isaac Sim's importers write it). The layer written is
  an override layer: it sublayers that file (path relative to the output) and holds an
  ``over`` per link, matched by prim name (the link's name made a valid USD identifier; a prim
  with ``PhysicsRigidBodyAPI`` wins among prims of one name). A link not found is an error
  naming it (another robot's USD is refused, nothing written). The values are converted to the
  file's ``metersPerUnit``/``kilogramsPerUnit``, which the layer repeats (stage metadata comes
  from the root layer). The link frames are taken to be the prims' frames.
- standalone: one ``Xform`` per sescid body, nested as the body tree (rooted at the support),
  each at its pose at the zero joint angles relative to its parent and named after the link
  whose frame is the body's; the other links a body merges (fixed joints) are ``Xform``
  children at their fixed offsets. Metres and kilograms, Z up.

The layer is built in memory and exported in one step to a temporary file renamed over the
output (``.usda`` text, ``.usdc``/``.usd`` binary crate); the same fit gives the same bytes.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

from sescid.base.files import atomic_path
from sescid.errors import MissingExtraError, ModelError
from sescid.estimation import Fit
from sescid.io.export.assets import relative
from sescid.io.export.inertia import principal
from sescid.io.export.parts import Part, exported_parts

#: file suffixes written as USD
USD_SUFFIXES = (".usda", ".usdc", ".usd")


def _pxr() -> Any:
    try:
        import pxr  # noqa: F401
        from pxr import Gf, Sdf, Tf, Usd, UsdGeom, UsdPhysics
    except ImportError:
        raise MissingExtraError("writing USD", "usd") from None
    return Gf, Sdf, Tf, Usd, UsdGeom, UsdPhysics


def _mass_api(prim: Any, part: Part, units: tuple[float, float], pxr: Any) -> None:
    """Apply MassAPI on ``prim`` with ``part``'s values in the stage's units (m, kg per unit)."""
    gf, _, _, _, _, physics = pxr
    mpu, kpu = units
    moments, quat = principal(part.inertia)
    api = physics.MassAPI.Apply(prim)
    api.CreateMassAttr().Set(float(part.mass / kpu))
    api.CreateCenterOfMassAttr().Set(gf.Vec3f(*(float(c / mpu) for c in part.com)))
    api.CreateDiagonalInertiaAttr().Set(gf.Vec3f(*(float(x / (kpu * mpu**2)) for x in moments)))
    api.CreatePrincipalAxesAttr().Set(
        gf.Quatf(float(quat[0]), gf.Vec3f(float(quat[1]), float(quat[2]), float(quat[3])))
    )


def _matrix(t: np.ndarray, pxr: Any) -> Any:
    """A (4, 4) transform (column vectors) as a Gf.Matrix4d (row vectors: transposed)."""
    return pxr[0].Matrix4d(*(float(v) for v in np.asarray(t, dtype=float).T.reshape(-1)))


def _standalone(stage: Any, fit: Fit, parts: list[Part], pxr: Any) -> None:
    """The body tree as nested Xforms at the zero pose, MassAPI on every part's link prim."""
    _, _, tf, _, geom, physics = pxr
    robot = fit.robot
    model = robot.model
    rot, org = robot.forward(np.zeros((1, robot.nq)))
    world = np.tile(np.eye(4), (len(model.bodies), 1, 1))
    world[:, :3, :3], world[:, :3, 3] = rot[0], org[0]
    root = "/" + tf.MakeValidIdentifier(robot.name or "robot")
    geom.Xform.Define(stage, root)
    stage.SetDefaultPrim(stage.GetPrimAtPath(root))
    paths: dict[int, str] = {}
    link_path: dict[str, str] = {}
    for b, body in enumerate(model.bodies):  # parents come first
        links = [n for n in body.links if n in model.link_frames]
        # the prim of the body frame: the link whose frame it is, else one named after the body
        at = [n for n in links if np.array_equal(model.link_frames[n][1], np.eye(4))]
        own = at[0] if at else f"{body.name}_frame"
        parent = paths.get(body.parent, root)
        path = f"{parent}/{tf.MakeValidIdentifier(own)}"
        local = world[b] if body.parent < 0 else np.linalg.solve(world[body.parent], world[b])
        xf = geom.Xform.Define(stage, path)
        xf.AddTransformOp().Set(_matrix(local, pxr))
        paths[b] = path
        for name in links:
            if name == own:
                link_path[name] = path
                continue
            sub = geom.Xform.Define(stage, f"{path}/{tf.MakeValidIdentifier(name)}")
            sub.AddTransformOp().Set(_matrix(model.link_frames[name][1], pxr))
            link_path[name] = str(sub.GetPath())
    for part in parts:
        _mass_api(stage.GetPrimAtPath(link_path[part.link]), part, (1.0, 1.0), pxr)
    physics.SetStageKilogramsPerUnit(stage, 1.0)


def _prims_by_name(over: Path, pxr: Any) -> tuple[dict, tuple[float, float], tuple[str, str]]:
    """The robot USD's prims by name as (path, has PhysicsRigidBodyAPI), its (metersPerUnit,
    kilogramsPerUnit), up axis and default prim."""
    _, _, _, usd, geom, physics = pxr
    try:
        stage = usd.Stage.Open(str(over))
    except Exception as exc:  # pxr raises Tf.ErrorException
        raise ModelError(f"{over}: cannot open the USD file ({str(exc).splitlines()[0]})") from None
    if stage is None:
        raise ModelError(f"{over}: cannot open the USD file")
    found: dict[str, list[Any]] = {}
    for prim in stage.Traverse():  # (path, is a rigid body): the stage closes on return
        found.setdefault(prim.GetName(), []).append(
            (str(prim.GetPath()), prim.HasAPI(physics.RigidBodyAPI))
        )
    units = (
        float(geom.GetStageMetersPerUnit(stage)),
        float(physics.GetStageKilogramsPerUnit(stage)),
    )
    return found, units, (str(geom.GetStageUpAxis(stage)), stage.GetRootLayer().defaultPrim)


def _over(stage: Any, parts: list[Part], over: Path, pxr: Any) -> None:
    """Override prims of ``over`` matched by name; ModelError naming links not found."""
    _, _, tf, _, geom, physics = pxr
    found, units, (up, default) = _prims_by_name(over, pxr)
    targets: dict[str, str] = {}
    missing, ambiguous = [], []
    for part in parts:
        prims = found.get(tf.MakeValidIdentifier(part.link), [])
        rigid = [p for p in prims if p[1]]
        pick = rigid if len(rigid) == 1 else prims
        if not pick:
            missing.append(part.link)
        elif len(pick) > 1:
            ambiguous.append(part.link)
        else:
            targets[part.link] = pick[0][0]
    if missing:
        raise ModelError(
            f"{over}: {len(missing)} of the {len(parts)} links with mass have no prim of that "
            f"name ({', '.join(missing[:5])}{' …' if len(missing) > 5 else ''}): is it this "
            "robot's USD?"
        )
    if ambiguous:
        raise ModelError(
            f"{over}: several prims named {ambiguous[0]!r} (none or several with "
            "PhysicsRigidBodyAPI): cannot tell which body it is"
        )
    geom.SetStageMetersPerUnit(stage, units[0])
    geom.SetStageUpAxis(stage, up)
    if default:
        stage.GetRootLayer().defaultPrim = default
    physics.SetStageKilogramsPerUnit(stage, units[1])
    for part in parts:
        _mass_api(stage.OverridePrim(targets[part.link]), part, units, pxr)


def export_usd(
    fit: Fit, path: str | Path, over: str | Path | None = None, repair_inertia: bool = False
) -> list[str]:
    """Write the fit's body masses, CoMs and inertias as a UsdPhysics layer to ``path``
    (.usda/.usdc/.usd, atomically), over the robot's USD file ``over`` or standalone (see the
    module doc). ``fit`` must hold masses. Returns warnings (as ``exported_parts``)."""
    pxr = _pxr()
    _, sdf, _, usd, geom, _ = pxr
    out = Path(path)
    if out.suffix.lower() not in USD_SUFFIXES:
        raise ModelError(f"{out}: a USD file ends in {', '.join(USD_SUFFIXES)}")
    parts, warnings = exported_parts(fit, repair_inertia)
    stage = usd.Stage.CreateInMemory()
    if over is None:
        geom.SetStageMetersPerUnit(stage, 1.0)
        geom.SetStageUpAxis(stage, geom.Tokens.z)
        _standalone(stage, fit, parts, pxr)
    else:
        over = Path(over)
        if not over.is_file():
            raise ModelError(f"{over}: USD file not found")
        _over(stage, parts, over, pxr)
    layer = sdf.Layer.CreateAnonymous(out.suffix)
    layer.TransferContent(stage.GetRootLayer())
    layer.comment = (
        f"masses, CoMs and inertias identified by sescid (method {fit.method_label}, "
        f"{fit.n_poses} poses, total mass {sum(p.mass for p in parts):.6f} kg)"
    )
    if over is not None:
        layer.subLayerPaths.append(relative(Path(os.path.abspath(over)), out.resolve().parent))
    with atomic_path(out) as tmp:
        if not layer.Export(str(tmp)):
            raise ModelError(f"{out}: USD could not write the layer")
    return warnings
