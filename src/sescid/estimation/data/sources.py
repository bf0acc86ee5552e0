"""Where measurements come from: arrays in memory, or chunks that can be read once.

``as_sources`` turns what ``identify`` accepts into a list of sources, each one data set (a file,
or arrays) that can be iterated more than once: the normal equations are accumulated on the first
pass, the residuals (MAE, RMS, the error against a simulation's truth) need the fitted r and so a
second pass. A source that can be read only once (a file's chunks as they are parsed) is spilled
on its first pass, chunk by chunk, as raw float64 to an anonymous temporary file (the OS's page
cache, not this process's memory) and replayed from there: flat memory for any number of poses.
"""

from __future__ import annotations

import dataclasses
import itertools
import tempfile
from collections.abc import Iterable, Iterator
from typing import IO, Any

import numpy as np

from sescid.errors import DataError
from sescid.estimation.data.measurements import ARRAYS, Measurements
from sescid.kinds import Kinds
from sescid.robot import Robot
from sescid.stance import Stance


class HeldSource:
    """Validated measurements as a source of one chunk (no second validation)."""

    def __init__(self, m: Measurements):
        self.data, self.name = m, m.source

    def chunks(self) -> Iterator[Measurements]:
        """The data, as one chunk."""
        yield self.data

    def first(self) -> Measurements | None:
        """The first chunk (what the data measure)."""
        return self.data

    def close(self) -> None:
        """Nothing to release."""


class MemorySource(HeldSource):
    """Measurements held in memory (validated once)."""

    def __init__(self, robot: Robot, data: Measurements):
        super().__init__(data.checked(robot))


class StreamSource:
    """Chunks that can be read once, each validated as it arrives and spilled for a replay."""

    def __init__(self, robot: Robot, chunks: Iterable[Measurements], name: str = "data"):
        self.robot, self.name = robot, name
        self._chunks: Iterable[Measurements] | None = chunks
        self._spill: IO[bytes] | None = None
        self._layout: list[tuple[Measurements, list[Any]]] = []

    def first(self) -> Measurements | None:
        """The first chunk, unchecked (what the data measure), read ahead without losing it:
        the first pass still yields every chunk."""
        if self._chunks is None:
            return self._layout[0][0] if self._layout else None
        it = iter(self._chunks)
        head = next(it, None)
        if head is not None:
            self._chunks = itertools.chain([head], it)
        return head

    def chunks(self) -> Iterator[Measurements]:
        """The chunks: read (and spilled) on the first pass, replayed on later ones."""
        if self._chunks is None:
            yield from self._replay()
            return
        source, self._chunks = self._chunks, None
        self._spill = tempfile.TemporaryFile(prefix="sescid-")
        for chunk in source:
            m = chunk.checked(self.robot)
            shapes = []
            for f in ARRAYS:
                a = getattr(m, f)
                shapes.append(None if a is None else a.shape)
                if a is not None:
                    self._spill.write(np.ascontiguousarray(a, dtype=float).tobytes())
            nothing: dict[str, Any] = {f: None for f in ARRAYS if f != "q"}
            empty = dataclasses.replace(m, **nothing)
            self._layout.append((dataclasses.replace(empty, q=np.empty((0, 0))), shapes))
            yield m

    def _replay(self) -> Iterator[Measurements]:
        if self._spill is None:
            raise DataError(f"{self.name}: the data were never read")
        self._spill.seek(0)
        for template, shapes in self._layout:
            arrays: dict[str, Any] = {}
            for f, shape in zip(ARRAYS, shapes, strict=True):
                if shape is None:
                    arrays[f] = None
                    continue
                count = int(np.prod(shape))
                raw = self._spill.read(8 * count)
                arrays[f] = np.frombuffer(raw, dtype=float, count=count).reshape(shape)
            yield dataclasses.replace(template, **arrays)

    def close(self) -> None:
        """Drop the spill file."""
        if self._spill is not None:
            self._spill.close()
            self._spill = None


Source = MemorySource | StreamSource


def as_sources(robot: Robot, data: Any, kinds: Kinds | None = None) -> list[Source]:
    """The sources of ``data``: a ``Measurements``; a list or tuple of them (pooled data sets);
    an iterable of ``Measurements`` chunks of one data set (read once); or a list of such
    iterables (pooled data sets read once, e.g. files). ``kinds``: keep only these measurement
    kinds of the data (None: all)."""
    if isinstance(data, Measurements):
        return [MemorySource(robot, data.only(kinds))]
    if isinstance(data, list | tuple) and data and all(isinstance(d, Measurements) for d in data):
        if len({id(d) for d in data}) < len(data):
            raise DataError("identify: the same Measurements given twice (each pose would count "
                            "twice: standard errors √2 too small)")  # fmt: skip
        return [MemorySource(robot, d.only(kinds)) for d in data]
    if isinstance(data, list) and data and all(_stream(d) for d in data):
        return [
            StreamSource(robot, (c.only(kinds) for c in d), f"source {i + 1}")
            for i, d in enumerate(data)
        ]
    if isinstance(data, np.ndarray) or not isinstance(data, Iterable):
        raise DataError(
            "identify: data must be Measurements, a list of them, or chunks of one data set "
            "(or joint angles q with cop=…)"
        )
    return [StreamSource(robot, (c.only(kinds) for c in data))]


def _stream(d: Any) -> bool:
    """An iterable of chunks (not an array, not a Measurements)."""
    return isinstance(d, Iterable) and not isinstance(d, np.ndarray | Measurements | str)


def in_memory(robot: Robot, sources: list[Source]) -> list[Measurements]:
    """Each source's data joined in memory, one set per stance it holds (for methods that
    revisit poses: robust, cv)."""
    from sescid.estimation.data.measurements import concatenate

    out = []
    for s in sources:
        stances: dict[Stance, list[Measurements]] = {}
        for part in s.chunks():  # one per stance of the source (a support column)
            stances.setdefault(part.stance_on(robot), []).append(part)
        out += [concatenate(parts) for parts in stances.values()]
    return out
