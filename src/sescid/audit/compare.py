"""``compare``: what changed between fits of one robot (before/after, or sessions over days).

Only the directions of vec(r) that every fit determines are compared (``common_subspace``); the
rest is counted and said, never compared. Two fits: their difference there, whitened by the sum of
their covariances, is explained by the bodies whose mass or first moment changed
(``linear.attribute``: beyond the noise, a two-sided z), with the change of the total mass and of
the CoM over a set of poses. Several fits: each session's departure from their weighted mean
against what its covariance predicts (an outlier is named, Bonferroni-corrected), and each named
combination's spread across sessions against the spread their covariances predict
(repeatability).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from sescid.audit.audit import DEFAULT_Z
from sescid.audit.linear import attribute, r_jacobian, tail, z_of_p
from sescid.audit.result import BodyChange, body_change, none_if_nan
from sescid.errors import ModelError, OptionError
from sescid.estimation import Fit, load_fit
from sescid.estimation.solvers.least_squares import DETERMINED

#: poses the CoM change is judged on (the zero pose and random ones within the joint limits)
COM_POSES = 64
#: rad, half-range of those random poses around the zero pose (clipped to the limits)
COM_RANGE = math.radians(30.0)
#: why a comparison of MAP fits is conservative
MAP_NOTE = (
    "MAP fits share the CAD prior: their difference is drawn toward it while their covariances "
    "hold its uncertainty, so this comparison is conservative (compare least-squares fits, "
    "identify --method ls, for its full power)"
)


@dataclass(frozen=True)
class Session:
    """One fit among several: its departure from the weighted mean of all."""

    fit: str
    z: float  #: two-sided z of its departure (Bonferroni-corrected over the sessions)
    outlier: bool


@dataclass(frozen=True)
class Repeat:
    """One named combination across sessions: its spread and the spread predicted."""

    label: str
    bodies: tuple[str, ...]
    spread: float  #: m, standard deviation of its values across the sessions
    predicted: float  #: m, RMS of the sessions' standard errors
    ratio: float  #: spread / predicted (≈ 1: as repeatable as the fits say)


@dataclass(frozen=True)
class CompareResult:
    """``compare``'s answer (module docstring)."""

    fits: tuple[str, ...]
    robot: str
    support: str
    compared: int  #: directions of vec(r) every fit determines
    not_compared: int  #: directions some fit leaves undetermined (not compared)
    z_overall: float  #: significance of the whole difference (two fits) or spread (several)
    changed: tuple[BodyChange, ...]
    com_change: tuple[float, float, float]  #: m, mean CoM change over the poses (last − first)
    com_change_rms: float  #: m, RMS over the poses of |CoM change|
    com_change_std: float  #: m, RMS over the poses of its standard error
    mass_change: float  #: kg, last − first total mass (nan when a fit has none)
    sessions: tuple[Session, ...] = ()
    repeatability: tuple[Repeat, ...] = ()
    level: float = DEFAULT_Z
    notes: tuple[str, ...] = ()  #: what a reader should know (MAP fits: a conservative test)

    def text(self) -> str:
        """What changed, in plain words."""
        lines = [f"note: {n}" for n in self.notes] + [
            f"compare {len(self.fits)} fits of {self.robot} (support {self.support}): "
            f"{self.compared} combinations every fit determines are compared; "
            f"{self.not_compared} that some fit leaves undetermined are not"
        ]
        if len(self.fits) == 2:
            if not self.changed:
                lines.append(
                    f"no body's change reaches z {self.level:g} (the whole difference: "
                    f"z {self.z_overall:.1f} over {self.compared} combinations)"
                )
            for c in self.changed:
                lines.append("changed: " + c.text().replace("this file says", "the first fit"))
            cx, cy, cz = (v * 1e3 for v in self.com_change)
            lines.append(
                f"CoM change over {COM_POSES} poses: mean ({cx:+.2f}, {cy:+.2f}, {cz:+.2f}) mm, "
                f"RMS {self.com_change_rms * 1e3:.2f} ± {self.com_change_std * 1e3:.2f} mm"
            )
            if math.isfinite(self.mass_change):
                lines.append(f"total mass change: {self.mass_change:+.3f} kg")
        else:
            for s in self.sessions:
                flag = "  ← outlier" if s.outlier else ""
                lines.append(f"session {s.fit}: departure z {s.z:.1f}{flag}")
            for r in self.repeatability[:8]:
                lines.append(
                    f"  {r.label}: spread {r.spread * 1e3:.3f} mm vs predicted "
                    f"{r.predicted * 1e3:.3f} mm (× {r.ratio:.2f})"
                )
            for c in self.changed:
                lines.append(
                    "outlier's change: " + c.text().replace("this file says", "the others")
                )
        return "\n".join(lines)

    def to_json(self) -> dict:
        """The comparison as JSON (``--json``)."""
        return {
            "format": "sescid-compare",
            "fits": list(self.fits),
            "robot": self.robot,
            "support": self.support,
            "compared": self.compared,
            "not_compared": self.not_compared,
            "z_overall": none_if_nan(self.z_overall),
            "z_level": self.level,
            "changed": [c.to_json() for c in self.changed],
            "com_change_mm": [none_if_nan(v * 1e3) for v in self.com_change],
            "com_change_rms_mm": none_if_nan(self.com_change_rms * 1e3),
            "com_change_std_mm": none_if_nan(self.com_change_std * 1e3),
            "mass_change": None if not math.isfinite(self.mass_change) else self.mass_change,
            "sessions": [{"fit": s.fit, "z": s.z, "outlier": s.outlier} for s in self.sessions],
            "notes": list(self.notes),
            "repeatability": [
                {
                    "label": r.label,
                    "bodies": list(r.bodies),
                    "spread": none_if_nan(r.spread),
                    "predicted": none_if_nan(r.predicted),
                    "ratio": none_if_nan(r.ratio),
                }  # fmt: skip
                for r in self.repeatability
            ],
        }


