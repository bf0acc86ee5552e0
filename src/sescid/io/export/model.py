"""``export_model``: the fit's model file in its own format (URDF or MJCF), or a USD layer."""

from __future__ import annotations

from pathlib import Path
from typing import get_args

from sescid.errors import OptionError, check_choice
from sescid.estimation import Fit
from sescid.io.export.assets import missing_assets
from sescid.io.export.mjcf import export_mjcf
from sescid.io.export.payload import export_model_with_payload
from sescid.io.export.urdf import export_urdf
from sescid.io.export.usd import USD_SUFFIXES, export_usd
from sescid.model import ModelFormat

#: model formats ``export_model`` writes
FORMATS: tuple[ModelFormat, ...] = get_args(ModelFormat)


def export_model(
    fit: Fit,
    path: str | Path,
    format: ModelFormat | None = None,
    repair_inertia: bool = False,
    over: str | Path | None = None,
) -> list[str]:
    """Write ``fit.robot``'s model file with the fit's masses and CoMs to ``path``; warnings.

    ``format``: "urdf" or "mjcf" (default: the model's own, ``RobotModel.format``). Export
    edits the model file the fit was made from, so a format other than the model's own raises
    OptionError (no URDF ↔ MJCF conversion). ``repair_inertia``: write inconsistent CAD
    tensors repaired with the smallest change (``sescid.model.repair_inertia``), else such a
    model raises ModelError naming them. A path ending in .usda/.usdc/.usd is written as a
    UsdPhysics layer (``export_usd``: over the robot's USD file ``over``, else standalone).
    """
    if Path(path).suffix.lower() in USD_SUFFIXES:
        if fit.payload is not None:
            raise OptionError("format", f"{path}: a payload fit is exported as URDF or MJCF")
        if format is not None:
            raise OptionError("format", f"{path}: a USD output takes no model format")
        return export_usd(fit, path, over=over, repair_inertia=repair_inertia)
    if over is not None:
        raise OptionError("over", f"{path}: --over applies to a USD output (.usda, .usdc, .usd)")
    own = fit.robot.model.format
    fmt = own if format is None else str(format).lower()
    check_choice("format", fmt, ModelFormat)
    if fmt != own:
        raise OptionError(
            "format",
            f"cannot write {fmt.upper()} from the {own.upper()} model {fit.robot.model_path}: "
            "export edits the inertials of the model file the fit was made from (convert the "
            "model first and identify on it)",
        )
    missing = missing_assets(fit.robot.model_path)
    if fit.payload is not None and fit.inertials is None and fit.payload.base == "model":
        return missing + export_model_with_payload(fit, path)  # the model's masses + payload
    if fmt == "mjcf":
        return missing + export_mjcf(fit, path, repair_inertia=repair_inertia)
    return missing + export_urdf(fit, path, repair_inertia=repair_inertia)
