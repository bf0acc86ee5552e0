"""ROS bags → the raw log table the ``fsr`` step reads, without a ROS installation.

``read_bag`` reads a rosbag2 recording (sqlite3 or MCAP directory) or ROS 1 ``.bag`` files with
the ``rosbags`` library (the ``bags`` extra) and a **mapping file** that names the topics:

- the joint read-backs: ``sensor_msgs/msg/JointState`` matched by joint name (with an optional
  rename table, bag name → model name), or any message with a float array and an index table;
- per foot, one force source: ``pads`` (an array of pad forces: a custom message whose ``.msg``
  text the mapping gives, ``std_msgs/msg/Float32MultiArray``, …) written as the ``fsr`` step's
  ``r_fsr1..4`` columns in mN; ``wrench`` (``geometry_msgs/msg/WrenchStamped`` of an ankle
  force/torque sensor, its frame a URDF link or a fixed transform from the sole) or ``plate``
  (load cells of a board under the foot) or ``cop`` (a ready ``geometry_msgs/msg/PointStamped``
  in the sole frame), written as per-sample ``<p>_cop_x``, ``<p>_cop_y`` (m, sole frame) and
  ``<p>_fz`` (N; absent for ``cop``);
- optionally a pose-id topic (``std_msgs/msg/Int32`` or ``String``; −1 or an empty string mark
  the robot moving between poses). Without it the poses are **segmented by stationarity**: a
  joint sample is still when every joint's speed, its change over ``window`` seconds, is below
  ``max_speed``; runs of still samples lasting at least ``dwell`` seconds are poses 0, 1, 2, …
  in time order, or, given the planned pose list, the id of the planned pose nearest to each
  run's mean joint angles (largest joint difference within ``match_deg``; runs matching no
  planned pose are dropped as ``unmatched_pose``). Force samples outside a pose are dropped and
  counted as ``moving``.

One output row per sample of the first foot's topic (the clock): the nearest joint state by
stamp within ``tolerance`` seconds gives its joint columns (else the row is dropped as
``no_joint_state``); other feet contribute their nearest sample within the tolerance (else NaN,
which the ``fsr`` step rejects as ``missing``). Stamps are the header stamps, or the bag's
receive time for messages without a header (``stamp: receive`` forces it).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import NoReturn, overload

import numpy as np

from sescid.base.files import read_document
from sescid.errors import DataError, MissingExtraError, SescidError
from sescid.sensors.wrench import cop_from_plate, cop_from_wrench, load_plate, rpy_matrix

MAPPING_FORMAT = "sescid-bag-mapping/1"
_FORCE_N = {"N": 1.0, "mN": 1e-3, "kgf": 9.80665}
_LENGTH_M = {"m": 1.0, "mm": 1e-3}
_SOURCES = ("pads", "wrench", "plate", "cop")
_DEFAULT_FIELD = {"pads": "data", "plate": "data", "wrench": "wrench", "cop": "point"}
_PREFIX = {"right": "r", "left": "l"}


# --- mapping ----------------------------------------------------------------------------------
@dataclass(frozen=True)
class JointSource:
    """Where the joint read-backs are: a JointState topic (by name) or an array (by index)."""

    topic: str
    kind: str = "joint_state"  #: "joint_state" or "array"
    unit: str = "rad"  #: "rad" or "deg"
    rename: dict[str, str] = dataclasses.field(
        default_factory=dict
    )  #: bag joint name → model joint name
    field: str = "data"  #: array field (kind "array"), dotted path
    index: dict[str, int] = dataclasses.field(default_factory=dict)  #: model joint → array index
    stamp: str = "auto"  #: "auto" (header if any), "header" or "receive"
    type: str | None = None  #: expected message type (checked when given)


@dataclass(frozen=True)
class FootSource:
    """One foot's force source and the columns it writes."""

    name: str
    source: str  #: "pads", "wrench", "plate" or "cop"
    topic: str
    prefix: str  #: output prefix: <prefix>_fsr1.., <prefix>_cop_x, <prefix>_cop_y, <prefix>_fz
    field: str | tuple[str, ...]  #: array field, or one scalar field per column (dotted paths)
    index: tuple[int, ...] = ()  #: array positions of the pads/cells
    columns: tuple[str, ...] = ()  #: pad column names (source "pads")
    unit: str = "N"  #: forces N, mN or kgf (torques in that unit × m); CoP m or mm
    scale: float = 1.0  #: extra factor on the raw values
    stamp: str = "auto"
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


@dataclass(frozen=True)
class PoseSource:
    """A topic carrying the pose id (Int32 or String)."""

    topic: str
    field: str = "data"
    stamp: str = "auto"


