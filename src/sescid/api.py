"""``sescid.identify``: the one entry point of an identification, from files or arrays.

``identify(robot, data, …)`` takes a file path or a list of paths (CSV or Parquet, see
``sescid.io.measurements``: each file is one source, streamed once — flat memory for any number
of poses — and pooled with the others), a ``Measurements``, a list of them, chunks of one data
set, or joint angles with ``cop=``. ``method`` names the method or is its options object;
``options`` holds what every method shares (``IdentifyOptions``, whose ``imu_link`` names the IMU
link when files carry its roll and pitch, and whose ``allow_outside_limits`` accepts poses
outside the model's joint limits, else an error names the first one; simulated data only warn).
The estimation itself is ``sescid.estimation.fit_measurements``.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from sescid.base.files import check_distinct
from sescid.errors import DataError, OptionError
from sescid.estimation import (
    Fit,
    IdentifyOptions,
    Measurements,
    MethodName,
    MethodOptions,
    PayloadOptions,
    check_base,
    check_payload,
    fit_measurements,
    payload_fit,
)
from sescid.io.measurements import ReadReport, read_measurements
from sescid.robot import Robot

__all__ = ["file_stance", "identify", "identify_payload"]


def _is_path(x: Any) -> bool:
    return isinstance(x, str | Path)


def _paths(data: Any) -> list | None:
    """The data files given (a path or a list of paths), or None for data of another form."""
    paths = [data] if _is_path(data) else data
    ok = isinstance(paths, list | tuple) and paths and all(_is_path(p) for p in paths)
    return list(paths) if ok else None


def _read_files(robot: Robot, paths: list, opts: IdentifyOptions, reports: list | None) -> list:
    """Each file (``FILE@FRAME``: in the stance FRAME, ``file_stance``) as a stream of
    ``Measurements``, read once; ``reports``: each file's ``ReadReport`` appended there."""
    check_distinct([file_stance(g)[0] for g in paths], "data")
    streams = []
    for given in paths:
        p, stance = file_stance(given)
        rep = None if reports is None else ReadReport(str(p))
        if reports is not None:
            reports.append(rep)
        streams.append(
            read_measurements(
                p, robot, imu_link=opts.imu_link,
                allow_outside_limits=opts.allow_outside_limits, report=rep, support=stance,
            )
        )  # fmt: skip
    return streams


def _arrays(data: Any, cop: Any, sigma: Any, gravity: Any) -> Any:
    """Joint angles with ``cop=`` (and ``sigma=``, ``gravity=``) as Measurements; anything
    else as given."""
    if cop is None:
        if sigma is not None or gravity is not None:
            raise OptionError("sigma", "sigma= and gravity= go with joint angles and cop=")
        return data
    if isinstance(data, Measurements):
        raise OptionError("cop", "give cop= with joint angles, not with Measurements")
    return Measurements(
        q=np.asarray(data, dtype=float),
        cop=np.asarray(cop, dtype=float),
        cop_se=None if sigma is None else _se(sigma, np.shape(data)[0]),
        gravity=None if gravity is None else np.asarray(gravity, dtype=float),
        source="data",
    )


def _se(sigma: Any, n: int) -> np.ndarray:
    s = np.asarray(sigma, dtype=float)
    if s.ndim == 1:
        if s.shape != (n,):
            raise DataError(f"sigma: expected shape ({n},) or ({n}, 2) in metres, got {s.shape}")
        s = np.repeat(s[:, None], 2, axis=1)
    return s


def file_stance(path: str | Path) -> tuple[Path, str | None]:
    """A data file and the stance its rows were measured in: ``FILE@FRAME`` (the file
    ``FILE``, rows without a ``support`` column in the stance ``FRAME``: the other foot, a held
    link) unless a file of that whole name exists; (path, None) otherwise."""
    p = Path(path)
    if "@" in p.name and not p.exists():
        name, frame = p.name.rsplit("@", 1)
        return p.with_name(name), frame
    return p, None


