"""What the robot is: a model file (URDF, MJCF) turned into a tree of rigid bodies re-rooted at
the support frame, with its collision/visual shapes.

``load_model(path, support)`` reads either format: the file becomes a format-neutral ``Graph``
(``urdf_parse`` → ``urdf_check`` → ``urdf``, or ``mjcf_compile`` → ``mjcf_joints`` → ``mjcf``),
which ``reroot`` (the one walk) turns into the tree ``RobotModel``/``Body``; ``Shape`` is the
geometry; ``inertia_parts`` the inertia tensors the file gives, per body; ``support_candidates``
the feet a robot can stand on (``feet``). See docs/model.md.
"""

from sescid.model.feet import FootCandidate, frame_up, root_frame, support_candidates
from sescid.model.geometry import Shape, ShapeKind, ShapeRole, body_hulls, shape_hull
from sescid.model.graph import Edge, Frame, Graph, LinkInertial
from sescid.model.inertia import (
    InertiaProblem,
    inertia_issue,
    inertia_parts,
    inertia_problems,
    repair_inertia,
)
from sescid.model.load import load_model, model_format
from sescid.model.tree import Body, ModelFormat, RobotModel, inv_transform, reroot, rot_axis
from sescid.model.urdf import build_urdf_model as build_urdf_model
from sescid.model.urdf_parse import load_urdf, parse_inertial

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
    "frame_up",
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
