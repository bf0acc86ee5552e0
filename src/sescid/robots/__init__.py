"""Robots sescid ships, each a small data package: model file plus a ``RobotProfile``.

``profile_for(name)`` gives an embedded robot's profile (``EMBEDDED`` lists the names);
``generic_profile`` stands for any other model file. ``EXAMPLES`` names the example models
shipped with the package (``example_path``), which load by name from any folder.
``body_table`` reads a profile's paper Table 1 (index → body) when it has one.
"""

import csv
from pathlib import Path

from sescid.errors import ModelError
from sescid.robots.op2 import PROFILE as _OP2
from sescid.robots.profile import (
    MX28,
    PoseSampler,
    RobotProfile,
    ServoEncoding,
    ServoGains,
    generic_profile,
)

#: embedded robot name → its profile
EMBEDDED: dict[str, RobotProfile] = {"op2": _OP2}

_EXAMPLES_DIR = Path(__file__).resolve().parent / "examples"
#: example model name → its file, shipped with the package (``--robot wheeled_humanoid``): model
#: files without a profile (``--support`` is given), sescid's own, written for its docs and tests.
#: ``wheeled_humanoid``: 11.6 kg, a base on two wheels balancing on its axle (frame ``axle``);
#: ``humanoid``: an MJCF humanoid on its sole sites ``r_sole``/``l_sole`` (the mujoco extra)
EXAMPLES: dict[str, Path] = {
    "humanoid": _EXAMPLES_DIR / "humanoid.xml",
    "wheeled_humanoid": _EXAMPLES_DIR / "wheeled_humanoid.urdf",
}


def example_path(name: str) -> Path:
    """The file of an example model shipped with the package (ModelError for another name)."""
    try:
        return EXAMPLES[name]
    except KeyError:
        raise ModelError(f"unknown example model '{name}': one of {', '.join(EXAMPLES)}") from None


def model_file_of(name: str) -> Path | None:
    """The model file a robot name stands for: an embedded robot's or an example's; None for
    anything else (a path, given as it is)."""
    if name in EMBEDDED:
        return EMBEDDED[name].model_file
    return EXAMPLES.get(name)


def profile_for(name: str) -> RobotProfile:
    """The profile of an embedded robot (ModelError for an unknown name)."""
    try:
        return EMBEDDED[name]
    except KeyError:
        raise ModelError(
            f"unknown robot '{name}': give an embedded name ({', '.join(EMBEDDED)}), an example "
            f"model's ({', '.join(EXAMPLES)}) or a model file"
        ) from None


def embedded_path(name: str) -> Path:
    """Path of an embedded robot's model file."""
    path = profile_for(name).model_file
    assert path is not None
    return path


def body_table(profile: RobotProfile) -> list[dict[str, str]] | None:
    """The paper's Table 1 rows (index, body, link, …) for a profile that has one."""
    if profile.body_table_file is None:
        return None
    with profile.body_table_file.open() as fh:
        return list(csv.DictReader(fh))


__all__ = [
    "EMBEDDED",
    "EXAMPLES",
    "MX28",
    "PoseSampler",
    "RobotProfile",
    "ServoEncoding",
    "ServoGains",
    "body_table",
    "embedded_path",
    "example_path",
    "generic_profile",
    "model_file_of",
    "profile_for",
]
