"""Reading a recording with ``rosbags`` (the ``bags`` extra): rosbag2 directories (sqlite3 or
MCAP) and ROS 1 ``.bag`` files, without a ROS installation; each wanted topic's messages and
receive times."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sescid.errors import DataError, MissingExtraError, SescidError
from sescid.io.bags.fields import normalize_type
from sescid.io.bags.mapping import BagMapping


@dataclass
class Topic:
    """One topic's messages in the bag's order and their receive times (int64 ns)."""

    name: str
    msgtype: str
    recv: np.ndarray  #: (m,) int64 ns
    msgs: list
    bag: str = ""  #: the recording's path(s), for messages


def rosbags():
    """The rosbags names used here (MissingExtraError without the bags extra)."""
    try:
        from rosbags.highlevel import AnyReader, AnyReaderError
        from rosbags.typesys import Stores, TypesysError, get_types_from_msg, get_typestore
    except ImportError:
        raise MissingExtraError("reading bags", "bags") from None
    return AnyReader, AnyReaderError, Stores, TypesysError, get_types_from_msg, get_typestore


def bag_paths(bag_path) -> list[Path]:
    """The recording's paths (a rosbag2 folder, a ROS 1 file or a list of ROS 1 files)."""
    paths = [Path(p) for p in bag_path] if isinstance(bag_path, list | tuple) else [Path(bag_path)]
    for p in paths:
        if not p.exists():
            raise DataError(f"{p}: bag not found")
    return paths


def _check_metadata(paths: list[Path]) -> None:
    """DataError for a rosbag2 folder without its metadata.yaml (rosbags' own error named the
    folder as the missing file)."""
    for p in paths:
        if p.is_dir() and not (p / "metadata.yaml").is_file():
            stored = sorted(f.name for f in p.iterdir() if f.suffix in (".mcap", ".db3"))
            has = f"it holds {', '.join(stored[:3])}" if stored else "it holds no .mcap or .db3"
            raise DataError(
                f"{p}: no metadata.yaml, the index of a rosbag2 recording ({has}): restore it "
                f"(ros2 bag reindex {p} rebuilds it) or give the recording's own folder"
            )


def wanted_topics(mp: BagMapping) -> dict[str, list[str]]:
    """Topic → the mapping fields that name it."""
    wanted: dict[str, list[str]] = {}
    wanted.setdefault(mp.joints.topic, []).append("joints.topic")
    if mp.torques is not None:
        wanted.setdefault(mp.torques.topic, []).append("torques.topic")
    for foot in mp.feet:
        wanted.setdefault(foot.topic, []).append(f"feet.{foot.name}.topic")
    if mp.pose is not None:
        wanted.setdefault(mp.pose.topic, []).append("pose.topic")
    if mp.support_topic is not None:
        wanted.setdefault(mp.support_topic.topic, []).append("support.topic")
    return wanted


def _typestore(mp: BagMapping, rb):
    """The mapping's typestore with its custom message types registered."""
    _, _, Stores, TypesysError, get_types_from_msg, get_typestore = rb
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
    return store


def read_topics(paths: list[Path], mp: BagMapping) -> dict[str, Topic]:
    """Every topic the mapping names, decoded (one-line errors naming the bag and the field)."""
    rb = rosbags()
    _check_metadata(paths)
    AnyReader, AnyReaderError, _, TypesysError, _, _ = rb
    store = _typestore(mp, rb)
    bag = ", ".join(str(p) for p in paths)
    try:
        with AnyReader(paths, default_typestore=store) as reader:
            topics = _decode(reader, store, mp, bag, (AnyReaderError, TypesysError, KeyError))
    except SescidError:
        raise
    except (AnyReaderError, TypesysError) as exc:
        raise DataError(f"{bag}: cannot read the bag ({exc})") from None
    except Exception as exc:  # rosbags storage errors (corrupt files) have no common base class
        if exc.__class__.__module__.startswith("rosbags"):
            raise DataError(f"{bag}: cannot read the bag ({exc})") from None
        raise
    for t in topics.values():
        if not t.msgs:
            raise DataError(f"{bag}: topic '{t.name}' has no messages")
    return topics


def _decode(reader, store, mp: BagMapping, bag: str, errors: tuple) -> dict[str, Topic]:
    # types the bag does not define (old rosbag2 recordings): the mapping's and the store's
    missing = {k: v for k, v in store.fielddefs.items() if k not in reader.typestore.fielddefs}
    if missing:
        reader.typestore.register(missing)
    have = sorted({c.topic for c in reader.connections})
    wanted = wanted_topics(mp)
    topics: dict[str, Topic] = {}
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
        topics[topic] = Topic(topic, types.pop(), np.empty(0, np.int64), [], bag)
    conns = [c for c in reader.connections if c.topic in wanted]
    recv: dict[str, list[int]] = {t: [] for t in topics}
    for conn, ts, raw in reader.messages(connections=conns):
        try:
            msg = reader.deserialize(raw, conn.msgtype)
        except errors as exc:
            raise DataError(
                f"{bag}: cannot decode {conn.msgtype} on '{conn.topic}' ({exc}); give its "
                f".msg text under types: in {mp.source}"
            ) from None
        topics[conn.topic].msgs.append(msg)
        recv[conn.topic].append(ts)
    for t in topics.values():
        t.recv = np.array(recv[t.name], dtype=np.int64)
    return topics


def check_type(topic: Topic, want: str | None, where: str, default: tuple[str, ...] = ()) -> None:
    """DataError when the topic's type is not ``want`` (or, without one, none of ``default``).

    ``where``: the mapping file and section, e.g. "map.yaml: feet.left".
    """
    have = topic.msgtype
    source, _, section = where.rpartition(": ")
    if want is not None and normalize_type(want) != have:
        raise DataError(f"{source}: {section}.type: {want}, but '{topic.name}' carries {have}")
    if want is None and default and have not in default:
        raise DataError(
            f"{source}: {section}: '{topic.name}' carries {have}, expected {' or '.join(default)}"
        )
