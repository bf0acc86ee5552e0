"""Data files: pose/CoP tables (CSV, Parquet), the fit JSON, and atomic writes.

Tables have one column per joint, named as the URDF joint, in **radians**, and metres for
``cop_x``, ``cop_y`` (support frame). Optional ``cop_se_x``/``cop_se_y`` (or ``cop_se``) give
per-pose CoP standard errors in metres.

Fit JSON (``"format": "sescid-fit/1"``), keys:
``robot`` {``source`` (embedded name or URDF path), ``name``, ``support``, ``joint_names``,
``body_names``, ``total_mass`` [kg]}, ``method``, ``rank``, ``n_poses``, ``n_rows``, ``rtol``,
``sigma_hat``/``rms``/``mae`` [m], ``r`` and ``r_prior`` {body: [x, y, z] m, body frame},
``r_std`` {body: [..] m}, ``cov`` (3N × 3N, m², order body-major then x, y, z), ``basis``
(3N × rank, orthonormal basis of the identifiable subspace), ``singular_values``,
``base_combinations`` and ``unidentifiable`` (lists of {terms [[body, axis, coef]], label,
value, std, reason}), ``notes`` and ``extra`` (method-specific results).
"""

from __future__ import annotations

import contextlib
import csv
import json
import math
import os
import tempfile
from pathlib import Path

import numpy as np

from .errors import SescidError

FIT_FORMAT = "sescid-fit/1"


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


#: permissions of new output files: what open() would give (mkstemp alone gives 0600)
_FILE_MODE = 0o666 & ~_umask()


@contextlib.contextmanager
def atomic_open(path, mode: str = "w", **kwargs):
    """Open a temporary file beside ``path``; it replaces ``path`` only if the block succeeds."""
    path = Path(path)
    directory = path.parent if str(path.parent) else Path(".")
    if not directory.is_dir():
        raise SescidError(f"{path}: output folder '{directory}' does not exist")
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=directory)
    os.chmod(tmp, _FILE_MODE)
    try:
        with os.fdopen(fd, mode, **kwargs) as fh:
            yield fh
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def atomic_path(path):
    """Context manager yielding a temporary path that replaces ``path`` on success (binary
    writers such as matplotlib or pyarrow)."""
    return _AtomicPath(Path(path))


class _AtomicPath:
    def __init__(self, path: Path):
        self.path = path

    def __enter__(self) -> Path:
        directory = self.path.parent if str(self.path.parent) else Path(".")
        if not directory.is_dir():
            raise SescidError(f"{self.path}: output folder '{directory}' does not exist")
        fd, tmp = tempfile.mkstemp(
            prefix=f".{self.path.stem}.", suffix=self.path.suffix, dir=directory
        )
        os.close(fd)
        os.chmod(tmp, _FILE_MODE)
        self.tmp = Path(tmp)
        return self.tmp

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is None:
            os.replace(self.tmp, self.path)
        else:
            with contextlib.suppress(OSError):
                self.tmp.unlink()


# --- tables ---------------------------------------------------------------------------
class Table:
    """Named float columns read from a file, with the file name for error messages."""

    def __init__(self, path: Path, columns: dict[str, np.ndarray], text: dict[str, list]):
        self.path = path
        self.columns = columns
        self.text = text  #: columns that are not numbers (e.g. labels), as strings
        self.n = len(next(iter(columns.values()))) if columns else 0

    def __contains__(self, name: str) -> bool:
        return name in self.columns

    def names(self) -> list[str]:
        return list(self.columns) + list(self.text)

    def get(self, name: str, what: str = "column") -> np.ndarray:
        """A numeric column; a clear error when it is missing, non-numeric or non-finite."""
        if name in self.text:
            row, value = next((i, v) for i, v in enumerate(self.text[name]) if not _is_number(v))
            raise SescidError(
                f"{self.path}: row {row + 2}, column '{name}': '{value}' is not a number"
            )
        if name not in self.columns:
            raise SescidError(f"{self.path}: missing {what} '{name}'")
        col = self.columns[name]
        bad = np.flatnonzero(~np.isfinite(col))
        if bad.size:
            raise SescidError(
                f"{self.path}: row {bad[0] + 2}, column '{name}': value {col[bad[0]]} is not finite"
            )
        return col


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def read_table(path) -> Table:
    """Read a CSV (header row) or Parquet file into float columns (text columns kept apart)."""
    path = Path(path)
    if not path.is_file():
        raise SescidError(f"{path}: file not found")
    if path.suffix.lower() in (".parquet", ".pq"):
        return _read_parquet(path)
    try:
        with path.open(newline="") as fh:
            rows = list(csv.reader(fh))
    except (OSError, UnicodeDecodeError) as exc:
        raise SescidError(f"{path}: cannot read ({exc.__class__.__name__})") from None
    rows = [r for r in rows if r and not (len(r) == 1 and not r[0].strip())]
    if not rows:
        raise SescidError(f"{path}: empty file (expected a header row)")
    header = [h.strip() for h in rows[0]]
    if len(set(header)) != len(header):
        dup = next(h for h in header if header.count(h) > 1)
        raise SescidError(f"{path}: column '{dup}' appears twice in the header")
    body = rows[1:]
    if not body:
        raise SescidError(f"{path}: no data rows")
    for i, r in enumerate(body):
        if len(r) != len(header):
            raise SescidError(
                f"{path}: row {i + 2} has {len(r)} fields, the header has {len(header)}"
            )
    columns, text = {}, {}
    for j, name in enumerate(header):
        values = [r[j].strip() for r in body]
        try:
            columns[name] = np.array([float(v) for v in values])
        except ValueError:
            text[name] = values
    return Table(path, columns, text)