@dataclass(frozen=True)
class BagMapping:
    """A parsed mapping file (see ``load_mapping``)."""

    joints: JointSource
    feet: tuple[FootSource, ...]
    pose: PoseSource | None = None
    max_speed: float = 0.05  #: rad/s
    dwell: float = 0.5  #: s
    window: float = 0.1  #: s
    match_deg: float = 3.0  #: a segment's mean angles within this of a planned pose take its id
    tolerance: float = 0.02  #: s
    typestore: str = "ros2_humble"
    types: dict[str, str] = dataclasses.field(default_factory=dict)  #: message type → .msg text
    source: str = ""


class _Fields:
    """Reads one mapping section; every error names the file and the field path."""

    def __init__(self, path: str, where: str, data, allowed: set[str]):
        self.path, self.where = path, where
        if not isinstance(data, dict):
            raise DataError(f"{path}: {where}: expected a mapping of fields")
        self.data = data
        unknown = sorted(str(k) for k in set(data) - allowed)
        if unknown:
            raise DataError(
                f"{path}: {self.name(unknown[0])}: unknown field "
                f"(known: {', '.join(sorted(allowed))})"
            )

    def name(self, key: str) -> str:
        return f"{self.where}.{key}" if self.where else key

    def fail(self, key: str, what: str) -> NoReturn:
        """Raise the one-line error for field ``key``."""
        raise DataError(f"{self.path}: {self.name(key)}: {what}")

    @overload
    def text(self, key: str) -> str | None: ...
    @overload
    def text(self, key: str, default: str, choices: tuple[str, ...] | None = None) -> str: ...
    @overload
    def text(
        self, key: str, default: None, choices: tuple[str, ...] | None = None
    ) -> str | None: ...

    def text(self, key: str, default=None, choices=None):
        """A non-empty string field (``default`` when absent), optionally one of ``choices``."""
        v = self.data.get(key, default)
        if v is None:
            if default is None and key in self.data:
                self.fail(key, "expected a value")
            return default
        if not isinstance(v, str) or not v.strip():
            self.fail(key, f"expected a name, got {v!r}")
        if choices is not None and v not in choices:
            self.fail(key, f"expected one of {', '.join(choices)}, got {v!r}")
        return v

    def required(self, key: str) -> str:
        """A string field that must be present."""
        v = self.text(key)
        if v is None:
            self.fail(key, "missing")
        return v

    def number(self, key: str, default: float, positive: bool = False) -> float:
        v = self.data.get(key, default)
        if isinstance(v, bool) or not isinstance(v, int | float) or not np.isfinite(v):
            self.fail(key, f"expected a number, got {v!r}")
        if positive and not v > 0:
            self.fail(key, f"must be > 0, got {v!r}")
        if not positive and v < 0:
            self.fail(key, f"must be ≥ 0, got {v!r}")
        return float(v)

    def vector(self, key: str, n: int, default=None) -> np.ndarray | None:
        v = self.data.get(key, default)
        if v is None:
            return None
        try:
            arr = np.array(v, dtype=float)
        except (TypeError, ValueError):
            arr = np.empty(0)
        if arr.shape != (n,) or not np.isfinite(arr).all():
            self.fail(key, f"expected {n} numbers, got {v!r}")
        return arr

    def sub(self, key: str, allowed: set[str]) -> _Fields:
        return _Fields(self.path, self.name(key), self.data[key], allowed)


def _normalize_type(name: str) -> str:
    parts = name.strip().split("/")
    return "/".join([parts[0], "msg", parts[1]]) if len(parts) == 2 else name.strip()


def _stamp(f: _Fields) -> str:
    return f.text("stamp", "auto", ("auto", "header", "receive"))


def _type(f: _Fields) -> str | None:
    t = f.text("type")
    return _normalize_type(t) if t else None


def _joints(f: _Fields) -> JointSource:
    kind = f.text("kind", "joint_state", ("joint_state", "array"))
    rename = f.data.get("rename") or {}
    if not isinstance(rename, dict) or not all(
        isinstance(k, str) and isinstance(v, str) for k, v in rename.items()
    ):
        f.fail("rename", "expected a table bag_name: model_joint_name")
    index = f.data.get("index") or {}
    if kind == "array":
        if not isinstance(index, dict) or not index:
            f.fail("index", "kind array needs a table model_joint_name: array index")
        for k, v in index.items():
            if not isinstance(k, str) or isinstance(v, bool) or not isinstance(v, int) or v < 0:
                f.fail("index", f"entry {k!r}: {v!r} is not an array index (integer ≥ 0)")
    elif "index" in f.data:
        f.fail("index", "only for kind: array (a JointState is matched by name)")
    return JointSource(
        topic=f.required("topic"),
        kind=kind,
        unit=f.text("unit", "rad", ("rad", "deg")),
        rename=dict(rename),
        field=f.text("field", "position" if kind == "joint_state" else "data"),
        index=dict(index),
        stamp=_stamp(f),
        type=_type(f),
    )


