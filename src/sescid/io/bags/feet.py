"""The ``feet`` section of a bag mapping: one force source per foot and the columns it writes.

``pads`` (an array of pad forces) → ``<p>_fsr1..4`` in mN (the ``fsr`` step's counts);
``wrench`` (an ankle F/T sensor), ``plate`` (load cells under the foot) or ``cop`` (a ready CoP
in the sole frame) → per-sample ``<p>_cop_x``, ``<p>_cop_y`` (m, sole frame) and ``<p>_fz`` (N;
absent for ``cop``).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Literal, cast, get_args

import numpy as np

from sescid.io.bags.fields import Fields, Stamp
from sescid.sensors.wrench import FORCE_UNITS, ForceUnit, load_plate, rpy_matrix

#: the unit of a ready CoP, and m per unit (forces: ``sensors.wrench.FORCE_UNITS``)
LengthUnit = Literal["m", "mm"]
LENGTH_UNITS: dict[LengthUnit, float] = {"m": 1.0, "mm": 1e-3}
#: a foot's force source: four pads, an ankle F/T wrench, a force plate, or a ready CoP
FootSourceKind = Literal["pads", "wrench", "plate", "cop"]
SOURCES: tuple[FootSourceKind, ...] = get_args(FootSourceKind)
_DEFAULT_FIELD = {"pads": "data", "plate": "data", "wrench": "wrench", "cop": "point"}
_PREFIX = {"right": "r", "left": "l"}
_COMMON = {"source", "topic", "type", "prefix", "field", "unit", "scale", "stamp"}
_EXTRA = {
    "pads": {"index", "columns"},
    "plate": {"index", "plate", "cells_m", "foot_pose", "min_force"},
    "wrench": {"sole_frame", "sensor_link", "sensor_in_sole", "foot_mass", "foot_com", "min_force"},
    "cop": set(),
}


@dataclass(frozen=True)
class FootSource:
    """One foot's force source and the columns it writes."""

    name: str
    source: FootSourceKind
    topic: str
    prefix: str  #: output prefix: <prefix>_fsr1.., <prefix>_cop_x, <prefix>_cop_y, <prefix>_fz
    field: str | tuple[str, ...]  #: array field, or one scalar field per column (dotted paths)
    index: tuple[int, ...] = ()  #: array positions of the pads/cells
    columns: tuple[str, ...] = ()  #: pad column names (source "pads")
    unit: ForceUnit | LengthUnit = "N"  #: forces N, mN or kgf (torques that × m); CoP m or mm

    @property
    def si_per_unit(self) -> float:
        """N (or m, for a ready CoP) per unit of the logged values."""
        if self.source == "cop":
            return LENGTH_UNITS[cast(LengthUnit, self.unit)]
        return FORCE_UNITS[cast(ForceUnit, self.unit)]

    scale: float = 1.0  #: extra factor on the raw values
    stamp: Stamp = "auto"
    type: str | None = None
    sole_frame: str | None = None  #: URDF link of the sole (wrench with sensor_link)
    sensor_link: str | None = None  #: URDF link of the F/T sensor frame
    sensor_rot: np.ndarray | None = None  #: (3, 3) fixed sensor frame in the sole frame
    sensor_pos: np.ndarray | None = None  #: (3,) m
    foot_mass: float = 0.0  #: kg below the sensor
    foot_com: np.ndarray | None = None  #: (3,) m, sole frame
    min_force: float = 0.0  #: N; CoP NaN at or below
    cells: np.ndarray | None = None  #: (k, 2) m, plate frame (source "plate")
    foot_pose: tuple[float, float, float] = (0.0, 0.0, 0.0)  #: sole on the plate (x, y, yaw)

    @property
    def output_columns(self) -> list[str]:
        """Raw-table columns this foot source writes."""
        if self.source == "pads":
            return list(self.columns)
        cols = [f"{self.prefix}_cop_x", f"{self.prefix}_cop_y"]
        return cols if self.source == "cop" else [*cols, f"{self.prefix}_fz"]


def _field_spec(f: Fields, default: str) -> str | tuple[str, ...]:
    v = f.data.get("field", default)
    if isinstance(v, str) and v.strip():
        return v
    if isinstance(v, list) and v and all(isinstance(x, str) and x.strip() for x in v):
        return tuple(v)
    return f.fail("field", f"expected a field name or a list of field names, got {v!r}")


