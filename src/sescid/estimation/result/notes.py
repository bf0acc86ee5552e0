"""The prose notes of a fit, generated from its typed fields (never parsed back)."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from sescid.base.text import listed
from sescid.estimation.result.records import REPEATED
from sescid.estimation.result.tilt import tilt_direction

if TYPE_CHECKING:  # pragma: no cover
    from sescid.estimation.result.fit import Fit

#: m: an unseen CoM height's prior std below this is a prior scale at the floor of its range
#: (a kept CAD model), not an uncertainty worth a note
HEIGHT_NOTE_MIN = 1e-6


def fit_notes(fit: Fit) -> list[str]:
    """Notes in a fixed order: residual, identifiability, weighting, method, modifiers."""
    if fit.payload is not None:  # the base is given: what the payload's data show
        return _payload_notes(fit)
    notes = [fit.choice.note()] if fit.choice is not None else []
    notes += _identifiability_notes(fit)
    if fit.scale is not None:
        notes.append(fit.scale.note())
    notes += _map_notes(fit)
    notes += _sensor_notes(fit)
    if fit.map is not None and fit.map.prior_decided:
        total, what = (
            (fit.r.size, "directions")
            if fit.bodies is None
            else (fit.bodies.x.size, "body-parameter directions")
        )
        notes.append(
            f"the prior, not the data, decided {fit.map.prior_decided} of {total} {what} "
            "(unseen by the data, or where they carry less than half of the information)"
        )
    if fit.bodies is not None:
        notes.append(_stance_note(fit))
    if fit.cop_offset is not None:
        bv, bs = fit.cop_offset.value, fit.cop_offset.std
        notes.append(
            f"CoP offset b = ({bv[0] * 1e3:.3f} ± {bs[0] * 1e3:.3f}, {bv[1] * 1e3:.3f} ± "
            f"{bs[1] * 1e3:.3f}) mm: confounded with the support body's x/y SESC components, "
            "separated only by the prior on them (±τ); predictions exclude it"
        )
    notes += _consistent_notes(fit)
    notes += _modifier_notes(fit)
    return notes


def _stance_note(fit: Fit) -> str:
    """What each stance determines alone and what pooling them adds."""
    b = fit.bodies
    each = ", ".join(f"{s.support} {s.rank} ({s.n_poses} poses)" for s in b.stances)
    added = listed(b.added, sep="; ")
    gain = f"; pooling adds {len(b.added)}: {added}" if b.added else ""
    return (
        f"stances pooled over the {b.x.size} body parameters (masses, first moments): each "
        f"alone determines {each} combinations, together {b.rank}{gain}"
    )


def _identifiability_notes(fit: Fit) -> list[str]:
    """Residual degrees of freedom, the unseen directions, a tilted sole's height, weighting."""
    from sescid.estimation.sums.normal_equations import poses_needed

    notes: list[str] = []
    if fit.method == "ls" or (fit.method == "consistent" and fit.map is None):
        if fit.n_rows - fit.rank <= 0:
            notes.append(
                f"{fit.n_poses} poses give {fit.n_rows} equations for {fit.rank} identifiable "
                "combinations: no residual left to estimate the noise "
                f"(use ≥ {poses_needed(fit.rank, fit.n_rows / max(fit.n_poses, 1))} poses)"
            )
        filled = (
            "they come from the CAD-closest masses"
            if fit.method == "consistent"
            else "they are filled from the prior model"
        )
        kinds = {k.kind for k in fit.kinds} or {"cop"}
        seen = " and ".join(
            {"cop": "CoP", "tau": "torque"}[k] for k in ("cop", "tau") if k in kinds
        )
        effect = (
            "CoM height partly does"
            if "cop" in kinds
            else (
                "the CoM does: a constant horizontal shift (the support body's own moments) and "
                "part of its height"
            )
        )
        notes.append(
            f"{len(fit.unidentifiable)} of {fit.r.size} directions are not determined by the "
            f"data; {filled} ({seen} predictions do not depend on them, {effect})"
        )
    tilt = tilt_direction(fit) if fit.kind("cop") is not None else None
    if tilt is not None:
        notes.append(
            f"tilted support: the data determine a CoM-height offset of {tilt.value * 1e3:.2f} "
            f"± {tilt.std * 1e3:.2f} mm (prior model {tilt.prior * 1e3:.2f} mm; rank +1 over "
            "a level sole)"
        )
    estimated = bool(fit.torque_noise) and fit.torque_noise[0].unit != "1"  # not given errors
    asked = fit.robust.weighted_input if fit.robust is not None else fit.weighted
    if fit.kinds and fit.robust is None:  # several kinds are weighed by their noise anyway
        asked = any(k.weighted and not (k.kind == "tau" and estimated) for k in fit.kinds)
    if fit.torque_noise:
        notes.append(_joint_noise_note(fit))
    if asked:
        present = {k.kind for k in fit.kinds if k.weighted or fit.robust is not None} or {"cop"}
        if estimated:
            present.discard("tau")
        present = present or {"cop"}
        given = " and ".join(
            {"cop": "CoP", "tau": "torque"}[k] for k in ("cop", "tau") if k in present
        )
        notes.append(
            f"weighted by the given {given} standard errors: sigma_hat is the dimensionless "
            "scale of the normalised residuals (≈ 1 when the standard errors are right)"
        )
    return notes