def _field_spec(f: _Fields, default: str) -> str | tuple[str, ...]:
    v = f.data.get("field", default)
    if isinstance(v, str) and v.strip():
        return v
    if isinstance(v, list) and v and all(isinstance(x, str) and x.strip() for x in v):
        return tuple(v)
    return f.fail("field", f"expected a field name or a list of field names, got {v!r}")


def _foot(path: str, name: str, data, mapping_dir: Path) -> FootSource:
    allowed = {"source", "topic", "type", "prefix", "field", "unit", "scale", "stamp"}
    f0 = _Fields(path, f"feet.{name}", data, set(data) if isinstance(data, dict) else set())
    source = f0.text("source", None, _SOURCES)
    if source is None:
        f0.fail("source", f"missing (one of {', '.join(_SOURCES)})")
    extra = {
        "pads": {"index", "columns"},
        "plate": {"index", "plate", "cells_m", "foot_pose", "min_force"},
        "wrench": {
            "sole_frame",
            "sensor_link",
            "sensor_in_sole",
            "foot_mass",
            "foot_com",
            "min_force",
        },
        "cop": set(),
    }[source]
    f = _Fields(path, f"feet.{name}", data, allowed | extra)
    prefix = f.text("prefix", _PREFIX.get(name, name))
    fld = _field_spec(f, _DEFAULT_FIELD[source])
    units = _LENGTH_M if source == "cop" else _FORCE_N
    unit = f.text("unit", "m" if source == "cop" else "N", tuple(units))
    kw: dict = {}
    if source in ("pads", "plate"):
        cols = f.data.get("columns")
        if cols is not None:
            if not isinstance(cols, list) or not cols or not all(isinstance(c, str) for c in cols):
                f.fail("columns", f"expected a list of column names, got {cols!r}")
            kw["columns"] = tuple(cols)
        elif source == "pads":
            kw["columns"] = tuple(f"{prefix}_fsr{k}" for k in range(1, 5))
        if source == "plate":
            kw["cells"], kw["foot_pose"], plate_unit = _plate(f, mapping_dir)
            if "unit" not in f.data:  # the plate file's force_unit, unless the mapping gives one
                kw["plate_unit"] = plate_unit
            kw["min_force"] = f.number("min_force", 0.0)
        count = len(kw["columns"]) if source == "pads" else len(kw["cells"])
        if isinstance(fld, tuple):
            if len(fld) != count:
                f.fail("field", f"{len(fld)} field names for {count} values")
            if "index" in f.data:
                f.fail("index", "not used with one field name per value")
        else:
            idx = f.data.get("index", list(range(count)))
            if (
                not isinstance(idx, list)
                or len(idx) != count
                or not all(isinstance(i, int) and not isinstance(i, bool) and i >= 0 for i in idx)
            ):
                f.fail("index", f"expected {count} array indices (integers ≥ 0), got {idx!r}")
            kw["index"] = tuple(idx)
    elif source == "wrench":
        if isinstance(fld, tuple):
            f.fail("field", "a wrench source takes one field (a geometry_msgs/msg/Wrench)")
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
        stamp=_stamp(f),
        type=_type(f),
        **kw,
    )


def _plate(f: _Fields, mapping_dir: Path) -> tuple[np.ndarray, tuple[float, float, float], float]:
    """Cell positions, the foot's pose on the plate and the plate file's N per unit (else 1)."""
    if ("plate" in f.data) == ("cells_m" in f.data):
        f.fail("plate", "give exactly one of plate (a plate file) or cells_m")
    if "plate" in f.data:
        p = Path(f.required("plate"))
        plate = load_plate(p if p.is_absolute() else mapping_dir / p)
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


