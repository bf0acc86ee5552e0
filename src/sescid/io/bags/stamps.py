"""Time stamps of the topics on one clock: header stamps or the bag's receive times, a clock
that steps back, and nearest-sample matching.

Header stamps are the sender's clock; the bag's receive times are the recorder's and never step
back (the reader returns messages in that order). When a topic's header stamps step back by more
than the matching tolerance (a restarted clock, a simulator reset, two recordings in one bag),
sorting them would interleave two time lines and lose poses: with ``stamp: auto`` every topic
then uses the receive times (a note counts the steps), with an explicit ``stamp: header`` it is
a DataError naming the topic, the message and the size of the step. Smaller steps back are
messages out of order and are sorted.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sescid.errors import DataError
from sescid.io.bags.fields import Stamp
from sescid.io.bags.recording import Topic


@dataclass(frozen=True)
class Clocked:
    """One mapped topic's stamps in the bag's order (int64 ns) and how they were chosen."""

    topic: Topic
    mode: Stamp  #: the mapping's stamp field
    where: str  #: "map.yaml: joints" (for messages)
    header: bool  #: the stamps are header stamps (else receive times)
    stamps: np.ndarray  #: (m,) int64 ns


def topic_stamps(topic: Topic, mode: Stamp, where: str, notes: list[str]) -> Clocked:
    """The stamps of ``topic`` for stamp mode ``mode`` (auto: the header's if it has one)."""
    has_header = bool(topic.msgs) and hasattr(topic.msgs[0], "header")
    if mode == "header" and not has_header:
        raise DataError(f"{where}: stamp: header, but {topic.msgtype} has no header")
    if mode == "receive" or not has_header:
        return Clocked(topic, mode, where, False, topic.recv)
    st = np.array(
        [m.header.stamp.sec * 1_000_000_000 + m.header.stamp.nanosec for m in topic.msgs],
        dtype=np.int64,
    )
    if mode == "auto" and not st.any():
        notes.append(f"{topic.name}: every header stamp is zero; used the bag's receive times")
        return Clocked(topic, mode, where, False, topic.recv)
    return Clocked(topic, mode, where, True, st)


def _steps_back(st: np.ndarray, tol_ns: int) -> np.ndarray:
    """Indices i where stamp i+1 lies more than ``tol_ns`` before stamp i."""
    return np.flatnonzero(np.diff(st) < -tol_ns)


def one_clock(clocks: list[Clocked], tol_ns: int, notes: list[str]) -> list[Clocked]:
    """The topics' stamps on one time line (see the module docstring)."""
    bad = [(c, _steps_back(c.stamps, tol_ns)) for c in clocks if c.header]
    bad = [(c, i) for c, i in bad if len(i)]
    if not bad:
        return clocks
    c, idx = bad[0]
    size = float(-np.diff(c.stamps)[idx].max()) * 1e-9
    behind = int((c.stamps[1:] < np.maximum.accumulate(c.stamps)[:-1] - tol_ns).sum())
    what = (
        f"'{c.topic.name}': the header stamps step back {len(idx)} time(s) by up to {size:.3g} s "
        f"(first at message {int(idx[0]) + 1}; {behind} messages stamped before an earlier one)"
    )
    strict = next((k for k in clocks if k.mode == "header"), None)
    if strict is not None:
        raise DataError(
            f"{strict.where}: stamp: header, but {what}: the recording holds two time lines "
            "(a restarted clock?); use stamp: receive or split the bag"
        )
    notes.append(f"{what}; every topic uses the bag's receive times instead")
    return [Clocked(k.topic, k.mode, k.where, False, k.topic.recv) for k in clocks]


def nearest(t_ref: np.ndarray, t: np.ndarray, tol_ns: int) -> np.ndarray:
    """Index into sorted ``t_ref`` of the nearest stamp to each of ``t`` (−1 beyond tol_ns)."""
    if len(t_ref) == 0:
        return np.full(len(t), -1)
    i = np.clip(np.searchsorted(t_ref, t), 1, max(len(t_ref) - 1, 1))
    lo = i - 1
    hi = np.minimum(i, len(t_ref) - 1)
    pick = np.where(np.abs(t_ref[hi] - t) < np.abs(t - t_ref[lo]), hi, lo)
    return np.where(np.abs(t_ref[pick] - t) <= tol_ns, pick, -1)


def fill_recent(t: np.ndarray, values: np.ndarray, tol_ns: int) -> np.ndarray:
    """``values`` (m, k) at sorted stamps ``t`` with each NaN replaced by the same column's
    latest earlier value no older than ``tol_ns`` (joint states split over several messages,
    e.g. one publisher per limb on one topic)."""
    out = values.copy()
    m = len(t)
    rows = np.arange(m)
    for k in range(values.shape[1]):
        ok = ~np.isnan(values[:, k])
        if ok.all() or not ok.any():
            continue
        last = np.maximum.accumulate(np.where(ok, rows, -1))
        take = ~ok & (last >= 0)
        take[take] &= t[take] - t[last[take]] <= tol_ns
        out[take, k] = values[last[take], k]
    return out
