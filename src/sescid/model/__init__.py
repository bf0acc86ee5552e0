"""What the robot is: a model file (URDF, MJCF) turned into a tree of rigid bodies re-rooted at
the support frame, with its collision/visual shapes.

``load_model(path, support)`` reads either format: the file becomes a format-neutral ``Graph``
(``urdf_parse`` → ``urdf_check`` → ``urdf``, or ``mjcf_compile`` → ``mjcf_joints`` → ``mjcf``),
which ``reroot`` (the one walk) turns into the tree ``RobotModel``/``Body``; ``Shape`` is the
geometry; ``inertia_parts`` the inertia tensors the file gives, per body; ``support_candidates``
the feet a robot can stand on (``feet``). See docs/model.md.
"""

from pathlib import Path
from xml.etree import ElementTree

from sescid.errors import ModelError
from sescid.model.feet import FootCandidate, root_frame, support_candidates
from sescid.model.geometry import Shape, ShapeKind, ShapeRole, body_hulls, shape_hull
from sescid.model.graph import Edge, Frame, Graph, LinkInertial
from sescid.model.inertia import (
    InertiaProblem,
    inertia_issue,
    inertia_parts,
    inertia_problems,
    repair_inertia,
)
from sescid.model.tree import Body, ModelFormat, RobotModel, inv_transform, reroot, rot_axis
from sescid.model.urdf import build_model as build_urdf_model
from sescid.model.urdf_parse import load_urdf, parse_inertial


def model_format(path: Path) -> ModelFormat:
    """The format, "urdf" or "mjcf", from the root element (ModelError if it is neither)."""
    if not path.is_file():
        kind = "URDF" if path.suffix.lower() == ".urdf" else "model"
        raise ModelError(f"{path}: {kind} file not found")
    try:
        for _, el in ElementTree.iterparse(path, events=("start",)):
            tag = el.tag
            break
        else:  # pragma: no cover - an empty document is a ParseError
            tag = ""
    except (ElementTree.ParseError, OSError, UnicodeDecodeError) as exc:
        raise ModelError(f"{path}: malformed model file (XML: {exc})") from None
    if tag == "robot":
        return "urdf"
    if tag == "mujoco":
        return "mjcf"
    raise ModelError(f"{path}: root element <{tag}> is neither URDF <robot> nor MJCF <mujoco>")


def load_model(path: str | Path, support: str) -> RobotModel:
    """Read a URDF or MJCF file into the body tree rooted at the frame ``support``."""
    p = Path(path)
    if model_format(p) == "mjcf":
        from sescid.model.mjcf import build_model as build_mjcf_model

        return build_mjcf_model(p, support)
    return build_urdf_model(p, support)


__all__ = [
    "Body",
    "Edge",
    "FootCandidate",
    "Frame",
    "Graph",
    "LinkInertial",
    "ModelFormat",
    "RobotModel",
    "Shape",
    "ShapeKind",
    "ShapeRole",
    "body_hulls",
    "build_urdf_model",
    "inertia_issue",
    "inertia_problems",
    "repair_inertia",
    "InertiaProblem",
    "inertia_parts",
    "inv_transform",
    "load_model",
    "load_urdf",
    "model_format",
    "parse_inertial",
    "reroot",
    "root_frame",
    "rot_axis",
    "shape_hull",
    "support_candidates",
]
