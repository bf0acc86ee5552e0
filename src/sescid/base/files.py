"""Files written all at once or not at all, and JSON/YAML documents read with one-line errors.

``atomic_open`` / ``atomic_path`` write to a temporary file beside the target and replace it
only when the block succeeds; ``read_json`` checks a JSON file's ``"format"`` tag;
``read_document`` reads a JSON or YAML document (mapping and plate files); ``check_outputs``
and ``OutputSet`` make sure a command's outputs destroy nothing and are written all together.
"""

from __future__ import annotations

import contextlib
import functools
import json
import os
import re
import secrets
import shutil
import stat
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import IO, Any

from sescid.errors import DataError, MissingExtraError


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
    """Open a temporary file beside ``path``; it replaces ``path`` only if the block succeeds.

    An OS error on the temporary file (creating, writing, replacing) is a DataError naming
    ``path``, never the temporary.
    """
    path = Path(path)
    path = path.resolve() if path.is_symlink() else path
    directory = path.parent if str(path.parent) else Path(".")
    if not directory.is_dir():
        raise DataError(f"{path}: output folder '{directory}' does not exist")
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=directory)
        os.chmod(tmp, _file_mode())
    except OSError as exc:
        raise DataError(f"{path}: cannot write ({exc.strerror or exc})") from None
    try:
        with os.fdopen(fd, mode, **kwargs) as fh:
            yield fh
        os.replace(tmp, path)
    except OSError as exc:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        if exc.filename in (None, tmp, str(path)):
            raise DataError(f"{path}: cannot write ({exc.strerror or exc})") from None
        raise
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
        try:
            fd, tmp = tempfile.mkstemp(
                prefix=f".{self.path.stem}.", suffix=self.path.suffix, dir=directory
            )
            os.close(fd)
            os.chmod(tmp, _file_mode())
        except OSError as exc:
            raise DataError(f"{self.path}: cannot write ({exc.strerror or exc})") from None
        self.tmp = Path(tmp)
        return self.tmp

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is None:
            try:
                os.replace(self.tmp, self.path)
                return
            except OSError as err:
                exc = err
        with contextlib.suppress(OSError):
            self.tmp.unlink()
        if isinstance(exc, OSError) and exc.filename in (None, str(self.tmp), str(self.path)):
            raise DataError(f"{self.path}: cannot write ({exc.strerror or exc})") from None
        if exc_type is None:
            raise exc


