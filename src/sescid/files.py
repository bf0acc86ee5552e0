"""Files written all at once or not at all, and JSON/YAML documents read with one-line errors.

``atomic_open`` / ``atomic_path`` write to a temporary file beside the target and replace it
only when the block succeeds; ``read_json`` checks a JSON file's ``"format"`` tag;
``read_document`` reads a JSON or YAML document (mapping and plate files).
"""

from __future__ import annotations

import contextlib
import functools
import json
import os
import stat
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import IO, Any

from .errors import DataError, MissingExtraError


@functools.cache
def _file_mode() -> int:
    """Permissions of new output files: what open() would give (mkstemp alone gives 0600).

    Read once, on the first write (reading the umask means setting it, so never at import).
    """
    mask = os.umask(0)
    os.umask(mask)
    return 0o666 & ~mask


@contextlib.contextmanager
def atomic_open(path: str | Path, mode: str = "w", **kwargs: Any) -> Iterator[IO[Any]]:
    """Open a temporary file beside ``path``; it replaces ``path`` only if the block succeeds."""
    path = Path(path)
    path = path.resolve() if path.is_symlink() else path
    directory = path.parent if str(path.parent) else Path(".")
    if not directory.is_dir():
        raise DataError(f"{path}: output folder '{directory}' does not exist")
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=directory)
    os.chmod(tmp, _file_mode())
    try:
        with os.fdopen(fd, mode, **kwargs) as fh:
            yield fh
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def atomic_path(path: str | Path) -> _AtomicPath:
    """Context manager yielding a temporary path that replaces ``path`` on success (binary
    writers such as matplotlib or pyarrow)."""
    return _AtomicPath(Path(path))


class _AtomicPath:
    def __init__(self, path: Path):
        self.path = path.resolve() if path.is_symlink() else path

    def __enter__(self) -> Path:
        directory = self.path.parent if str(self.path.parent) else Path(".")
        if not directory.is_dir():
            raise DataError(f"{self.path}: output folder '{directory}' does not exist")
        fd, tmp = tempfile.mkstemp(
            prefix=f".{self.path.stem}.", suffix=self.path.suffix, dir=directory
        )
        os.close(fd)
        os.chmod(tmp, _file_mode())
        self.tmp = Path(tmp)
        return self.tmp

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is None:
            os.replace(self.tmp, self.path)
        else:
            with contextlib.suppress(OSError):
                self.tmp.unlink()


def read_json(path: str | Path, fmt: str | tuple[str, ...], what: str) -> dict:
    """A JSON object whose ``"format"`` is ``fmt`` (or one of them); one-line errors naming the
    file."""
    path = Path(path)
    fmts = (fmt,) if isinstance(fmt, str) else fmt
    if not path.is_file():
        raise DataError(f"{path}: file not found")
    try:
        data = json.loads(path.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise DataError(f"{path}: not a JSON file ({exc.__class__.__name__})") from None
    if not isinstance(data, dict) or data.get("format") not in fmts:
        raise DataError(f'{path}: not {what} (expected "format": "{fmts[-1]}")')
    return data


def check_outputs(outputs: list[str | Path | None], inputs: list[str | Path | None]) -> None:
    """DataError unless every output can be written without destroying anything.

    An output must not be one of the inputs (same resolved path or same file), nor a directory,
    device or FIFO, nor a write-protected file, and two outputs must differ. A symlink is written
    through (its target is replaced, the link kept).
    """
    seen: dict[tuple[int, int] | Path, Path] = {}
    ins: dict[tuple[int, int] | Path, Path] = {}
    for p in inputs:
        if p is not None and Path(p).exists():
            ins[_identity(Path(p))] = Path(p)
    for p in outputs:
        if p is None:
            continue
        path = Path(p)
        key = _identity(path)
        if key in ins:
            raise DataError(
                f"{path}: this output is also an input ({ins[key]}); choose another name"
            )
        if key in seen:
            raise DataError(f"{path}: given twice as an output ({seen[key]})")
        seen[key] = path
        if path.exists() or path.is_symlink():
            target = path.resolve()
            if target.is_dir():
                raise DataError(f"{path}: is a directory, not a file to write")
            mode = target.stat().st_mode if target.exists() else 0
            if target.exists() and not stat.S_ISREG(mode):
                raise DataError(f"{path}: is a device or pipe, not a regular file to write")
            if (
                target.exists()
                and not os.access(target, os.W_OK)
                or (target.exists() and not mode & 0o222)
            ):
                raise DataError(f"{path}: the file is write-protected")


def _identity(path: Path) -> tuple[int, int] | Path:
    """(device, inode) of an existing file, else its resolved path."""
    try:
        st = path.resolve().stat()
    except OSError:
        return path.resolve()
    return (st.st_dev, st.st_ino)


def read_document(path: str | Path) -> object:
    """A JSON or YAML document, by suffix (``.json`` → JSON, anything else → YAML).

    JSON needs only the standard library; YAML is read by ruamel.yaml (it ships with the bags
    extra). Errors are one line naming the file (and the line of a syntax error).
    """
    path = Path(path)
    if not path.is_file():
        raise DataError(f"{path}: file not found")
    try:
        text = path.read_text()
    except (OSError, UnicodeDecodeError) as exc:
        raise DataError(f"{path}: cannot read ({exc.__class__.__name__})") from None
    if path.suffix.lower() == ".json":
        try:
            return json.loads(text)
        except json.JSONDecodeError as exc:
            raise DataError(f"{path}: not a JSON file (line {exc.lineno}: {exc.msg})") from None
    try:
        from ruamel.yaml import YAML
        from ruamel.yaml.error import YAMLError
    except ImportError:  # pragma: no cover - ruamel.yaml ships with the bags extra
        raise MissingExtraError(f"{path}: reading YAML", "bags") from None
    try:
        return YAML(typ="safe", pure=True).load(text)
    except YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f"line {mark.line + 1}: " if mark is not None else ""
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        raise DataError(f"{path}: not a YAML file ({where}{problem})") from None
