"""Values out of decoded messages: dotted field paths (through arrays of messages), joint values
by name (``JointState``) or by array position, each foot's force values, pose ids."""

from __future__ import annotations

import numpy as np

from sescid.errors import DataError
from sescid.io.bags.feet import FootSource
from sescid.io.bags.recording import Topic


def get(msg, path: str, where: str):
    """The field at dotted ``path`` of ``msg``; a DataError listing the fields when absent."""
    obj = msg
    for part in path.split("."):
        obj = _attr(obj, part, msg, path, where)
    return obj


def _attr(obj, part: str, msg, path: str, where: str):
    if not hasattr(obj, part):
        have = ", ".join(getattr(obj, "__dataclass_fields__", {})) or "none"
        raise DataError(
            f"{where}: message {getattr(msg, '__msgtype__', type(msg).__name__)} has no field "
            f"'{path}' (fields: {have})"
        )
    return getattr(obj, part)


def array(msg, path: str, where: str) -> np.ndarray:
    """The numbers at dotted ``path`` as a flat float array; a path through an array of messages
    (``motor_state.tau_est``) gives that field of each element, in order."""
    return np.asarray(_walk(msg, path.split("."), msg, path, where), dtype=float).ravel()


def _walk(obj, parts: list[str], msg, path: str, where: str):
    for k, part in enumerate(parts):
        if isinstance(obj, list | tuple):  # an array of messages: the rest of the path on each
            return [_walk(el, parts[k:], msg, path, where) for el in obj]
        obj = _attr(obj, part, msg, path, where)
    return obj


def by_index(topic: Topic, field: str, index: dict[str, int], where: str) -> np.ndarray:
    """(m, len(index)) values at the array positions of ``index`` (its order), per message."""
    idx = np.array(list(index.values()), dtype=int)
    out = np.empty((len(topic.msgs), len(idx)))
    for i, msg in enumerate(topic.msgs):
        arr = array(msg, field, where)
        if arr.size <= idx.max():
            raise DataError(
                f"{where}: message {i} of {topic.name} has {arr.size} values in '{field}', the "
                f"index needs {idx.max() + 1}"
            )
        out[i] = arr[idx]
    return out


def by_name(
    topic: Topic, field: str, rename: dict[str, str], joint_names: list[str], where: str
) -> tuple[np.ndarray, set[str], int]:
    """Values (m, nq) of a JointState-like topic matched by ``name`` (NaN where a message lacks
    a joint), the model joints seen, and the number of messages whose ``field`` is empty."""
    col = {j: k for k, j in enumerate(joint_names)}
    out = np.full((len(topic.msgs), len(joint_names)), np.nan)
    cache: dict[tuple, tuple[np.ndarray, np.ndarray]] = {}
    seen: set[str] = set()
    empty = 0
    for i, msg in enumerate(topic.msgs):
        names = tuple(get(msg, "name", where))
        if names not in cache:
            pairs = [
                (k, col[rename.get(n, n)]) for k, n in enumerate(names) if rename.get(n, n) in col
            ]
            src = np.array([p[0] for p in pairs], dtype=int)
            dst = np.array([p[1] for p in pairs], dtype=int)
            cache[names] = (src, dst)
            seen.update(joint_names[d] for d in dst)
        src, dst = cache[names]
        values = np.asarray(get(msg, field, where), dtype=float).ravel()
        if values.size == 0 and names:
            empty += 1
            continue
        if values.size != len(names):
            raise DataError(
                f"{where}: message {i} of {topic.name} has {len(names)} names and "
                f"{values.size} {field} values"
            )
        out[i, dst] = values[src]
    return out, seen, empty


def bag_names(topic: Topic) -> list[str]:
    """The joint names a JointState topic carries (sorted)."""
    return sorted({n for msg in topic.msgs for n in getattr(msg, "name", [])})


def foot_values(topic: Topic, foot: FootSource, where: str) -> np.ndarray:
    """Values per message times ``scale``: pads/plate (m, k), wrench (m, 6), cop (m, 2)."""
    m = len(topic.msgs)
    if foot.source in ("pads", "plate"):
        if isinstance(foot.field, tuple):
            out = np.array([[float(get(msg, f, where)) for f in foot.field] for msg in topic.msgs])
        else:
            index = {str(k): i for k, i in enumerate(foot.index)}
            out = by_index(topic, foot.field, index, where)
    elif foot.source == "wrench":
        assert isinstance(foot.field, str)
        out = np.empty((m, 6))
        for i, msg in enumerate(topic.msgs):
            w = get(msg, foot.field, where)
            f, t = get(w, "force", where), get(w, "torque", where)
            out[i] = (f.x, f.y, f.z, t.x, t.y, t.z)
    else:
        assert isinstance(foot.field, str)
        out = np.empty((m, 2))
        for i, msg in enumerate(topic.msgs):
            p = get(msg, foot.field, where)
            out[i] = (p.x, p.y)
    return out.reshape(m, -1) * foot.scale


def message_pose_ids(topic: Topic, field: str, where: str) -> np.ndarray:
    """The pose id of each message as text (stripped)."""
    return np.array([str(get(msg, field, where)).strip() for msg in topic.msgs])