def _joint_noise_note(fit: Fit) -> str:
    """The per-joint torque noise (``torque_noise``): its range and what sigma_hat then is."""
    recs = fit.torque_noise
    lo = min(recs, key=lambda r: r.sigma)
    hi = max(recs, key=lambda r: r.sigma)
    given = recs[0].unit == "1"
    unit = " × tau_se" if given else " N·m"
    pooled = sum(r.by == "pooled" for r in recs)
    return (
        f"torque noise estimated per joint (feasible GLS{', on the given tau_se' if given else ''}"
        f"): σ_j from {lo.sigma:.3g}{unit} ({lo.joint}) to {hi.sigma:.3g}{unit} ({hi.joint}), "
        "each joint's rows weighed by 1/σ_j"
        + (f"; {pooled} joints with too few degrees of freedom keep the pooled level"
           if pooled else "")
        + "; the torques' sigma_hat is the scale of the normalised residuals (≈ 1)"
    )  # fmt: skip


def _map_notes(fit: Fit) -> list[str]:
    """The prior's shape and whether the evidence found any deviation from it."""
    m = fit.map
    if m is None:
        return []
    if m.prior == "bodies":
        shape = (
            f"a per-body CAD prior (masses ±{100 * m.prior_scale:.3g} %, first moments "
            f"±{(m.prior_com_std or math.nan) * 1e3:.3g} mm per unit mass; "
            f"{m.prior_scale_by})"
        )
    else:
        shape = (
            f"a Gaussian prior N(CAD, ({m.prior_scale * 1e3:.3g} mm)²) on each SESC "
            f"component ({m.prior_scale_by})"
        )
    notes = [
        f"MAP with {shape}; {len(fit.unidentifiable)} directions the data cannot see keep "
        "the prior's value and uncertainty (included in cov)"
    ]
    if m.prior_scale_by == REPEATED:
        notes.append(
            "the CAD model is kept: the data's distinct poses give no more equations than the "
            "combinations they determine, and repeats of a pose share its error (a sensor's "
            "bias there), so they cannot show the model to be off; its intervals assume it exact "
            "and say nothing of its error; measure more distinct poses"
        )
    height = _unseen_height(fit)
    if height is not None and height >= HEIGHT_NOTE_MIN:
        notes.append(
            "the part of the CoM height a level CoP cannot see stays the CAD model's, with the "
            f"prior's uncertainty: ±{height * 1e3:.2g} mm at the zero pose (in cov and the CoM "
            "intervals); a tilted support or joint torques see it"
        )
    if m.at_lower_bound:
        notes.append(
            "the evidence is largest at the smallest prior scale searched: these data cannot "
            "detect any deviation from CAD, and the intervals (±τ) assume there is none"
        )
    return notes


def _unseen_height(fit: Fit) -> float | None:
    """The standard deviation [m] of the zero pose's CoM height along the directions a CoP-only
    fit of one stance does not see (None for other fits, or when it sees all of it)."""
    import numpy as np

    if fit.bodies is not None or {k.kind for k in fit.kinds} != {"cop"}:
        return None
    g = fit.robot.regressor(np.zeros((1, fit.robot.nq)), (2,))[0, 0]
    unseen = g - fit.basis @ (fit.basis.T @ g)
    if np.linalg.norm(unseen) <= 1e-9 * np.linalg.norm(g):
        return None
    return math.sqrt(max(float(unseen @ np.nan_to_num(fit.cov) @ unseen), 0.0))


