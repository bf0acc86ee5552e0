"""``sescid.identify``: the estimation entry point, reading measurement files too.

``identify(robot, data, …)`` accepts everything ``sescid.estimation.identify`` does (arrays,
``Measurements``, lists of them, chunks) and also a file path or a list of paths (CSV or
Parquet, see ``sescid.io.measurements``): each file is one source, streamed once (flat memory
for any number of poses) and pooled with the others. The options are the same typed
``IdentifyOptions``, whose ``imu_link`` names the IMU link when the files carry its roll and
pitch, and whose ``allow_outside_limits`` accepts poses outside the model's joint limits (else an
error names the first one; simulated data only warn).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from sescid.estimation import Fit, IdentifyOptions
from sescid.estimation import identify as _identify
from sescid.io.measurements import ReadReport, read_measurements
from sescid.robot import Robot

__all__ = ["file_stance", "identify"]


def _is_path(x: Any) -> bool:
    return isinstance(x, str | Path)


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
    method: str = "auto",
    options: IdentifyOptions | None = None,
    progress: Any = None,
    **overrides: Any,
) -> Fit:
    """Identify from files or arrays (see ``sescid.estimation.identify`` for the rest).

    ``data``: a path, a list of paths (pooled), or anything ``estimation.identify`` takes; a
    path ``FILE@FRAME`` reads FILE as measured in the stance FRAME (``file_stance``), a
    ``support`` column names each row's stance.
    Poses outside the limits of a file that allows them (or of simulated data) are a warning
    stored in the fit.
    """
    paths = [data] if _is_path(data) else data
    if not (isinstance(paths, list | tuple) and paths and all(_is_path(p) for p in paths)):
        return _identify(
            robot, data, cop, method=method, options=options, progress=progress, **overrides
        )
    if cop is not None:
        raise TypeError("cop= goes with joint angles, not with files")
    opts = (options or IdentifyOptions()).with_overrides(**overrides)
    got: list[ReadReport] = []
    streams = []
    for given in paths:
        p, stance = file_stance(given)
        rep = ReadReport(str(p))
        got.append(rep)
        streams.append(
            read_measurements(
                p, robot, imu_link=opts.imu_link,
                allow_outside_limits=opts.allow_outside_limits, report=rep, support=stance,
            )
        )  # fmt: skip
    fit = _identify(robot, streams, method=method, options=opts, progress=progress)
    notes = [m for m in (r.limit_message() for r in got) if m is not None]
    if notes:
        import dataclasses

        fit = dataclasses.replace(fit, warnings=tuple(notes) + fit.warnings)
    return fit