def identify(
    robot: Robot,
    data: Any,
    cop: Any = None,
    *,
    method: MethodName | MethodOptions = "auto",
    options: IdentifyOptions | None = None,
    sigma: Any = None,
    gravity: Any = None,
    progress: Callable[[int, int | None], None] | None = None,
    **overrides: Any,
) -> Fit:
    """Identify the SESC vectors (and sensor offsets) from static poses and what was measured.

    ``data``: a path or a list of paths (pooled; ``FILE@FRAME`` reads FILE as measured in the
    stance FRAME, ``file_stance``, and a ``support`` column names each row's stance), a
    ``Measurements`` (q (n, nq) rad with a CoP
    (n, 2) m and/or joint torques (n, J) N·m), a list of them, chunks of one data set; or joint
    angles with ``cop=`` (n, 2) m, optional ``sigma=`` per-pose CoP standard errors (n,) or
    (n, 2) m (a weighted fit) and ``gravity=`` per-pose gravity directions (n, 3) in the support
    frame. ``method``: "auto" (the default: MAP with the CAD prior when the data leave
    directions weakly determined, least squares when they determine every direction well;
    ``fit.choice`` says which and why), "ls" (least squares, the paper's), "map" (Gaussian CAD
    prior) or "consistent" (physical masses/CoMs) with their default options, or an options
    object naming its method (``MapOptions(…)``, ``AutoOptions(…)``, ``ConsistentOptions(…)``).
    ``options``: ``IdentifyOptions``; keyword ``overrides`` replace its fields (``rtol=``,
    ``robust=``, ``total_mass=`` …). ``progress(poses_done, total)`` is called while the
    normal equations are accumulated. Warnings (data quality, poses outside the limits of a
    file that allows them or of simulated data) are stored in ``fit.warnings``.
    """
    opts = (options or IdentifyOptions()).with_overrides(**overrides)
    if sigma is not None:
        opts = dataclasses.replace(opts, weighted=True)
    paths = _paths(data)
    if paths is None:
        data = _arrays(data, cop, sigma, gravity)
        return fit_measurements(robot, data, method=method, options=opts, progress=progress)
    if cop is not None or sigma is not None or gravity is not None:
        raise OptionError("cop", "cop=, sigma= and gravity= go with joint angles, not with files")
    got: list[ReadReport] = []
    streams = _read_files(robot, paths, opts, got)
    fit = fit_measurements(robot, streams, method=method, options=opts, progress=progress)
    notes = [m for r in got for m in (r.limit_message(), r.missing_message()) if m is not None]
    if notes:
        fit = dataclasses.replace(fit, warnings=tuple(notes) + fit.warnings)
    return fit


#: the ``IdentifyOptions`` a payload fit uses (any other changed from its default is refused)
PAYLOAD_OPTIONS = ("rtol", "cop_noise", "tau_noise", "gravity_accel", "kinds", "imu_link",
                   "allow_outside_limits", "seed", "huber_k", "mc_draws", "gain_prior")  # fmt: skip


def _same(a: Any, b: Any) -> bool:
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return a is b
    return bool(a == b)


def identify_payload(
    robot: Robot,
    data: Any,
    body: str,
    *,
    mass: float | None = None,
    base: Fit | None = None,
    options: IdentifyOptions | None = None,
    **overrides: Any,
) -> Fit:
    """Identify a payload on the link ``body``: its mass [kg] (``mass``: weighed, not
    identified) and CoM [m, ``body``'s frame], the robot's own masses kept as the base.

    ``base``: a previous fit of this robot (any method, any stance; ``load_fit``) or None for
    the model file's masses. ``data`` as ``identify``'s (files, ``Measurements`` or a list of
    them; any kind and stance). ``options``/``overrides``: the ``IdentifyOptions`` that apply
    (``rtol``, ``cop_noise``, ``tau_noise``, ``gravity_accel``, ``kinds``, ``imu_link``,
    ``allow_outside_limits``). Returns the robot with its payload as a ``Fit`` (its r and total
    mass include it; ``fit.payload`` the payload with its standard errors, nan for what the
    poses do not determine and why) — ``estimation.payload``.
    """
    opts = (options or IdentifyOptions()).with_overrides(**overrides)
    idle = [
        f.name
        for f in dataclasses.fields(IdentifyOptions)
        if f.name not in PAYLOAD_OPTIONS
        and not _same(getattr(opts, f.name), getattr(IdentifyOptions(), f.name))
    ]
    if idle:
        more = f" (nor {', '.join(idle[1:])})" if idle[1:] else ""
        why = (
            "give the payload's weighed mass instead (mass=, --payload-mass)"
            if idle[0] == "total_mass"
            else "only the payload is fitted, each kind's noise estimated or given (cop_noise, "
            "tau_noise)"
        )
        raise OptionError(idle[0], f"does not apply to a payload fit{more}: {why}")
    if base is not None:
        check_base(robot, base, "base")
    check_payload(robot, body, mass)
    paths = _paths(data)
    chunks: list[Measurements] = []
    if paths is not None:
        chunks = [m for stream in _read_files(robot, paths, opts, None) for m in stream]
    elif isinstance(data, Measurements):
        chunks = [data]
    elif isinstance(data, list | tuple) and all(isinstance(d, Measurements) for d in data):
        chunks = list(data)
    else:
        raise DataError("identify_payload: data must be files, Measurements or a list of them")
    chunks = [c.only(opts.kinds).checked(robot) for c in chunks]
    popts = PayloadOptions(
        body, mass, opts.cop_noise, opts.tau_noise, opts.gravity_accel, opts.rtol
    )
    return payload_fit(robot, chunks, popts, base)
