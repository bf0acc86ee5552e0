"""HTML sections of the page about the data: the summary, the CoP and the joint torques
(residuals, sensor offsets and friction bands, the support leg's torques)."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from sescid.estimation import Fit, Kind, NuisanceEstimate
from sescid.report.inputs import ReportContent
from sescid.report.numbers import CAD, IDENTIFIED, WORSE_MARGIN, KindNumbers, worse_joints
from sescid.report.text import (
    KIND_TITLES,
    NOT_DETERMINED,
    RESIDUAL_DEFINITION,
    cell,
    esc,
    fixed,
    in_mm,
    nm,
    table,
    with_unit,
)


def summary_section(c: ReportContent) -> str:
    """Title, what was fitted, each kind's residuals on the report's poses, the total mass."""
    fit = c.fit
    robot = fit.robot
    kinds = []
    for k in (c.cop, c.tau):
        if k is not None:
            s = k.total()
            kinds.append(
                f"{KIND_TITLES[k.kind]}: residual RMS {with_unit(s.rms, k.unit)}, "
                f"MAE {with_unit(s.mae, k.unit)} over {s.n_rows} rows"
            )
    mass = ""
    if fit.kind("tau") is not None:
        how = "weighed" if fit.mass_given else "the model's: not weighed"
        mass = f" Total mass {fit.total_mass:.4g} kg ({how}): torques measure M·r."
    return (
        f"<h1>Mass-distribution identification of {esc(robot.name)}</h1>\n"
        f"<p>{esc(fit.method_label)} fit, support {esc(robot.support)}: {fit.n_poses} poses, "
        f"rank {fit.rank} of {fit.r.size}. Report data: {c.data.n} poses, "
        f"{esc(', '.join(KIND_TITLES[k] for k in c.data.kinds))}.{esc(mass)}</p>\n"
        f"<p><b>Identified model on these poses</b> — {esc('; '.join(kinds))}.</p>\n"
        f'<p class="def">{esc(RESIDUAL_DEFINITION)}</p>'
    )


def _cop_table(k: KindNumbers) -> str:
    rows = []
    for model in (CAD, IDENTIFIED):
        x, y, all_ = k.stats[model]
        rows.append(
            [
                esc(model),
                cell(in_mm(x.mean)),
                cell(in_mm(y.mean)),
                cell(in_mm(float(np.hypot(x.mean, y.mean)))),
                cell(in_mm(all_.rms, 3)),
                cell(in_mm(all_.mae, 3)),
            ]
        )
    head = ["model", "mean x", "mean y", "|mean|", "RMS", "MAE"]
    return table(head, rows)


def _offsets_line(fit: Fit, kind: Kind) -> str:
    items = [e for e in fit.nuisance if e.kind == kind and e.what == "offset"]
    if kind != "cop" or not items:
        return ""
    parts = [
        f"{e.name} {_value(e)}" + (f" ({e.reason})" if not e.determined else "") for e in items
    ]
    return (
        f"<p>Estimated constant CoP offset (sensor bias), mm: {esc('; '.join(parts))}. "
        "The identified model's residuals are net of it.</p>"
    )


def cop_section(c: ReportContent, figs: Mapping[str, str]) -> str:
    """The CoP: residuals of both models (table), CoP per pose (Fig. 7), residual figure."""
    k = c.cop
    if k is None:
        return ""
    se = ""
    if c.data.cop_se is not None:
        s = c.data.cop_se
        se = (
            f"<p>Mean standard error of a measured CoP: x {in_mm(float(s[:, 0].mean()), 3)} mm, "
            f"y {in_mm(float(s[:, 1].mean()), 3)} mm.</p>"
        )
    return (
        "<h2>Centre of pressure</h2>\n"
        "<p>CoP residual, measured − predicted [mm], over the report's poses:</p>\n"
        f"{_cop_table(k)}\n{_offsets_line(c.fit, 'cop')}{se}\n"
        f"<h3>CoP per pose (Fig. 7)</h3>{figs.get('fig7_cop.png', '')}\n"
        f"<h3>CoP residuals</h3>{figs.get('residuals.png', '')}"
    )


def _torque_table(k: KindNumbers, fit: Fit) -> str:
    noise = {r.joint: r for r in fit.torque_noise}
    scaled = bool(noise) and fit.torque_noise[0].unit == "1"
    rows = []
    for fit_s, cad_s in zip(k.stats[IDENTIFIED], k.stats[CAD], strict=True):
        name = "all joints" if fit_s.name == "all" else fit_s.name
        row = [
            f"<b>{esc(name)}</b>" if fit_s.name == "all" else f"<code>{esc(name)}</code>",
            str(fit_s.n_rows),
            cell(nm(fit_s.rms, 4)),
            cell(nm(fit_s.mae, 4)),
            cell(nm(cad_s.rms, 4)),
            cell(nm(cad_s.mae, 4)),
        ]
        if noise:
            n = noise.get(fit_s.name)
            row.append("" if n is None else cell(nm(n.sigma, 4)))
        rows.append(row)
    head = ["joint", "rows", "RMS identified", "MAE identified", "RMS manufacturer",
            "MAE manufacturer"]  # fmt: skip
    if noise:
        head.append("noise σ_j [× tau_se]" if scaled else "noise σ_j [N·m]")
    return table(head, rows)


def worse_than_cad(k: KindNumbers, fit: Fit) -> str:
    """Where the identified model's torque residual exceeds the manufacturer model's (by over
    ``WORSE_MARGIN``), joint by joint, with the reason; one line when nowhere."""
    worse = worse_joints(fit, k)
    n = len(k.columns)
    if not worse:
        return (
            f"<p>On every one of the {n} joints the identified model's residual RMS is below "
            f"the manufacturer model's or within {WORSE_MARGIN:.0%} of it.</p>"
        )
    rows = [
        [f"<code>{esc(w.joint)}</code>", cell(nm(w.rms, 4)), cell(nm(w.cad_rms, 4)),
         esc(w.reason)]
        for w in worse
    ]  # fmt: skip
    shared = ""
    if not fit.torque_noise:
        shared = (
            " This fit shared one noise level among all joints: the most loaded joints' "
            "residuals outweigh the light ones', which the fit then trades away; fitting "
            "with a noise level per joint (the default, <code>--tau-noise-model joint</code>) "
            "weighs each joint by its own."
        )
    return (
        f"<p><b>Worse than the manufacturer model</b> on {len(worse)} of {n} joints (residual "
        f"RMS over {WORSE_MARGIN:.0%} above it), and why.{shared}</p>\n"
        + table(["joint", "RMS identified", "RMS manufacturer", "why"], rows, "lrrl")
    )


def _value(e: NuisanceEstimate | None) -> str:
    """The value ± its std in the estimate's display unit, or "not determined"."""
    if e is None:
        return "–"
    if not e.determined:
        return NOT_DETERMINED
    scale, digits = (1e3, 3) if e.unit == "m" else (1.0, 4)
    std = "" if not np.isfinite(e.std) else f" ± {fixed(e.std * scale, digits)}"
    return f"{fixed(e.value * scale, digits)}{std}"


