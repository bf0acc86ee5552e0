"""What an audit reports: per candidate its errors per kind, the body changes the data ask of
it and its model checks; the ranking and the verdict, as text and JSON."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sescid.audit.checks import Check
from sescid.audit.linear import ALL_BODIES, Named
from sescid.estimation.result.records import json_ready
from sescid.robot import Robot

#: display unit of each kind: (JSON suffix, factor from SI, printed unit)
AUDIT_UNITS = {
    "cop": ("mm", 1e3, "mm"),
    "tau": ("Nm", 1.0, "N·m"),
    "balance": ("deg", 180 / math.pi, "°"),
}
AUDIT_TITLES = {"cop": "CoP", "tau": "torques", "balance": "balance tilt"}


@dataclass(frozen=True)
class KindError:
    """One kind's errors for a candidate, SI (m, N·m, rad): ``AUDIT_UNITS`` converts them."""

    kind: str
    rows: int
    noise: float  #: the data's noise standard deviation
    #: RMS of measured − the file's prediction (a torque sensor's offset and friction band are
    #: fitted aside: sescid's fits estimate them too, they are not the file's)
    prediction: float
    cv: float  #: RMS of measured − held-out prediction of a MAP fit with the file as prior


@dataclass(frozen=True)
class BodyChange:
    """A change the data ask of a candidate (data − file), beyond its noise."""

    bodies: tuple[str, ...]
    change: float  #: kg, the mass change
    std: float  #: kg
    z: float  #: significance of the body's change (mass and first moment), two-sided z
    first_moment: tuple[float, float, float]  #: kg·m, body frame (nan for every body)
    first_moment_std: tuple[float, float, float]
    com_shift: float  #: m, how far the body's CoM moves (nan when not defined)
    share: float  #: the change as a share of the file's mass of those bodies
    #: bodies whose change would explain the data as well (the data cannot tell them apart)
    alternatives: tuple[str, ...] = ()

    def text(self) -> str:
        """One line in plain words."""
        alt = self.alternatives
        if not alt:
            return self._text()
        more = " …" if len(alt) > 3 else ""
        other = "other body" if len(alt) == 1 else "other bodies"
        return self._text() + f" (or {len(alt)} {other} as well: {', '.join(alt[:3])}{more})"

    def _text(self) -> str:
        who = "every body" if self.bodies == (ALL_BODIES,) else self.bodies[0]
        more = "more" if self.change > 0 else "less"
        mass_seen = abs(self.change) >= 2 * self.std and abs(self.change) > 0
        if self.bodies == (ALL_BODIES,):
            return (
                f"{who} carries {abs(self.share) * 100:.1f} % {more} mass than this file says "
                f"({abs(self.change):.3f} ± {self.std:.3f} kg in all, z {self.z:.1f})"
            )
        shift = (
            ""
            if not math.isfinite(self.com_shift)
            else f"its CoM {self.com_shift * 1e3:.1f} mm off"
        )
        if mass_seen:
            out = f"{who} carries {abs(self.change):.3f} ± {self.std:.3f} kg {more}"
            out += " than this file says"
            return out + (f", {shift}" if shift else "") + f" (z {self.z:.1f})"
        return (
            f"{who}: {shift or 'its first moment differs'}, mass as the file says (z {self.z:.1f})"
        )

    def to_json(self) -> dict:
        """The JSON entry: bodies, change, std, z and the first-moment details."""
        return {
            "bodies": list(self.bodies),
            "change": self.change,
            "std": self.std,
            "z": self.z,
            "first_moment": json_ready(self.first_moment),
            "first_moment_std": json_ready(self.first_moment_std),
            "com_shift_mm": None if not math.isfinite(self.com_shift) else self.com_shift * 1e3,
            "alternatives": list(self.alternatives),
            "text": self.text(),
        }


def none_if_nan(x: float) -> float | None:
    """JSON's null for a number that is not finite (not determined)."""
    return None if not math.isfinite(x) else float(x)


