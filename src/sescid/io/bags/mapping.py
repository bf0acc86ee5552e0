"""The mapping file: which topics of a bag hold the joints, the joint torques, each foot's force
source, the pose ids and the stance (``format: sescid-bag-mapping/1``, YAML or JSON).

Joints and torques come either from a ``sensor_msgs/msg/JointState`` (``kind: joint_state``,
matched by name, with an optional ``rename`` table bag name → model name; torques from its
``effort``) or from any message with a float array (``kind: array``: ``field`` a dotted path,
which may pass through an array of messages, e.g. ``motor_state.tau_est`` of a Unitree
``LowState``; ``names`` the model joint of each array position, or ``index`` a table model joint
→ position). ``support`` names the stance the recording was made in (a frame of the model, or
``double``), or a String topic naming it as it changes (``{topic: /stance}``). Every bad
field raises a one-line DataError naming the file and the field path.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

from sescid.base.files import read_document
from sescid.errors import DataError
from sescid.io.bags.feet import FootSource, parse_foot
from sescid.io.bags.fields import Fields, Stamp, normalize_type

MAPPING_FORMAT = "sescid-bag-mapping/1"
#: the unit of a logged joint torque, and N·m per unit
TorqueUnit = Literal["N.m", "mN.m"]
TORQUE_NM: dict[TorqueUnit, float] = {"N.m": 1.0, "mN.m": 1e-3}
#: how a source message carries its values: a JointState (by name) or a float array (by index)
MessageKind = Literal["joint_state", "array"]
#: the unit of logged joint angles
AngleUnit = Literal["rad", "deg"]
_SOURCE_FIELDS = {"topic", "kind", "rename", "field", "index", "names", "stamp", "type"}
_TOP = {"format", "joints", "torques", "feet", "pose", "stationary", "tolerance", "typestore"}
_TOP |= {"types", "notes", "support"}


@dataclass(frozen=True)
class JointSource:
    """Where the joint read-backs are: a JointState topic (by name) or an array (by index)."""

    topic: str
    kind: MessageKind = "joint_state"
    unit: AngleUnit = "rad"
    rename: dict[str, str] = dataclasses.field(default_factory=dict)  #: bag name → model name
    field: str = "data"  #: value field (dotted path; "position" for a JointState)
    index: dict[str, int] = dataclasses.field(default_factory=dict)  #: model joint → position
    stamp: Stamp = "auto"
    type: str | None = None  #: expected message type (checked when given)


@dataclass(frozen=True)
class TorqueSource:
    """Where the joint torques are (written as ``tau_<joint>`` columns, N·m): a JointState's
    ``effort`` by name, or an array by index (any subset of the joints)."""

    topic: str
    kind: MessageKind = "joint_state"
    unit: TorqueUnit = "N.m"
    scale: float = 1.0  #: extra factor on the raw values
    rename: dict[str, str] = dataclasses.field(default_factory=dict)  #: bag name → model name
    field: str = "effort"  #: value field (dotted path)
    index: dict[str, int] = dataclasses.field(default_factory=dict)  #: model joint → position
    stamp: Stamp = "auto"
    type: str | None = None


@dataclass(frozen=True)
class PoseSource:
    """A topic carrying a label per message: the pose id (Int32 or String), or the stance
    (String: a frame of the model, or "double")."""

    topic: str
    field: str = "data"
    stamp: Stamp = "auto"


@dataclass(frozen=True)
class BagMapping:
    """A parsed mapping file (see ``load_mapping``)."""

    joints: JointSource
    feet: tuple[FootSource, ...]
    pose: PoseSource | None = None
    torques: TorqueSource | None = None
    support: str | None = None  #: the stance of the whole recording (None: a topic's, or none)
    support_topic: PoseSource | None = None  #: a topic naming the stance as it changes
    max_speed: float = 0.05  #: rad/s
    dwell: float = 0.5  #: s
    window: float = 0.1  #: s
    match_deg: float = 3.0  #: a segment's mean angles within this of a planned pose take its id
    tolerance: float = 0.02  #: s
    typestore: str = "ros2_humble"
    types: dict[str, str] = dataclasses.field(default_factory=dict)  #: message type → .msg text
    source: str = ""

    @property
    def clock(self) -> str:
        """The topic whose samples are the output rows: the first foot's, else the torques'."""
        if self.feet:
            return self.feet[0].topic
        assert self.torques is not None  # parse_mapping requires feet or torques
        return self.torques.topic


def _positions(f: Fields, kind: MessageKind, need: bool) -> dict[str, int]:
    """Array positions by model joint, from ``index`` (a table) or ``names`` (a list whose
    i-th entry names the joint at position i; null or "" skips a position)."""
    if kind != "array":
        for key in ("index", "names"):
            if key in f.data:
                f.fail(key, "only for kind: array (a JointState is matched by name)")
        return {}
    if "index" in f.data and "names" in f.data:
        f.fail("names", "give one of names (a list) or index (a table)")
    if "names" in f.data:
        names = f.data["names"]
        if not isinstance(names, list) or not all(n is None or isinstance(n, str) for n in names):
            f.fail("names", "expected a list of joint names (null skips an array position)")
        index = {n: i for i, n in enumerate(names) if n}
        dup = next((n for n in index if names.count(n) > 1), None)
        if dup is not None:
            f.fail("names", f"joint '{dup}' appears twice")
    else:
        index = f.data.get("index") or {}
        if not isinstance(index, dict):
            f.fail("index", "expected a table model_joint_name: array index")
        for k, v in index.items():
            if not isinstance(k, str) or isinstance(v, bool) or not isinstance(v, int) or v < 0:
                f.fail("index", f"entry {k!r}: {v!r} is not an array index (integer ≥ 0)")
    if need and not index:
        f.fail("index", "kind array needs a table model_joint_name: array index (or names)")
    return dict(index)


def _joints(f: Fields) -> JointSource:
    kind: MessageKind = f.choice("kind", "joint_state", MessageKind)
    return JointSource(
        topic=f.required("topic"),
        kind=kind,
        unit=f.choice("unit", "rad", AngleUnit),
        rename=f.table("rename", "bag_name: model_joint_name"),
        field=f.text("field", "position" if kind == "joint_state" else "data"),
        index=_positions(f, kind, need=True),
        stamp=f.stamp(),
        type=f.msgtype(),
    )


def _torques(f: Fields, joints: JointSource) -> TorqueSource:
    kind: MessageKind = f.choice("kind", "joint_state", MessageKind)
    rename = f.table("rename", "bag_name: model_joint_name")
    return TorqueSource(
        topic=f.required("topic"),
        kind=kind,
        unit=f.choice("unit", "N.m", TorqueUnit),
        scale=f.number("scale", 1.0, positive=True),
        rename=rename if "rename" in f.data else dict(joints.rename),
        field=f.text("field", "effort" if kind == "joint_state" else "data"),
        index=_positions(f, kind, need=True),
        stamp=f.stamp(),
        type=f.msgtype(),
    )


def _support(f: Fields) -> tuple[str | None, PoseSource | None]:
    """The ``support`` field: a stance name, or a table {topic, field, stamp} of a String
    topic naming it."""
    raw = f.data.get("support")
    if raw is None:
        return None, None
    if isinstance(raw, dict):
        t = f.sub("support", {"topic", "field", "stamp"})
        return None, PoseSource(t.required("topic"), t.text("field", "data"), t.stamp())
    return f.text("support"), None


def parse_mapping(data, source: str = "<mapping>", mapping_dir: Path | None = None) -> BagMapping:
    """A mapping from its parsed YAML/JSON document (see ``load_mapping``)."""
    f = Fields(source, "", data, _TOP, mapping_dir)
    if data.get("format") != MAPPING_FORMAT:
        f.fail("format", f"expected {MAPPING_FORMAT!r}, got {data.get('format')!r}")
    if "joints" not in data:
        f.fail("joints", "missing (the joint read-back topic)")
    joints = _joints(f.sub("joints", _SOURCE_FIELDS | {"unit"}))
    torques = None
    if data.get("torques") is not None:
        torques = _torques(f.sub("torques", _SOURCE_FIELDS | {"unit", "scale"}), joints)
    feet_raw = data.get("feet")
    if feet_raw is None and torques is not None:
        feet_raw = {}
    if not isinstance(feet_raw, dict) or (not feet_raw and torques is None):
        f.fail(
            "feet",
            "expected a table foot_name: {source, topic, ...} with at least one foot "
            "(or a torques: section)",
        )
    folder = mapping_dir or Path(".")
    feet = tuple(parse_foot(source, str(k), v, folder) for k, v in feet_raw.items())
    cols = [c for foot in feet for c in foot.output_columns]
    dup = next((c for c in cols if cols.count(c) > 1), None)
    if dup:
        f.fail("feet", f"two feet write the column '{dup}' (set prefix or columns)")
    pose = None
    if data.get("pose") is not None:
        p = f.sub("pose", {"topic", "field", "stamp"})
        pose = PoseSource(p.required("topic"), p.text("field", "data"), p.stamp())
    st = (
        f.sub("stationary", {"max_speed", "dwell", "window", "match_deg"})
        if "stationary" in data
        else None
    )
    types = f.table("types", "message_type: .msg text")
    support, support_topic = _support(f)
    return BagMapping(
        joints=joints,
        feet=feet,
        pose=pose,
        torques=torques,
        support=support,
        support_topic=support_topic,
        max_speed=st.number("max_speed", 0.05, positive=True) if st else 0.05,
        dwell=st.number("dwell", 0.5) if st else 0.5,
        window=st.number("window", 0.1, positive=True) if st else 0.1,
        match_deg=st.number("match_deg", 3.0, positive=True) if st else 3.0,
        tolerance=f.number("tolerance", 0.02, positive=True),
        typestore=f.text("typestore", "ros2_humble"),
        types={normalize_type(k): v for k, v in types.items()},
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
