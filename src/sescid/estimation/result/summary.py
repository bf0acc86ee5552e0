"""A fit in a few lines for the terminal: method, poses, rank, each kind's noise and residuals,
its notes and warnings (``sescid identify`` prints it)."""

from __future__ import annotations

import math

from sescid.estimation.result.fit import Fit
from sescid.estimation.result.notes import fit_notes
from sescid.estimation.result.records import KindFit


def fit_summary(fit: Fit) -> str:
    """A few lines: method, poses, rank, each kind's noise and residuals, notes, warnings."""
    lines = [
        f"{fit.method_label if fit.payload is None else 'payload'} fit of {fit.robot.name} "
        f"(support {fit.robot.support}): "
        f"{fit.n_poses} poses, rank {fit.rank} of {fit.r.size}"
    ]
    kinds = fit.kinds or (None,)
    for k in kinds:
        lines.append("  " + _kind_line(fit, k))
    lines += [f"  note: {n}" for n in fit_notes(fit)]
    lines += [f"  warning: {w}" for w in fit.warnings]
    return "\n".join(lines)


def _number(x: float, unit: str) -> str:
    """A value in a kind's display unit: mm for metres, N·m as is; "not determined" for nan."""
    if not math.isfinite(x):
        return "not determined"
    if unit == "rad":  # an angle: degrees at the boundary
        return f"{math.degrees(x):.3f}°"
    return f"{x * 1e3:.3f} mm" if unit == "m" else f"{x:.4f} {unit}"


def _kind_line(fit: Fit, k: KindFit | None) -> str:
    """One kind's noise and residuals (the fit's own figures for a fit without kinds)."""
    if k is None or len(fit.kinds) == 1:
        unit = "m" if k is None else k.unit
        weighted = fit.weighted
        sigma, rms, mae, name = fit.sigma_hat, fit.rms, fit.mae, "" if k is None else k.kind
    else:
        unit, weighted, sigma, rms, mae, name = k.unit, k.weighted, k.sigma, k.rms, k.mae, k.kind
    label = {"cop": "CoP", "tau": "joint torques", "balance": "balance tilt"}.get(name, name)
    head = f"{label}: " if label else ""
    if weighted:
        scale = "not determined" if not math.isfinite(sigma) else f"{sigma:.3f}"
        noise = f"sigma_hat {scale} (scale of normalised residuals)"
    else:
        noise = f"sigma_hat {_number(sigma, unit)}"
    if k is not None and k.sigma_by == "given":
        noise += " (given)"
    out = f"{head}{noise}, residual RMS {_number(rms, unit)}"
    return out + ("" if math.isnan(mae) else f", MAE {_number(mae, unit)}")


__all__ = ["fit_summary"]