def parse_foot(path: str, name: str, data, folder: Path) -> FootSource:
    """The foot ``name`` of the ``feet`` section."""
    f0 = Fields(path, f"feet.{name}", data, set(data) if isinstance(data, dict) else set())
    source: FootSourceKind | None = f0.choice("source", None, FootSourceKind)
    if source is None:
        f0.fail("source", f"missing (one of {', '.join(SOURCES)})")
    f = Fields(path, f"feet.{name}", data, _COMMON | _EXTRA[source], folder)
    prefix = f.text("prefix", _PREFIX.get(name, name))
    fld = _field_spec(f, _DEFAULT_FIELD[source])
    unit: ForceUnit | LengthUnit = (
        f.choice("unit", "m", LengthUnit) if source == "cop" else f.choice("unit", "N", ForceUnit)
    )
    kw: dict = {}
    if source in ("pads", "plate"):
        kw = _array_foot(f, source, prefix, fld)
    elif source == "wrench":
        kw = _wrench_foot(f, fld)
    elif isinstance(fld, tuple):
        f.fail("field", "a cop source takes one field (a geometry_msgs/msg/Point)")
    return FootSource(
        name=name,
        source=source,
        topic=f.required("topic"),
        prefix=prefix,
        field=fld,
        unit=unit,
        scale=f.number("scale", 1.0, positive=True) * kw.pop("plate_unit", 1.0),
        stamp=f.stamp(),
        type=f.msgtype(),
        **kw,
    )


def _array_foot(f: Fields, source: FootSourceKind, prefix: str, fld) -> dict:
    """Fields of a pads or plate source (columns, cells, array positions)."""
    kw: dict = {}
    cols = f.data.get("columns")
    if cols is not None:
        if not isinstance(cols, list) or not cols or not all(isinstance(c, str) for c in cols):
            f.fail("columns", f"expected a list of column names, got {cols!r}")
        kw["columns"] = tuple(cols)
    elif source == "pads":
        kw["columns"] = tuple(f"{prefix}_fsr{k}" for k in range(1, 5))
    if source == "plate":
        kw["cells"], kw["foot_pose"], plate_unit = _plate(f)
        if "unit" not in f.data:  # the plate file's force_unit, unless the mapping gives one
            kw["plate_unit"] = plate_unit
        kw["min_force"] = f.number("min_force", 0.0)
    count = len(kw["columns"]) if source == "pads" else len(kw["cells"])
    if isinstance(fld, tuple):
        if len(fld) != count:
            f.fail("field", f"{len(fld)} field names for {count} values")
        if "index" in f.data:
            f.fail("index", "not used with one field name per value")
        return kw
    idx = f.data.get("index", list(range(count)))
    if (
        not isinstance(idx, list)
        or len(idx) != count
        or not all(isinstance(i, int) and not isinstance(i, bool) and i >= 0 for i in idx)
    ):
        f.fail("index", f"expected {count} array indices (integers ≥ 0), got {idx!r}")
    kw["index"] = tuple(idx)
    return kw


def _wrench_foot(f: Fields, fld) -> dict:
    """Fields of an ankle F/T source (sensor frame, foot below the sensor)."""
    if isinstance(fld, tuple):
        f.fail("field", "a wrench source takes one field (a geometry_msgs/msg/Wrench)")
    kw: dict = {}
    link = f.text("sensor_link")
    fixed = f.data.get("sensor_in_sole")
    if (link is None) == (fixed is None):
        f.fail("sensor_link", "give exactly one of sensor_link (a URDF link) or sensor_in_sole")
    if link is not None:
        kw["sensor_link"] = link
        kw["sole_frame"] = f.text("sole_frame")
        if kw["sole_frame"] is None:
            f.fail("sole_frame", "missing (the URDF link of the sole, needed with sensor_link)")
    else:
        t = f.sub("sensor_in_sole", {"xyz", "rpy"})
        kw["sensor_pos"] = t.vector("xyz", 3, [0.0, 0.0, 0.0])
        kw["sensor_rot"] = rpy_matrix(t.vector("rpy", 3, [0.0, 0.0, 0.0]))
        kw["sole_frame"] = f.text("sole_frame")
    kw["foot_mass"] = f.number("foot_mass", 0.0)
    kw["foot_com"] = f.vector("foot_com", 3)
    if kw["foot_mass"] > 0 and kw["foot_com"] is None:
        f.fail("foot_com", "missing (the CoM of the foot below the sensor, sole frame, m)")
    kw["min_force"] = f.number("min_force", 0.0)
    return kw


def _plate(f: Fields) -> tuple[np.ndarray, tuple[float, float, float], float]:
    """Cell positions, the foot's pose on the plate and the plate file's N per unit (else 1)."""
    if ("plate" in f.data) == ("cells_m" in f.data):
        f.fail("plate", "give exactly one of plate (a plate file) or cells_m")
    if "plate" in f.data:
        p = Path(f.required("plate"))
        plate = load_plate(p if p.is_absolute() else f.folder / p)
        cells, unit = plate.cells, plate.force_unit
    else:
        try:
            cells = np.array(f.data["cells_m"], dtype=float)
        except (TypeError, ValueError):
            cells = np.empty((0, 0))
        if cells.ndim != 2 or cells.shape[1] != 2 or len(cells) < 3:
            f.fail("cells_m", "expected at least 3 points [x, y] in metres")
        unit = 1.0
    pose = f.vector("foot_pose", 3, [0.0, 0.0, 0.0])
    assert pose is not None  # a default is given
    return cells, (float(pose[0]), float(pose[1]), float(pose[2])), unit
