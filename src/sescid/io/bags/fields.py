"""One section of a mapping file read field by field; every error names the file and the field
path (``feet.right.unit``)."""

from __future__ import annotations

from pathlib import Path
from typing import Any, Literal, NoReturn, overload

import numpy as np

from sescid.errors import DataError, choices

#: which time a message is filed under: its header stamp if it has one, the header (required),
#: or when the recorder received it
Stamp = Literal["auto", "header", "receive"]


def normalize_type(name: str) -> str:
    """'pkg/Type' → 'pkg/msg/Type' (ROS 2 form); other names stripped."""
    parts = name.strip().split("/")
    return "/".join([parts[0], "msg", parts[1]]) if len(parts) == 2 else name.strip()


class Fields:
    """Reads one mapping section (``data``, a dict) at field path ``where`` of file ``path``."""

    def __init__(self, path: str, where: str, data, allowed: set[str], folder: Path | None = None):
        self.path, self.where = path, where
        self.folder = folder or Path(".")  #: the mapping file's folder (relative file names)
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
        """The field path of ``key`` in this section."""
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
        """A finite number (> 0 when ``positive``, else ≥ 0)."""
        v = self.data.get(key, default)
        if isinstance(v, bool) or not isinstance(v, int | float) or not np.isfinite(v):
            self.fail(key, f"expected a number, got {v!r}")
        if positive and not v > 0:
            self.fail(key, f"must be > 0, got {v!r}")
        if not positive and v < 0:
            self.fail(key, f"must be ≥ 0, got {v!r}")
        return float(v)

    def vector(self, key: str, n: int, default=None) -> np.ndarray | None:
        """``n`` finite numbers (None when absent and no default)."""
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

    def table(self, key: str, what: str) -> dict[str, str]:
        """A table of names → names (e.g. a rename table); {} when absent."""
        v = self.data.get(key) or {}
        if not isinstance(v, dict) or not all(
            isinstance(k, str) and isinstance(x, str) for k, x in v.items()
        ):
            self.fail(key, f"expected a table {what}")
        return dict(v)

    def sub(self, key: str, allowed: set[str]) -> Fields:
        """The nested section ``key``."""
        return Fields(self.path, self.name(key), self.data[key], allowed, self.folder)

    def choice(self, key: str, default: str | None, alias: Any) -> Any:
        """A field that is one of the values of the ``Literal`` alias ``alias``."""
        return self.text(key, default, choices(alias))

    def stamp(self) -> Stamp:
        """The ``stamp`` field: auto (header if any), header or receive."""
        return self.choice("stamp", "auto", Stamp)

    def msgtype(self) -> str | None:
        """The optional ``type`` field, normalised."""
        t = self.text("type")
        return normalize_type(t) if t else None