def _check_same(fits: list[Fit], labels: list[str]) -> None:
    a = fits[0].robot
    for f, lab in zip(fits[1:], labels[1:], strict=True):
        b = f.robot
        other = sorted(b.joint_names) != sorted(a.joint_names)
        if not other and b.support != a.support:
            raise ModelError(
                f"{lab} is in the support '{b.support}', {labels[0]} in '{a.support}': compare "
                "fits of one support"
            )
        if other or b.body_names != a.body_names:
            raise ModelError(
                f"{lab} is a fit of {b.name}, {labels[0]} of {a.name} (other bodies or joints): "
                "compare fits of one robot"
            )


def common_subspace(fits: list[Fit]) -> np.ndarray:
    """(3N, p) orthonormal basis of the directions every fit determines."""
    size = fits[0].r.size
    proj = sum((f.basis @ f.basis.T for f in fits), np.zeros((size, size))) / len(fits)
    w, v = np.linalg.eigh((proj + proj.T) / 2)
    return v[:, w > DETERMINED]


def _whitener(c: np.ndarray) -> np.ndarray:
    """W with W C Wᵀ = I on C's range (C symmetric PSD)."""
    w, v = np.linalg.eigh((c + c.T) / 2)
    keep = w > 1e-12 * max(float(w.max()), 1e-300)
    return (v[:, keep] / np.sqrt(w[keep])).T


def _com_poses(fit: Fit) -> np.ndarray:
    lim = fit.robot.joint_limits
    rng = np.random.default_rng(0)
    q = rng.uniform(-COM_RANGE, COM_RANGE, (COM_POSES, fit.robot.nq))
    q[0] = 0.0
    return np.clip(q, lim[:, 0], lim[:, 1])


def _cov(fit: Fit) -> np.ndarray:
    return np.nan_to_num(np.asarray(fit.cov, dtype=float))


def _mass(fit: Fit) -> float:
    if fit.inertials is not None:
        return float(fit.inertials.total_mass)
    return float(fit.total_mass) if fit.mass_given else math.nan


