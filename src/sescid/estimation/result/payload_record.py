"""What a payload identification gives: the payload's mass and CoM on a body, their errors.

``PayloadFit`` is the typed record a ``Fit`` carries as ``fit.payload`` (``estimation.payload``
makes it); ``payload_to_json`` / ``payload_from_json`` are its part of the fit file (lengths
in m, masses in kg, a quantity the data do not determine is ``null``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from sescid.errors import DataError
from sescid.estimation.result.records import json_ready


@dataclass(frozen=True)
class PayloadKind:
    """One measurement kind's share of a payload fit: rows, noise and residuals."""

    kind: str  #: "cop", "tau" or "balance"
    n_rows: int
    sigma: float  #: noise standard deviation (m, N·m, rad), estimated or given
    sigma_by: str  #: "given" or "residuals"
    dof: float  #: residual degrees of freedom of this kind
    rms: float  #: residual RMS per row, in the kind's unit


@dataclass(frozen=True)
class PayloadFit:
    """A payload of mass ``mass`` [kg] with its CoM at ``com`` (3,) [m] in the frame of the
    model link ``body``, identified on a base model of the robot's own masses.

    A component the data do not determine is nan (``unseen`` names it, ``reason`` says why,
    ``more_poses`` how many more poses that turn ``body`` would determine it; None when no pose
    of these kinds can). ``cov`` (4, 4) is the covariance of (mass, com) [kg, m] (its mass row
    and column are 0 with a weighed mass)."""

    body: str  #: the model link the payload is fixed to
    mass: float  #: kg
    com: np.ndarray  #: (3,) m, in ``body``'s frame
    mass_std: float  #: kg (0 for a weighed mass)
    com_std: np.ndarray  #: (3,) m
    cov: np.ndarray  #: (4, 4) of (mass, com_x, com_y, com_z)
    mass_given: bool  #: the payload was weighed (its mass not identified)
    base: str  #: "model" (the model file's masses) or the base fit ("fit: <method>")
    base_mass: float  #: kg, the robot without its payload
    n_poses: int
    n_rows: int
    kinds: tuple[PayloadKind, ...] = ()
    unseen: tuple[str, ...] = ()  #: components not determined ("mass", "com_x", …)
    reason: str = ""
    more_poses: int | None = 0
    stances: tuple[str, ...] = ()  #: supports the data were measured in

    @property
    def total_mass(self) -> float:
        """kg, the robot with its payload (nan when the payload's mass is not determined)."""
        return self.base_mass + self.mass

    def summary(self) -> str:
        """One or two lines: the payload's mass and CoM with their standard errors."""
        if self.mass_given:
            mass = f"{self.mass:.4g} kg (weighed)"
        elif math.isfinite(self.mass):
            mass = f"{self.mass:.4g} ± {self.mass_std:.2g} kg"
        else:
            mass = "mass not determined"
        parts = []
        for a, v, s in zip("xyz", self.com, self.com_std, strict=True):
            parts.append(
                f"{a} {v * 1e3:.1f} ± {s * 1e3:.1f}" if math.isfinite(v) else f"{a} not determined"
            )
        line = f"payload on {self.body}: {mass}, CoM ({', '.join(parts)}) mm in {self.body}'s frame"
        if self.unseen:
            line += f"\n  {self.reason}"
        return line


def payload_to_json(p: PayloadFit) -> dict:
    """The fit file's ``payload`` object."""
    return {
        "body": p.body,
        "mass": json_ready(p.mass),
        "com": json_ready(p.com),
        "mass_std": json_ready(p.mass_std),
        "com_std": json_ready(p.com_std),
        "cov": json_ready(p.cov),
        "mass_given": p.mass_given,
        "base": p.base,
        "base_mass": p.base_mass,
        "n_poses": p.n_poses,
        "n_rows": p.n_rows,
        "kinds": [
            {
                "kind": k.kind,
                "n_rows": k.n_rows,
                "sigma": json_ready(k.sigma),
                "sigma_by": k.sigma_by,
                "dof": json_ready(k.dof),
                "rms": json_ready(k.rms),
            }
            for k in p.kinds
        ],  # fmt: skip
        "unseen": list(p.unseen),
        "reason": p.reason,
        "more_poses": p.more_poses,
        "stances": list(p.stances),
    }


def _f(v: Any) -> float:
    return math.nan if v is None else float(v)


def _arr(v: Any, shape: tuple[int, ...], where: str) -> np.ndarray:
    flat = [math.nan if x is None else float(x) for x in np.ravel(np.array(v, dtype=object))]
    if len(flat) != math.prod(shape):
        raise DataError(f"{where}: a payload field has {len(flat)} numbers, expected {shape}")
    return np.array(flat, dtype=float).reshape(shape)


def payload_from_json(d: dict, where: str) -> PayloadFit:
    """A ``PayloadFit`` from the fit file's ``payload`` object (DataError naming ``where``)."""
    try:
        return PayloadFit(
            body=str(d["body"]),
            mass=_f(d["mass"]),
            com=_arr(d["com"], (3,), where),
            mass_std=_f(d["mass_std"]),
            com_std=_arr(d["com_std"], (3,), where),
            cov=_arr(d["cov"], (4, 4), where),
            mass_given=bool(d["mass_given"]),
            base=str(d.get("base", "")),
            base_mass=float(d["base_mass"]),
            n_poses=int(d["n_poses"]),
            n_rows=int(d["n_rows"]),
            kinds=tuple(
                PayloadKind(
                    str(k["kind"]),
                    int(k["n_rows"]),
                    _f(k["sigma"]),
                    str(k["sigma_by"]),
                    _f(k["dof"]),
                    _f(k["rms"]),
                )
                for k in d.get("kinds", [])
            ),  # fmt: skip
            unseen=tuple(str(u) for u in d.get("unseen", [])),
            reason=str(d.get("reason", "")),
            more_poses=None if d.get("more_poses") is None else int(d["more_poses"]),
            stances=tuple(str(s) for s in d.get("stances", [])),
        )
    except (KeyError, TypeError, ValueError) as exc:
        raise DataError(f"{where}: malformed payload ({exc.__class__.__name__}: {exc})") from None