@dataclass(frozen=True)
class CandidateAudit:
    """One candidate file's audit."""

    model: str  #: the path (or name) as given
    total_mass: float  #: kg, the file's
    mass_gap: float  #: kg, weighed − file (nan without a weighed mass)
    errors: tuple[KindError, ...]
    score: float  #: mean squared normalised misfit (1: within the noise)
    z_overall: float  #: significance of everything the data see against this file
    rank: int  #: 1 = best
    rejected: tuple[BodyChange, ...]
    checks: tuple[Check, ...]

    def error(self, kind: str) -> KindError | None:
        """The record of one kind, None when the data have none."""
        return next((e for e in self.errors if e.kind == kind), None)

    def to_json(self) -> dict:
        """The candidate's JSON object (``audit`` docs)."""
        pred, cv, noise = {}, {}, {}
        for e in self.errors:
            suffix, f, _ = AUDIT_UNITS[e.kind]
            pred[f"{e.kind}_{suffix}"] = none_if_nan(e.prediction * f)
            cv[f"{e.kind}_{suffix}"] = none_if_nan(e.cv * f)
            noise[f"{e.kind}_{suffix}"] = none_if_nan(e.noise * f)
        return {
            "model": self.model,
            "rank": self.rank,
            "total_mass": self.total_mass,
            "mass_gap": none_if_nan(self.mass_gap),
            "prediction_error": pred,
            "cv_error": cv,
            "noise": noise,
            "score": self.score,
            "z_overall": self.z_overall,
            "rejected": [r.to_json() for r in self.rejected],
            "checks": [c.to_json() for c in self.checks],
        }


@dataclass(frozen=True)
class AuditResult:
    """``audit``'s answer: every candidate (in the order given) and the verdict."""

    candidates: tuple[CandidateAudit, ...]
    weighed_mass: float  #: kg (nan: not given)
    n_poses: int
    level: float  #: the z a change must reach to be named
    folds: int

    @property
    def ranked(self) -> list[CandidateAudit]:
        """The candidates best first."""
        return sorted(self.candidates, key=lambda c: c.rank)

    @property
    def best(self) -> CandidateAudit:
        """The rank-1 candidate."""
        return self.ranked[0]

    def verdict(self) -> str:
        """The verdict in plain words (a few lines)."""
        best = self.best
        ok = not best.rejected
        lines = [
            f"best: {best.model} "
            + (
                "— the data agree with it within their noise"
                if ok
                else "— closest to the data, but the data still reject part of it"
            )
        ]
        for c in self.ranked:
            if c.rejected:
                lines.append(
                    f"{c.model}: the data reject it: " + "; ".join(r.text() for r in c.rejected)
                )
            if c.checks:
                lines.append(f"{c.model}: {len(c.checks)} model check(s) fail")
        return "\n".join(lines)

    def text(self) -> str:
        """The ranking table and the verdict, for the terminal."""
        kinds = [e.kind for e in self.candidates[0].errors]
        head = f"audit of {len(self.candidates)} candidate(s) on {self.n_poses} poses"
        if math.isfinite(self.weighed_mass):
            head += f", weighed {self.weighed_mass:.3f} kg"
        lines = [head]
        for e in self.candidates[0].errors:
            suffix, f, unit = AUDIT_UNITS[e.kind]
            title = AUDIT_TITLES[e.kind]
            lines.append(f"  {title} noise of the data: {e.noise * f:.3g} {unit} ({e.rows} rows)")
        for c in self.ranked:
            parts = [f"#{c.rank} {c.model}: {c.total_mass:.3f} kg"]
            if math.isfinite(c.mass_gap):
                parts.append(f"gap {c.mass_gap:+.3f} kg")
            for k in kinds:
                e = c.error(k)
                assert e is not None
                _, f, unit = AUDIT_UNITS[k]
                cv = f" (cv {e.cv * f:.3g})" if math.isfinite(e.cv) else ""
                parts.append(f"{AUDIT_TITLES[k]} {e.prediction * f:.3g} {unit}{cv}")
            parts.append(f"score {c.score:.2f}")
            lines.append("  " + ", ".join(parts))
            for r in c.rejected:
                lines.append(f"      rejected: {r.text()}")
            for ch in c.checks:
                lines.append(f"      check: {ch.body}: {ch.problem}")
        return "\n".join(lines + ["verdict: " + self.verdict().replace("\n", "\n  ")])

    def to_json(self) -> dict:
        """The whole audit as JSON (``--json``)."""
        return {
            "format": "sescid-audit",
            "weighed_mass": none_if_nan(self.weighed_mass),
            "n_poses": self.n_poses,
            "z_level": self.level,
            "folds": self.folds,
            "best": self.best.model,
            "verdict": self.verdict(),
            "candidates": [c.to_json() for c in self.ranked],
        }


def body_change(x: Named, masses: np.ndarray, robot: Robot) -> BodyChange:
    """A named change as the record audit and compare report (its share of the file's mass)."""
    if x.bodies == (ALL_BODIES,):
        base = float(masses.sum())
    else:
        base = float(masses[robot.body_names.index(x.bodies[0])])
    share = x.mass / base if base > 0 else math.nan
    fm, fs = x.moment, x.moment_std
    return BodyChange(
        x.bodies, x.mass, x.mass_std, x.z, (float(fm[0]), float(fm[1]), float(fm[2])),
        (float(fs[0]), float(fs[1]), float(fs[2])), x.com_shift, share, x.alternatives,
    )  # fmt: skip