def compare(fits: Sequence[Any], *, level: float = DEFAULT_Z) -> CompareResult:
    """What changed between fits of one robot and support (module docstring). ``fits``: Fit
    objects or fit files (at least two); ``level``: the z a change must reach to be named."""
    if len(fits) < 2:
        raise OptionError("fits", "compare needs at least two fits")
    labels = [str(f) if not isinstance(f, Fit) else f"fit {i + 1}" for i, f in enumerate(fits)]
    loaded = [f if isinstance(f, Fit) else load_fit(f) for f in fits]
    _check_same(loaded, labels)
    first, last = loaded[0], loaded[-1]
    robot = first.robot
    u = common_subspace(loaded)
    p = u.shape[1]
    theta = robot.body_parameters()
    _, dr = r_jacobian(robot.sesc_matrix(), theta, len(robot.body_names))
    changed: list[BodyChange] = []
    sessions: tuple[Session, ...] = ()
    repeat: tuple[Repeat, ...] = ()
    if len(loaded) == 2:
        d = (last.r - first.r).reshape(-1)
        w = _whitener(u.T @ (_cov(first) + _cov(last)) @ u)
        named, z_all, _ = attribute(w @ u.T @ d, w @ u.T @ dr, robot, theta, level)
        changed = [body_change(x, robot.masses, robot) for x in named]
    else:
        xs = [u.T @ f.r.reshape(-1) for f in loaded]
        cs = [u.T @ _cov(f) @ u for f in loaded]
        infos = [np.linalg.pinv(c, hermitian=True) for c in cs]
        c_mean = np.linalg.pinv(sum(infos, np.zeros((p, p))), hermitian=True)
        mean = c_mean @ sum((i @ x for i, x in zip(infos, xs, strict=True)), np.zeros(p))
        zs, chi_all = [], 0.0
        for x, c in zip(xs, cs, strict=True):
            dev = x - mean
            chi = float(dev @ np.linalg.pinv(c - c_mean, hermitian=True) @ dev)
            chi_all += float(dev @ np.linalg.pinv(c, hermitian=True) @ dev)
            zs.append(z_of_p(min(tail(chi, p, math.inf) * len(loaded), 1.0)))
        z_all = z_of_p(tail(chi_all, p * (len(loaded) - 1), math.inf))
        worst = int(np.argmax(zs))
        sessions = tuple(
            Session(lab, z, i == worst and z >= level)
            for i, (lab, z) in enumerate(zip(labels, zs, strict=True))
        )
        if zs[worst] >= level:
            d = u @ (xs[worst] - mean)
            w = _whitener(cs[worst] - c_mean)
            named, _, _ = attribute(w @ u.T @ d, w @ u.T @ dr, robot, theta, level)
            changed = [body_change(x, robot.masses, robot) for x in named]
        repeat = tuple(_repeatability(loaded, u))
    q = _com_poses(first)
    dcom = last.predict_com(q) - first.predict_com(q)
    phi = robot.regressor(q, (0, 1, 2))
    cov = _cov(first) + _cov(last)
    var = np.einsum("nap,pk,nak->n", phi, cov, phi)
    m0, m1 = _mass(first), _mass(last)
    notes = ()
    if any(f.map is not None for f in loaded):
        notes = (MAP_NOTE,)
    return CompareResult(
        fits=tuple(labels),
        robot=robot.name,
        support=robot.support,
        compared=p,
        not_compared=robot.sesc_vectors().size - p,
        z_overall=z_all,
        changed=tuple(changed),
        com_change=tuple(float(v) for v in dcom.mean(axis=0)),  # type: ignore[arg-type]
        com_change_rms=float(np.sqrt(np.mean(np.sum(dcom**2, axis=1)))),
        com_change_std=float(np.sqrt(np.mean(np.clip(var, 0, None)))),
        mass_change=m1 - m0,
        sessions=sessions,
        repeatability=repeat,
        level=level,
        notes=notes,
    )


def _repeatability(fits: list[Fit], u: np.ndarray) -> list[Repeat]:
    """The first fit's named combinations that every fit determines, most spread first."""
    from sescid.estimation.result.identifiability import combination_vector

    out = []
    for comb in fits[0].base:
        g = combination_vector(fits[0].robot, comb.terms)
        if np.linalg.norm(g - u @ (u.T @ g)) > 1e-6 * np.linalg.norm(g):
            continue
        vals = np.array([g @ f.r.reshape(-1) for f in fits])
        stds = np.array([math.sqrt(max(float(g @ _cov(f) @ g), 0.0)) for f in fits])
        spread = float(np.std(vals, ddof=1))
        pred = float(np.sqrt(np.mean(stds**2)))
        ratio = spread / pred if pred > 0 else math.inf
        bodies = tuple(dict.fromkeys(b for b, _, _ in comb.terms))
        out.append(Repeat(comb.label(), bodies, spread, pred, ratio))
    return sorted(out, key=lambda r: -r.ratio)