def _consistent_notes(fit: Fit) -> list[str]:
    """The consistent step: total mass, active constraints, grown boxes."""
    b = fit.inertials
    if b is None:
        return []
    active = b.active_constraints
    compare = (
        f"; CoP residual RMS {fit.rms * 1e3:.3f} mm vs {b.source_rms * 1e3:.3f} mm for "
        f"{b.source_method}"
        if math.isfinite(fit.rms) and math.isfinite(b.source_rms)
        else f" (each kind's residuals above; the {b.source_method} fit's in its record)"
    )
    notes = [
        f"consistent masses/CoMs (total {b.total_mass:.4f} kg): "
        + (f"{len(active)} active constraints" if active else "no active constraint")
        + compare
    ]
    if b.grown_boxes:
        notes.append("CoM boxes grown to contain the CAD CoM: " + ", ".join(b.grown_boxes))
    notes += list(b.notes)
    if active and b.prior_std is None and not b.exact:
        notes.append(
            "active constraints: the fit's noisiest combinations pull masses/CoMs onto "
            "their bounds; a CAD prior (ConsistentOptions.prior_std, e.g. 0.05) gives "
            "plausible masses"
        )
    return notes


def _modifier_notes(fit: Fit) -> list[str]:
    """Robust weighting and the recursive estimator."""
    notes: list[str] = []
    if fit.robust is not None:
        r = fit.robust
        if r.weighted_input:
            shown = f"{r.scale:.3f} × the given errors"
        else:  # per kind, in its unit
            unit = {"cop": (1e3, "mm"), "tau": (1.0, "N·m")}
            shown = ", ".join(
                f"{kind} {v * unit.get(kind, (1.0, ''))[0]:.3f} {unit.get(kind, (1.0, ''))[1]}"
                for kind, v in (r.scales or {"cop": r.scale}).items()
            )
        notes.append(
            f"Huber IRLS (k = {r.k:g}, robust scale {shown}): {len(r.downweighted)} of "
            f"{fit.n_poses} poses down-weighted"
        )
    if fit.online is not None:
        at = fit.online.converged_at
        notes.append(
            "recursive estimator: "
            + (f"converged after {at} poses" if at is not None else "not converged")
            + f" (predicted CoP error fell < {fit.online.tol:.0%} over {fit.online.window} poses)"
        )
    return notes


def _sensor_notes(fit: Fit) -> list[str]:
    """What the torque sensors' nuisance parameters came to: offsets, friction bands."""
    tau = [e for e in fit.nuisance if e.kind == "tau"]
    if not tau:
        return []
    out = []
    offsets = [e for e in tau if e.what == "offset"]
    lost = [e.name for e in offsets if not e.determined]
    out.append(
        f"a constant offset estimated for each of the {len(offsets)} torque sensors"
        + (
            f"; not determined for {', '.join(lost)} (see the fit's nuisance reasons)"
            if lost
            else ""
        )
    )
    friction = [e for e in tau if e.what == "friction"]
    if friction:
        sep = [e for e in friction if e.determined and not e.reason]  # by the data
        prior = any(e.determined and e.reason for e in friction)
        out.append(
            f"static friction bands separated from the offsets for {len(sep)} of "
            f"{len(friction)} joints (approach sides"
            + (
                ")"
                if len(sep) == len(friction)
                else "; the others were approached from one side"
                + (": the prior, not the data, split their offset and band)" if prior else ")")
            )
        )
    elif fit.robust is None:
        out.append(
            "no approach column: static friction (a held torque anywhere within ±f of the "
            "gravity torque) is left in the residuals; a robust fit or approach sides separate it"
        )
    return out


def _payload_notes(fit: Fit) -> list[str]:
    """A payload fit: its base, what is not determined, the noise left undetermined."""
    p = fit.payload
    assert p is not None
    notes = [
        f"the robot's own masses are the base ({p.base}, {p.base_mass:.4g} kg), kept as given; "
        f"only the payload on {p.body} was identified from {p.n_poses} poses ({p.n_rows} rows)"
    ]
    if p.reason:
        notes.append(p.reason)
    lost = [k.kind for k in p.kinds if k.sigma_by == "not determined"]
    if lost:
        notes.append(
            f"no residual left to estimate the {', '.join(lost)} noise: the payload's standard "
            "errors are not determined (more poses, or give the noise)"
        )
    return notes