def _read_parquet(path: Path) -> Table:
    try:
        import pyarrow.parquet as pq
    except ImportError:  # pragma: no cover - optional dependency
        raise SescidError(f"{path}: reading Parquet needs pyarrow (pip install pyarrow)") from None
    try:
        tab = pq.read_table(path)
    except Exception as exc:
        raise SescidError(f"{path}: cannot read Parquet ({str(exc).splitlines()[0]})") from None
    columns, text = {}, {}
    for name in tab.column_names:
        col = tab.column(name).to_pylist()
        try:
            columns[name] = np.array([np.nan if v is None else float(v) for v in col])
        except (TypeError, ValueError):
            text[name] = ["" if v is None else str(v) for v in col]
    if not columns and not text:
        raise SescidError(f"{path}: no columns")
    return Table(path, columns, text)


def write_table(path, columns: dict[str, np.ndarray]) -> None:
    """Write float (or string) columns as CSV (or Parquet by suffix), atomically.

    Floats are written in their shortest exact form, so a CSV round trip is lossless.
    """
    path = Path(path)
    names = list(columns)
    cols = [np.asarray(columns[k]) for k in names]
    if path.suffix.lower() in (".parquet", ".pq"):
        import pyarrow as pa
        import pyarrow.parquet as pq

        with atomic_path(path) as tmp:
            pq.write_table(pa.table(dict(zip(names, cols, strict=True))), tmp)
        return
    with atomic_open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(names)
        text = [c.tolist() for c in cols]  # Python floats: repr is the shortest exact form
        w.writerows(zip(*text, strict=True))


def read_poses(table: Table, joint_names: list[str]) -> np.ndarray:
    """Joint angles (n, nq) in radians from columns named as the joints.

    Values beyond ±2π cannot be radians of a revolute joint: they are taken for degrees and
    rejected with a message saying so.
    """
    missing = [j for j in joint_names if j not in table.columns and j not in table.text]
    if missing:
        more = f" (and {len(missing) - 1} more)" if len(missing) > 1 else ""
        raise SescidError(f"{table.path}: missing joint column '{missing[0]}'{more}")
    q = np.column_stack([table.get(j, "joint column") for j in joint_names])
    big = np.argwhere(np.abs(q) > 2 * math.pi)
    if big.size:
        i, j = big[0]
        raise SescidError(
            f"{table.path}: row {i + 2}, column '{joint_names[j]}': {q[i, j]:g} looks like "
            "degrees; joint columns are in radians"
        )
    return q


def read_cop(table: Table) -> np.ndarray:
    """Measured CoP (n, 2) in metres from ``cop_x``, ``cop_y``."""
    cop = np.column_stack([table.get("cop_x"), table.get("cop_y")])
    big = np.argwhere(np.abs(cop) > 2.0)
    if big.size:
        i, j = big[0]
        raise SescidError(
            f"{table.path}: row {i + 2}, column 'cop_{'xy'[j]}': {cop[i, j]:g} m is not a "
            "plausible CoP (columns are in metres)"
        )
    return cop


def read_cop_se(table: Table) -> np.ndarray | None:
    """Per-pose CoP standard errors (n, 2) in m, if the table has them."""
    if "cop_se_x" in table or "cop_se_y" in table:
        return np.column_stack([table.get("cop_se_x"), table.get("cop_se_y")])
    if "cop_se" in table:
        return table.get("cop_se")
    return None


