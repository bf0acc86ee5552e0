"""A model file read: its format (URDF or MJCF, from the root element) and its body tree."""

from pathlib import Path
from xml.etree import ElementTree

from sescid.errors import ModelError
from sescid.model.tree import ModelFormat, RobotModel
from sescid.model.urdf import build_urdf_model as build_urdf_model


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
        from sescid.model.mjcf import build_mjcf_model as build_mjcf_model

        return build_mjcf_model(p, support)
    return build_urdf_model(p, support)


__all__ = ["load_model", "model_format"]