def parse_mapping(data, source: str = "<mapping>", mapping_dir: Path | None = None) -> BagMapping:
    """A mapping from its parsed YAML/JSON document (see ``load_mapping``)."""
    top = {
        "format",
        "joints",
        "feet",
        "pose",
        "stationary",
        "tolerance",
        "typestore",
        "types",
        "notes",
    }
    f = _Fields(source, "", data, top)
    if data.get("format") != MAPPING_FORMAT:
        f.fail("format", f"expected {MAPPING_FORMAT!r}, got {data.get('format')!r}")
    if "joints" not in data:
        f.fail("joints", "missing (the joint read-back topic)")
    joints = _joints(
        f.sub(
            "joints",
            {"topic", "kind", "unit", "rename", "field", "index"}
            | {
                "stamp",
                "type",
            },
        )
    )
    feet_raw = data.get("feet")
    if not isinstance(feet_raw, dict) or not feet_raw:
        f.fail("feet", "expected a table foot_name: {source, topic, ...} with at least one foot")
    feet = tuple(_foot(source, str(k), v, mapping_dir or Path(".")) for k, v in feet_raw.items())
    cols = [c for foot in feet for c in foot.output_columns]
    dup = next((c for c in cols if cols.count(c) > 1), None)
    if dup:
        f.fail("feet", f"two feet write the column '{dup}' (set prefix or columns)")
    pose = None
    if data.get("pose") is not None:
        p = f.sub("pose", {"topic", "field", "stamp"})
        pose = PoseSource(p.required("topic"), p.text("field", "data"), _stamp(p))
    st = (
        f.sub("stationary", {"max_speed", "dwell", "window", "match_deg"})
        if "stationary" in data
        else None
    )
    types = data.get("types") or {}
    if not isinstance(types, dict) or not all(
        isinstance(k, str) and isinstance(v, str) for k, v in types.items()
    ):
        f.fail("types", "expected a table message_type: .msg text")
    return BagMapping(
        joints=joints,
        feet=feet,
        pose=pose,
        max_speed=st.number("max_speed", 0.05, positive=True) if st else 0.05,
        dwell=st.number("dwell", 0.5) if st else 0.5,
        window=st.number("window", 0.1, positive=True) if st else 0.1,
        match_deg=st.number("match_deg", 3.0, positive=True) if st else 3.0,
        tolerance=f.number("tolerance", 0.02, positive=True),
        typestore=f.text("typestore", "ros2_humble"),
        types={_normalize_type(k): v for k, v in types.items()},
        source=source,
    )


def load_mapping(path) -> BagMapping:
    """Read a bag mapping file (YAML or JSON, ``format: sescid-bag-mapping/1``).

    Every bad field raises a one-line DataError naming the file and the field path.
    """
    path = Path(path)
    data = read_document(path)
    if not isinstance(data, dict):
        raise DataError(f"{path}: not a bag mapping (expected format: {MAPPING_FORMAT})")
    return parse_mapping(data, str(path), path.parent)


# --- result -------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Segment:
    """One pose in the bag: its id, first and last kept sample (s since the bag's first stamp)."""

    pose: str
    start: float
    end: float
    samples: int


@dataclass
class RawLogTable:
    """The raw log table (``write_table`` writes ``columns``) and how it was cut."""

    columns: dict[str, np.ndarray]  #: pose (text), t (s), joints (rad), force columns
    segments: list[Segment]
    dropped: dict[str, int]  #: reason → force samples left out (moving, no_joint_state, no_pose)
    notes: list[str] = dataclasses.field(default_factory=list)

    @property
    def n(self) -> int:
        """Number of rows (samples)."""
        return len(self.columns["pose"])


# --- reading ----------------------------------------------------------------------------------
def _rosbags():
    try:
        from rosbags.highlevel import AnyReader, AnyReaderError
        from rosbags.typesys import Stores, TypesysError, get_types_from_msg, get_typestore
    except ImportError:
        raise MissingExtraError("reading bags", "bags") from None
    return AnyReader, AnyReaderError, Stores, TypesysError, get_types_from_msg, get_typestore


def _get(msg, path: str, where: str):
    obj = msg
    for part in path.split("."):
        if not hasattr(obj, part):
            have = ", ".join(getattr(obj, "__dataclass_fields__", {})) or "none"
            raise DataError(
                f"{where}: message {getattr(msg, '__msgtype__', type(msg).__name__)} has no field "
                f"'{path}' (fields: {have})"
            )
        obj = getattr(obj, part)
    return obj


@dataclass
class _Topic:
    name: str
    msgtype: str
    recv: np.ndarray  #: (m,) int64 ns
    msgs: list


def _stamps(topic: _Topic, mode: str, where: str, notes: list[str]) -> np.ndarray:
    has_header = bool(topic.msgs) and hasattr(topic.msgs[0], "header")
    if mode == "header" and not has_header:
        raise DataError(f"{where}: stamp: header, but {topic.msgtype} has no header")
    if mode == "receive" or not has_header:
        return topic.recv
    st = np.array(
        [m.header.stamp.sec * 1_000_000_000 + m.header.stamp.nanosec for m in topic.msgs],
        dtype=np.int64,
    )
    if mode == "auto" and not st.any():
        notes.append(f"{topic.name}: every header stamp is zero; used the bag's receive times")
        return topic.recv
    return st


def _nearest(t_ref: np.ndarray, t: np.ndarray, tol_ns: int) -> np.ndarray:
    """Index into sorted ``t_ref`` of the nearest stamp to each of ``t`` (−1 beyond tol_ns)."""
    if len(t_ref) == 0:
        return np.full(len(t), -1)
    i = np.clip(np.searchsorted(t_ref, t), 1, max(len(t_ref) - 1, 1))
    lo = i - 1
    hi = np.minimum(i, len(t_ref) - 1)
    pick = np.where(np.abs(t_ref[hi] - t) < np.abs(t - t_ref[lo]), hi, lo)
    return np.where(np.abs(t_ref[pick] - t) <= tol_ns, pick, -1)


