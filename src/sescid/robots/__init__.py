"""Embedded robot models and the paper's Table 1 map for the OP2."""

from __future__ import annotations

import csv
from importlib import resources
from pathlib import Path

#: embedded model name → (URDF file in this package, default support frame)
EMBEDDED = {"op2": ("op2.urdf", "r_sole")}


def embedded_path(name: str) -> Path:
    """Path of an embedded URDF (``op2``)."""
    return Path(str(resources.files(__name__).joinpath(EMBEDDED[name][0])))


def op2_table1() -> list[dict[str, str]]:
    """The paper's Table 1: index 1..21 → body name, manufacturer link, servo ID, joint."""
    path = resources.files(__name__).joinpath("op2_table1.csv")
    with path.open() as fh:
        return list(csv.DictReader(fh))