# --- fits -------------------------------------------------------------------------------
def _num(x: float):
    return None if x is None or (isinstance(x, float) and math.isnan(x)) else float(x)


def fit_to_json(fit) -> dict:
    robot = fit.robot
    bodies = robot.body_names
    return {
        "format": FIT_FORMAT,
        "robot": {
            "source": robot.source,
            "name": robot.name,
            "support": robot.support,
            "joint_names": robot.joint_names,
            "body_names": bodies,
            "total_mass": robot.total_mass,
        },
        "method": fit.method,
        "rank": fit.rank,
        "n_poses": fit.n_poses,
        "n_rows": fit.n_rows,
        "rtol": fit.rtol,
        "sigma_hat": _num(fit.sigma_hat),
        "rms": _num(fit.rms),
        "mae": _num(fit.mae),
        "units": "m (r, r_std, sigma_hat, rms, mae), m^2 (cov)",
        "r": {b: fit.r[i].tolist() for i, b in enumerate(bodies)},
        "r_prior": {b: fit.r_prior[i].tolist() for i, b in enumerate(bodies)},
        "r_std": {b: np.nan_to_num(fit.r_std[i]).tolist() for i, b in enumerate(bodies)},
        "cov": np.nan_to_num(fit.cov).tolist(),
        "basis": fit.basis.tolist(),
        "singular_values": fit.singular_values.tolist(),
        "base_combinations": [c.to_json() for c in fit.base],
        "unidentifiable": [c.to_json() for c in fit.unidentifiable],
        "notes": list(fit.notes),
        "extra": fit.extra,
    }


def save_fit(fit, path) -> None:
    """Write a fit as JSON, atomically."""
    with atomic_open(path, "w") as fh:
        json.dump(fit_to_json(fit), fh, indent=1)
        fh.write("\n")


def read_json(path, fmt: str, what: str) -> dict:
    """A JSON object whose ``"format"`` is ``fmt``; one-line errors naming the file."""
    path = Path(path)
    if not path.is_file():
        raise SescidError(f"{path}: file not found")
    try:
        data = json.loads(path.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise SescidError(f"{path}: not a JSON file ({exc.__class__.__name__})") from None
    if not isinstance(data, dict) or data.get("format") != fmt:
        raise SescidError(f'{path}: not {what} (expected "format": "{fmt}")')
    return data


def load_fit(path):
    """Read a fit written by ``Fit.save``; reloads its robot (embedded model or URDF)."""
    from .estimate import Combination, Fit
    from .robot import load_robot

    path = Path(path)
    data = read_json(path, FIT_FORMAT, "a sescid fit")
    try:
        meta = data["robot"]
        robot = load_robot(meta["source"], meta["support"])
        if robot.body_names != meta["body_names"] or robot.joint_names != meta["joint_names"]:
            raise SescidError(
                f"{path}: the robot '{meta['source']}' no longer has the bodies/joints this "
                "fit was made for"
            )
        bodies = robot.body_names
        r = np.array([data["r"][b] for b in bodies], dtype=float)
        r_prior = np.array([data["r_prior"][b] for b in bodies], dtype=float)
        nan = float("nan")
        fit = Fit(
            robot=robot,
            r=r,
            r_prior=r_prior,
            cov=np.array(data["cov"], dtype=float),
            basis=np.array(data["basis"], dtype=float).reshape(r.size, -1),
            singular_values=np.array(data["singular_values"], dtype=float),
            rank=int(data["rank"]),
            n_poses=int(data["n_poses"]),
            n_rows=int(data["n_rows"]),
            sigma_hat=nan if data["sigma_hat"] is None else float(data["sigma_hat"]),
            rms=nan if data["rms"] is None else float(data["rms"]),
            mae=nan if data["mae"] is None else float(data["mae"]),
            rtol=float(data["rtol"]),
            method=data["method"],
            base=[Combination.from_json(c) for c in data["base_combinations"]],
            unidentifiable=[Combination.from_json(c) for c in data["unidentifiable"]],
            notes=list(data.get("notes", [])),
            extra=dict(data.get("extra", {})),
        )
    except SescidError:
        raise
    except (KeyError, TypeError, ValueError) as exc:
        raise SescidError(f"{path}: malformed fit file ({exc.__class__.__name__}: {exc})") from None
    return fit