#: column titles of the torque sensors' nuisance parameters (others: "<what> ± 1σ [unit]")
NUISANCE_TITLES = {
    "offset": "sensor offset ± 1σ [N·m]",
    "friction": "friction band f ± 1σ [N·m]",
    "gain": "gain error g ± 1σ (reading × (1 + g))",
}


def nuisance_table(fit: Fit, joints: tuple[str, ...]) -> str:
    """Each torque sensor's estimated parameters (offset, friction band, and any other the fit
    carries, e.g. a gain) as value ± 1σ, or "not determined" with the reason."""
    tau = [e for e in fit.nuisance if e.kind == "tau"]
    est: dict[tuple[str, str], NuisanceEstimate] = {(e.what, e.name): e for e in tau}
    whats = ["offset", "friction"] + list(dict.fromkeys(
        e.what for e in tau if e.what not in ("offset", "friction")
    ))  # fmt: skip
    rows, reasons = [], []
    for j in joints:
        got = [est.get((w, j)) for w in whats]
        reasons.append("; ".join(
            f"{w}: {e.reason}" for w, e in zip(whats, got, strict=True)
            if e is not None and not e.determined
        ))  # fmt: skip
        rows.append([f"<code>{esc(j)}</code>", *(cell(_value(e)) for e in got)])
    units: dict[str, str] = {e.what: e.unit for e in tau}
    head = ["joint"] + [
        NUISANCE_TITLES.get(w, f"{w} ± 1σ [{units.get(w, '')}]") for w in whats
    ]  # fmt: skip
    if any(reasons):  # the reasons' column only when something is not determined
        rows = [[*r, esc(w)] for r, w in zip(rows, reasons, strict=True)]
        head.append("why not determined")
    return table(head, rows, "l" + "r" * len(whats) + "l")


def _friction_words(fit: Fit) -> str:
    if any(e.kind == "tau" and e.what == "friction" for e in fit.nuisance):
        return (
            "A held torque sits at the edge of the joint's static-friction band ±f on the side "
            "it came from (the approach column): f is estimated beside each offset."
        )
    if fit.robust is not None:
        return (
            "No approach column: friction bands were not estimated; the robust (Huber) fit "
            "treats them as bounded errors, and they remain in the residuals."
        )
    return (
        "No approach column: friction bands were not estimated (–) and remain in the "
        "residuals; record from which side each pose was reached to separate them."
    )


def _noise_words(fit: Fit) -> str:
    """How the torque rows were weighed: per joint (σ_j in the table) or one shared level."""
    if fit.torque_noise:
        return (
            "<p>Each joint's rows were weighed by its own noise σ_j, estimated from its "
            "residuals (feasible generalised least squares; a lightly loaded joint is not "
            "outweighed by the support leg).</p>\n"
        )
    if fit.kind("tau") is not None:
        return "<p>One noise level was shared by every joint's rows.</p>\n"
    return ""


def torque_section(c: ReportContent, figs: Mapping[str, str]) -> str:
    """Joint torques: residuals per joint (table and map), sensor offsets and friction bands,
    the support leg's torques."""
    k = c.tau
    if k is None:
        return ""
    gains = " (and gains)" if any(e.what == "gain" for e in c.fit.nuisance) else ""
    return (
        "<h2>Joint torques</h2>\n"
        "<p>Torque residual, measured − predicted [N·m], per joint over the report's poses. "
        "Each model is net of its own best sensor terms: the identified model's estimated "
        "offsets and friction bands, and for the manufacturer model a constant offset (and "
        "friction band) per joint of the same form, so the two are compared on their masses."
        "</p>\n"
        f"{_torque_table(k, c.fit)}\n{worse_than_cad(k, c.fit)}\n{_noise_words(c.fit)}"
        f"{figs.get('torque_residuals.png', '')}\n"
        f"<h3>Torque sensor offsets and friction bands{gains}</h3>\n"
        f"<p>{esc(_friction_words(c.fit))}</p>\n{nuisance_table(c.fit, k.columns)}\n"
        f"<h3>Support leg</h3>{figs.get('torque_support_leg.png', '')}"
    )