def _joint_values(topic: _Topic, js: JointSource, joint_names: list[str], where: str, notes):
    n, nq = len(topic.msgs), len(joint_names)
    q = np.full((n, nq), np.nan)
    col = {j: k for k, j in enumerate(joint_names)}
    if js.kind == "array":
        unknown = [j for j in js.index if j not in col]
        if unknown:
            raise DataError(f"{where}: index: '{unknown[0]}' is not a joint of the robot")
        missing = [j for j in joint_names if j not in js.index]
        if missing:
            raise DataError(f"{where}: index: no array index for joint '{missing[0]}'")
        cols = np.array([col[j] for j in js.index])
        idx = np.array(list(js.index.values()))
        for i, m in enumerate(topic.msgs):
            arr = np.asarray(_get(m, js.field, where), dtype=float).ravel()
            if arr.size <= idx.max():
                raise DataError(
                    f"{where}: message {i} of {topic.name} has {arr.size} values, the index "
                    f"table needs {idx.max() + 1}"
                )
            q[i, cols] = arr[idx]
    else:
        cache: dict[tuple, tuple[np.ndarray, np.ndarray]] = {}
        seen: set[str] = set()
        partial = 0
        for i, m in enumerate(topic.msgs):
            names = tuple(_get(m, "name", where))
            if names not in cache:
                src, dst = [], []
                for k, nm in enumerate(names):
                    j = js.rename.get(nm, nm)
                    if j in col:
                        src.append(k)
                        dst.append(col[j])
                cache[names] = (np.array(src, dtype=int), np.array(dst, dtype=int))
                seen.update(joint_names[d] for d in dst)
            src, dst = cache[names]
            pos = np.asarray(_get(m, js.field, where), dtype=float)
            if pos.size != len(names):
                raise DataError(
                    f"{where}: message {i} of {topic.name} has {len(names)} names and "
                    f"{pos.size} {js.field} values"
                )
            q[i, dst] = pos[src]
            partial += len(dst) < nq
        missing = [j for j in joint_names if j not in seen]
        if missing:
            bag_names = sorted({nm for names in cache for nm in names})
            more = f" (and {len(missing) - 1} more)" if len(missing) > 1 else ""
            raise DataError(
                f"{where}: joint '{missing[0]}'{more} is not in {topic.name} (its names: "
                f"{', '.join(bag_names[:8])}{', …' if len(bag_names) > 8 else ''}); "
                "add joints.rename: {bag_name: model_name}"
            )
        if partial:
            notes.append(
                f"{topic.name}: {partial} of {n} joint states lack some joints (NaN there)"
            )
    if js.unit == "deg":
        q = np.radians(q)
    return q


def _foot_values(topic: _Topic, foot: FootSource, where: str) -> np.ndarray:
    """Values per message times ``scale``: pads/plate (m, k), wrench (m, 6), cop (m, 2)."""
    factor = foot.scale
    m = len(topic.msgs)
    if foot.source in ("pads", "plate"):
        if isinstance(foot.field, tuple):
            out = np.array(
                [[float(_get(msg, fl, where)) for fl in foot.field] for msg in topic.msgs]
            )
        else:
            idx = np.array(foot.index)
            out = np.empty((m, len(idx)))
            for i, msg in enumerate(topic.msgs):
                arr = np.asarray(_get(msg, foot.field, where), dtype=float).ravel()
                if arr.size <= idx.max():
                    raise DataError(
                        f"{where}: message {i} of {topic.name} has {arr.size} values in "
                        f"'{foot.field}', the index needs {idx.max() + 1}"
                    )
                out[i] = arr[idx]
    elif foot.source == "wrench":
        assert isinstance(foot.field, str)
        out = np.empty((m, 6))
        for i, msg in enumerate(topic.msgs):
            w = _get(msg, foot.field, where)
            f, t = _get(w, "force", where), _get(w, "torque", where)
            out[i] = (f.x, f.y, f.z, t.x, t.y, t.z)
    else:
        assert isinstance(foot.field, str)
        out = np.empty((m, 2))
        for i, msg in enumerate(topic.msgs):
            p = _get(msg, foot.field, where)
            out[i] = (p.x, p.y)
    return out.reshape(m, -1) * factor