def read_json(path: str | Path, fmt: str | tuple[str, ...], what: str) -> dict:
    """A JSON object whose ``"format"`` is ``fmt`` (or one of them); one-line errors naming the
    file (and the field of an infinite number)."""
    path = Path(path)
    fmts = (fmt,) if isinstance(fmt, str) else fmt
    if not path.is_file():
        raise DataError(f"{path}: file not found")
    try:
        data = json.loads(path.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise DataError(f"{path}: not a JSON file ({exc.__class__.__name__})") from None
    _finite(data, path, "")
    if not isinstance(data, dict) or data.get("format") not in fmts:
        raise DataError(f'{path}: not {what} (expected "format": "{fmts[-1]}")')
    return data


def _finite(obj: object, path: Path, where: str) -> None:
    """DataError naming the field when a document holds an infinite number (JSON's Infinity,
    a number too large for a float, YAML's .inf): no sescid file holds one."""
    if isinstance(obj, float) and obj in (float("inf"), float("-inf")):
        raise DataError(f"{path}: {where or 'the document'}: {obj} is not a finite number")
    if isinstance(obj, dict):
        items = list(obj.items())
    else:
        items = list(enumerate(obj)) if isinstance(obj, list) else []
    for key, value in items:
        _finite(value, path, f"{where}.{key}" if where else str(key))


def check_outputs(
    outputs: list[str | Path | None],
    inputs: list[str | Path | None],
    *,
    force: bool = False,
    folders: list[str | Path | None] | None = None,
) -> None:
    """DataError unless every output can be written without destroying anything.

    An output must not be one of the inputs (same resolved path or same file), nor lie inside
    an input folder (a rosbag2 recording, a session folder: a recording is never written
    into), nor be a directory, device or FIFO, nor a write-protected file (unless ``force``);
    its folder must exist and be writable, and two outputs must differ. A symlink is written
    through (its target is replaced, the link kept). ``folders``: output folders (created when
    missing); each must not be a file nor lie inside an input folder.
    """
    seen: dict[tuple[int, int] | Path, Path] = {}
    ins: dict[tuple[int, int] | Path, Path] = {}
    in_folders = [Path(p) for p in inputs if p is not None and Path(p).is_dir()]
    for p in inputs:
        if p is not None and Path(p).exists():
            ins[_identity(Path(p))] = Path(p)
    for d in folders or []:
        if d is not None and Path(d).exists() and not Path(d).is_dir():
            raise DataError(f"{d}: exists and is not a folder")
        if d is not None:
            _not_inside(Path(d), in_folders)
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
        _not_inside(path, in_folders)
        if path.exists() or path.is_symlink():
            target = path.resolve()
            if target.is_dir():
                raise DataError(f"{path}: is a directory, not a file to write")
            mode = target.stat().st_mode if target.exists() else 0
            if target.exists() and not stat.S_ISREG(mode):
                raise DataError(f"{path}: is a device or pipe, not a regular file to write")
            protected = target.exists() and (not os.access(target, os.W_OK) or not mode & 0o222)
            if protected and not force:
                raise DataError(f"{path}: the file is write-protected (--force replaces it)")
        parent = path.resolve().parent
        if not parent.is_dir() and not any(
            d is not None and _inside(path, Path(d)) for d in folders or []
        ):
            raise DataError(f"{path}: output folder '{path.parent}' does not exist")
        if parent.is_dir() and not os.access(parent, os.W_OK | os.X_OK):
            raise DataError(f"{path}: output folder '{path.parent}' is not writable")


def _not_inside(path: Path, in_folders: list[Path]) -> None:
    """DataError when ``path`` lies inside (or is) one of the input folders."""
    for d in in_folders:
        if _inside(path, d):
            raise DataError(
                f"{path}: inside the input {d} (a recording or input folder is never written "
                "into); choose another folder"
            )


def _inside(path: Path, folder: Path) -> bool:
    return path.resolve().is_relative_to(folder.resolve())


class OutputSet:
    """A command's outputs, validated before anything is written and committed together.

    ``with OutputSet([out, figure], [inputs…]) as outs:`` then write each output to
    ``outs.path(out)`` (a temporary name beside it, same suffix) or a folder's files into
    ``outs.folder(out_dir)`` (a temporary folder); on success every output replaces its target
    (targets are checked again just before, all before the first replace); on any error or
    Ctrl-C the temporaries are removed and no target is touched.
    """

    def __init__(
        self,
        outputs: list[str | Path | None],
        inputs: list[str | Path | None],
        *,
        folders: list[str | Path | None] | None = None,
        force: bool = False,
    ):
        self.inputs = inputs
        self.force = force
        check_outputs(outputs, inputs, force=force, folders=folders)
        self._files: dict[Path, Path] = {}  # target → temporary
        self._folders: dict[Path, Path] = {}  # target folder → temporary folder

    def path(self, target: str | Path) -> Path:
        """Temporary path to write ``target`` to (beside it, same suffix; inside the temporary
        folder when ``target`` lies in a folder given to ``folder``)."""
        target = Path(target)
        for d, tmp_d in self._folders.items():
            if target.resolve().parent == d.resolve():
                return tmp_d / target.name
        target = target.resolve() if target.is_symlink() else target
        folder = target.parent if str(target.parent) else Path(".")
        tmp = folder / f".{target.stem}.{secrets.token_hex(4)}{target.suffix}"
        self._files[target] = tmp
        return tmp

    def folder(self, target: str | Path) -> Path:
        """Temporary folder whose files go into ``target`` on commit (``target`` and its missing
        parents are created only then)."""
        target = Path(target)
        base = target.resolve().parent
        while not base.is_dir():
            base = base.parent
        try:
            tmp = Path(tempfile.mkdtemp(prefix=f".{target.name}.", suffix=".tmp", dir=base))
        except OSError as exc:
            raise DataError(
                f"{target}: cannot create the output folder ({exc.strerror or exc})"
            ) from None
        self._folders[target] = tmp
        return tmp

    def __enter__(self) -> OutputSet:
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is None:
            try:
                self.commit()
            except (OSError, DataError) as err:
                exc = err
            else:
                return
            finally:
                self._clean()
        else:
            self._clean()
        named = self._named(exc) if isinstance(exc, OSError | DataError) else None
        if named is not None:
            raise DataError(named) from None
        if exc_type is None:
            raise exc

    def _named(self, exc: OSError | DataError) -> str | None:
        """The error's message with every temporary replaced by its output's name (None when
        it names no temporary)."""
        if isinstance(exc, OSError):
            if not exc.filename:
                return None
            text = f"{exc.filename}: cannot write ({exc.strerror or exc})"
        else:
            text = str(exc)
        new = text
        for target, tmp in self._files.items():
            pattern = re.escape(str(tmp.parent)) + r"/\.?" + re.escape(tmp.name) + r"[^\s:']*"
            new = re.sub(pattern, str(target).replace("\\", r"\\"), new)
        for target, tmp_d in self._folders.items():
            new = new.replace(f"{tmp_d}/", f"{target}/").replace(str(tmp_d), str(target))
        return new if new != text else None

    def commit(self) -> None:
        """Move every temporary onto its target (after checking all targets again)."""
        moves: list[tuple[Path, Path]] = []
        for target, tmp in self._files.items():
            if not tmp.exists():
                raise DataError(f"{target}: was not written")
            moves.append((tmp, target))
        for target, tmp_d in self._folders.items():
            moves += [(f, target / f.name) for f in sorted(tmp_d.iterdir())]
        check_outputs(
            [t for _, t in moves], self.inputs, force=self.force, folders=list(self._folders)
        )
        for target in self._folders:
            target.mkdir(parents=True, exist_ok=True)
        for tmp, target in moves:
            dest = target.resolve() if target.is_symlink() else target
            os.replace(tmp, dest)

    def _clean(self) -> None:
        for tmp in self._files.values():
            with contextlib.suppress(OSError):
                tmp.unlink()
        for tmp_d in self._folders.values():
            shutil.rmtree(tmp_d, ignore_errors=True)


def check_distinct(paths: list[str | Path], what: str) -> None:
    """DataError when two of ``paths`` are the same file (a path, a link) or two copies of
    the same bytes: pooling data with itself counts every pose twice (standard errors √2 too
    small). ``what`` names the inputs in the message ("data files")."""
    import hashlib

    seen: dict[object, Path] = {}
    sizes: dict[int, list[Path]] = {}
    for raw in paths:
        p = Path(raw)
        key = _identity(p)
        if key in seen:
            raise DataError(
                f"{p}: given twice as {what} (as {seen[key]}): each pose would count twice"
            )
        seen[key] = p
        with contextlib.suppress(OSError):
            sizes.setdefault(p.stat().st_size, []).append(p)
    for same in sizes.values():
        digests: dict[str, Path] = {}
        for p in same if len(same) > 1 else []:
            h = hashlib.sha256()
            try:
                with p.open("rb") as fh:
                    while block := fh.read(1 << 20):
                        h.update(block)
            except OSError:
                continue
            d = h.hexdigest()
            if d in digests:
                raise DataError(
                    f"{p}: the same bytes as {digests[d]} (a copy given twice as {what}): each "
                    "pose would count twice"
                )
            digests[d] = p


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
            doc = json.loads(text)
        except json.JSONDecodeError as exc:
            raise DataError(f"{path}: not a JSON file (line {exc.lineno}: {exc.msg})") from None
        _finite(doc, path, "")
        return doc
    try:
        from ruamel.yaml import YAML
        from ruamel.yaml.error import YAMLError
    except ImportError:  # pragma: no cover - ruamel.yaml ships with the bags extra
        raise MissingExtraError(f"{path}: reading YAML", "bags") from None
    try:
        doc = YAML(typ="safe", pure=True).load(text)
    except YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f"line {mark.line + 1}: " if mark is not None else ""
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        raise DataError(f"{path}: not a YAML file ({where}{problem})") from None
    _finite(doc, path, "")
    return doc