def _segments(t: np.ndarray, q: np.ndarray, mp: BagMapping) -> np.ndarray:
    """Segment number (0, 1, …) of each joint sample, −1 while moving (see module docstring)."""
    n = len(t)
    seg = np.full(n, -1)
    if n == 0:
        return seg
    half = int(round(mp.window * 5e8))
    lo = np.searchsorted(t, t - half, side="left")
    hi = np.searchsorted(t, t + half, side="right") - 1
    same = hi <= lo
    lo = np.where(same, np.maximum(np.arange(n) - 1, 0), lo)
    hi = np.where(same, np.minimum(np.arange(n) + 1, n - 1), hi)
    dt = (t[hi] - t[lo]) * 1e-9
    with np.errstate(invalid="ignore", divide="ignore"):
        speed = np.abs(q[hi] - q[lo]).max(axis=1) / dt
    still = (speed < mp.max_speed) & (dt > 0)
    edges = np.flatnonzero(np.diff(np.concatenate([[0], still.astype(int), [0]])))
    k = 0
    for a, b in zip(edges[::2], edges[1::2], strict=True):
        if (t[b - 1] - t[a]) * 1e-9 >= mp.dwell:
            seg[a:b] = k
            k += 1
    return seg


def read_bag(bag_path, mapping, joint_names=None, robot=None, poses=None) -> RawLogTable:
    """Read a ROS bag into the raw log table of the ``fsr`` step (see the module docstring).

    ``bag_path``: a rosbag2 directory (sqlite3 or MCAP), a ROS 1 ``.bag`` file, or a list of
    ROS 1 files. ``mapping``: a ``BagMapping`` or a mapping file path. ``joint_names``: the
    model's joints (default ``robot.joint_names``). ``robot`` is needed for a wrench source whose
    sensor frame is a URDF link. ``poses = (ids, q)``: the planned pose list (ids (k,) text,
    angles (k, nq) rad) whose ids the stationary segments take (without a pose topic).
    """
    AnyReader, AnyReaderError, Stores, TypesysError, get_types_from_msg, get_typestore = _rosbags()
    mp = mapping if isinstance(mapping, BagMapping) else load_mapping(mapping)
    if joint_names is None:
        if robot is None:
            raise DataError("read_bag needs joint_names or a robot")
        joint_names = robot.joint_names
    joint_names = list(joint_names)
    if robot is not None and joint_names != list(robot.joint_names):
        raise DataError("read_bag: joint_names differ from the robot's joints")
    if robot is None and any(f.sensor_link for f in mp.feet):
        foot = next(f for f in mp.feet if f.sensor_link)
        raise DataError(
            f"{mp.source}: feet.{foot.name}.sensor_link needs the robot model to place the sensor"
        )
    paths = [Path(p) for p in bag_path] if isinstance(bag_path, list | tuple) else [Path(bag_path)]
    bag = ", ".join(str(p) for p in paths)
    for p in paths:
        if not p.exists():
            raise DataError(f"{p}: bag not found")

    try:
        store = get_typestore(Stores[mp.typestore.upper()])
    except KeyError:
        raise DataError(
            f"{mp.source}: typestore: unknown {mp.typestore!r} "
            f"(e.g. {', '.join(s.name.lower() for s in list(Stores)[:4])})"
        ) from None
    custom: dict = {}
    for name, text in mp.types.items():
        try:
            custom.update(get_types_from_msg(text, name))
        except TypesysError as exc:
            raise DataError(f"{mp.source}: types.{name}: bad .msg text ({exc})") from None
    try:
        store.register(custom)
    except TypesysError as exc:
        raise DataError(f"{mp.source}: types: {exc}") from None

    wanted: dict[str, list[str]] = {}  # topic → mapping fields that use it
    wanted.setdefault(mp.joints.topic, []).append("joints.topic")
    for foot in mp.feet:
        wanted.setdefault(foot.topic, []).append(f"feet.{foot.name}.topic")
    if mp.pose is not None:
        wanted.setdefault(mp.pose.topic, []).append("pose.topic")

    notes: list[str] = []
    topics: dict[str, _Topic] = {}
    try:
        with AnyReader(paths, default_typestore=store) as reader:
            # types the bag does not define (old rosbag2 recordings): the mapping's and the store's
            missing = {
                k: v for k, v in store.fielddefs.items() if k not in reader.typestore.fielddefs
            }
            if missing:
                reader.typestore.register(missing)
            have = sorted({c.topic for c in reader.connections})
            for topic, fields in wanted.items():
                conns = [c for c in reader.connections if c.topic == topic]
                if not conns:
                    raise DataError(
                        f"{bag}: no topic '{topic}' ({mp.source}: {fields[0]}); the bag has "
                        f"{', '.join(have) if have else 'no topics'}"
                    )
                types = {c.msgtype for c in conns}
                if len(types) > 1:
                    raise DataError(f"{bag}: topic '{topic}' has several types: {sorted(types)}")
                topics[topic] = _Topic(topic, types.pop(), np.empty(0, np.int64), [])
            conns = [c for c in reader.connections if c.topic in wanted]
            recv: dict[str, list[int]] = {t: [] for t in topics}
            for conn, ts, raw in reader.messages(connections=conns):
                try:
                    msg = reader.deserialize(raw, conn.msgtype)
                except (AnyReaderError, TypesysError, KeyError) as exc:
                    raise DataError(
                        f"{bag}: cannot decode {conn.msgtype} on '{conn.topic}' ({exc}); give its "
                        f".msg text under types: in {mp.source}"
                    ) from None
                topics[conn.topic].msgs.append(msg)
                recv[conn.topic].append(ts)
    except SescidError:
        raise
    except (AnyReaderError, TypesysError) as exc:
        raise DataError(f"{bag}: cannot read the bag ({exc})") from None
    except Exception as exc:  # rosbags storage errors (corrupt files) have no common base class
        if exc.__class__.__module__.startswith("rosbags"):
            raise DataError(f"{bag}: cannot read the bag ({exc})") from None
        raise
    for t in topics.values():
        t.recv = np.array(recv[t.name], dtype=np.int64)
        if not t.msgs:
            raise DataError(f"{bag}: topic '{t.name}' has no messages")

    def check_type(topic: str, want: str | None, where: str, default: tuple[str, ...] = ()):
        have = topics[topic].msgtype
        if want is not None and _normalize_type(want) != have:
            raise DataError(f"{mp.source}: {where}.type: {want}, but '{topic}' carries {have}")
        if want is None and default and have not in default:
            raise DataError(
                f"{mp.source}: {where}: '{topic}' carries {have}, expected {' or '.join(default)}"
            )

    # joints
    js = mp.joints
    jt = topics[js.topic]
    check_type(
        js.topic,
        js.type,
        "joints",
        ("sensor_msgs/msg/JointState",) if js.kind == "joint_state" else (),
    )
    tj = _stamps(jt, js.stamp, f"{mp.source}: joints", notes)
    q = _joint_values(jt, js, joint_names, f"{mp.source}: joints", notes)
    order = np.argsort(tj, kind="stable")
    tj, q = tj[order], q[order]

    # force sources, aligned to the first foot
    values, stamps = [], []
    for foot in mp.feet:
        default = {
            "wrench": ("geometry_msgs/msg/WrenchStamped", "geometry_msgs/msg/Wrench"),
            "cop": ("geometry_msgs/msg/PointStamped", "geometry_msgs/msg/Point"),
        }.get(foot.source, ())
        check_type(foot.topic, foot.type, f"feet.{foot.name}", default)
        where = f"{mp.source}: feet.{foot.name}"
        tf = _stamps(topics[foot.topic], foot.stamp, where, notes)
        v = _foot_values(topics[foot.topic], foot, where)
        o = np.argsort(tf, kind="stable")
        values.append(v[o])
        stamps.append(tf[o])
    t_clock = stamps[0]
    tol = int(round(mp.tolerance * 1e9))
    m = len(t_clock)
    rows = [values[0]]
    for k in range(1, len(mp.feet)):
        i = _nearest(stamps[k], t_clock, tol)
        v = np.where((i >= 0)[:, None], values[k][np.maximum(i, 0)], np.nan)
        if (i < 0).any():
            notes.append(
                f"feet.{mp.feet[k].name}: {(i < 0).sum()} of {m} samples have no message within "
                f"{mp.tolerance:g} s on {mp.feet[k].topic} (NaN there)"
            )
        rows.append(v)
    ij = _nearest(tj, t_clock, tol)
    keep = ij >= 0
    dropped = {"no_joint_state": int((~keep).sum()), "moving": 0, "no_pose": 0}

    # poses
    if mp.pose is not None:
        pt = topics[mp.pose.topic]
        check_type(mp.pose.topic, None, "pose", ("std_msgs/msg/Int32", "std_msgs/msg/String"))
        tp = _stamps(pt, mp.pose.stamp, f"{mp.source}: pose", notes)
        raw_ids = [_get(msg, mp.pose.field, f"{mp.source}: pose") for msg in pt.msgs]
        ids = np.array([str(x).strip() for x in raw_ids])
        o = np.argsort(tp, kind="stable")
        tp, ids = tp[o], ids[o]
        ip = np.searchsorted(tp, t_clock, side="right") - 1
        before = ip < 0
        pose = np.where(before, "", ids[np.maximum(ip, 0)])
        moving = ~before & np.isin(pose, ["", "-1"])
        dropped["no_pose"] = int((keep & before).sum())
        dropped["moving"] = int((keep & moving).sum())
        keep &= ~before & ~moving
    else:
        seg = _segments(tj, q, mp)
        s = np.where(keep, seg[np.maximum(ij, 0)], -1)
        dropped["moving"] = int((keep & (s < 0)).sum())
        keep &= s >= 0
        labels = np.arange(seg.max() + 1).astype(str)
        if poses is not None:
            labels = _match_poses(seg, q, poses, mp, notes)
            unmatched = keep & (labels[np.maximum(s, 0)] == "")
            dropped["unmatched_pose"] = int(unmatched.sum())
            keep &= ~unmatched
        pose = np.where(s >= 0, labels[np.maximum(s, 0)] if len(labels) else "", "")

    t0 = min(int(tj[0]), int(t_clock[0]))
    cols: dict[str, np.ndarray] = {
        "pose": pose[keep],
        "t": (t_clock[keep] - t0) * 1e-9,
    }
    qk = q[ij[keep]]
    cols |= {j: qk[:, c] for c, j in enumerate(joint_names)}
    for foot, v in zip(mp.feet, rows, strict=True):
        v = v[keep]
        cols |= _foot_columns(foot, v, qk, robot, mp.source)

    segments = []
    pk, tk = cols["pose"], cols["t"]
    if len(pk):
        change = np.flatnonzero(pk[1:] != pk[:-1]) + 1
        for a, b in zip(np.r_[0, change], np.r_[change, len(pk)], strict=True):
            segments.append(Segment(str(pk[a]), float(tk[a]), float(tk[b - 1]), int(b - a)))
    if len(pk) == 0:
        notes.append(
            f"no sample kept: {', '.join(f'{k}={v}' for k, v in dropped.items() if v) or 'none'}"
        )
    return RawLogTable(cols, segments, dropped, notes)


def _match_poses(seg, q, poses, mp: BagMapping, notes: list[str]) -> np.ndarray:
    """Per segment, the id of the nearest planned pose (max joint difference ≤ match_deg)."""
    ids, q_plan = np.asarray(poses[0]).astype(str), np.asarray(poses[1], dtype=float)
    if q_plan.ndim != 2 or q_plan.shape != (len(ids), q.shape[1]):
        raise DataError(
            f"read_bag: the pose list has {q_plan.shape} angles for {len(ids)} ids and "
            f"{q.shape[1]} joints"
        )
    k = seg.max() + 1
    labels = np.full(k, "", dtype=object)
    tol = np.radians(mp.match_deg)
    for i in range(k):
        mean = np.nanmean(q[seg == i], axis=0)
        d = np.abs(q_plan - mean).max(axis=1)
        j = int(np.argmin(d)) if len(d) else -1
        if j >= 0 and d[j] <= tol:
            labels[i] = ids[j]
        else:
            near = f" (nearest {ids[j]}: {np.degrees(d[j]):.1f}°)" if j >= 0 else ""
            notes.append(f"segment {i} matches no planned pose within {mp.match_deg:g}°{near}")
    return labels.astype(str)


def _foot_columns(foot: FootSource, v: np.ndarray, q: np.ndarray, robot, source: str) -> dict:
    """Output columns of one foot from its SI values (n, ·) and the joint angles (n, nq)."""
    if foot.source == "pads":  # the fsr step's force counts, mN (exact for unit mN, scale 1)
        mn = {"N": 1000.0, "mN": 1.0, "kgf": 9806.65}[foot.unit]
        return {c: v[:, k] * mn for k, c in enumerate(foot.columns)}
    v = v * (_LENGTH_M if foot.source == "cop" else _FORCE_N)[foot.unit]
    if foot.source == "cop":
        return {f"{foot.prefix}_cop_x": v[:, 0], f"{foot.prefix}_cop_y": v[:, 1]}
    if foot.source == "plate":
        cop, fz = cop_from_plate(v, foot.cells, foot.foot_pose, foot.min_force)
    else:
        if foot.sensor_link is not None:
            if len(q):
                try:
                    r_sole, p_sole = robot.link_poses(q, foot.sole_frame)
                    r_s, p_s = robot.link_poses(q, foot.sensor_link)
                except SescidError as exc:
                    raise DataError(f"{source}: feet.{foot.name}: {exc}") from None
                rot = np.swapaxes(r_sole, -1, -2) @ r_s
                pos = np.einsum("nji,nj->ni", r_sole, p_s - p_sole)
            else:
                rot, pos = np.zeros((0, 3, 3)), np.zeros((0, 3))
        else:
            rot, pos = foot.sensor_rot, foot.sensor_pos
        cop, fz = cop_from_wrench(
            v[:, :3],
            v[:, 3:],
            rot,
            pos,
            foot_mass=foot.foot_mass,
            foot_com=foot.foot_com,
            min_force=foot.min_force,
        )
    p = foot.prefix
    return {f"{p}_cop_x": cop[:, 0], f"{p}_cop_y": cop[:, 1], f"{p}_fz": fz}
