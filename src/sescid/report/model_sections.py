"""HTML sections of the page about the identified model: what the data determine (per kind and
pooled, in words), the physical masses and CoMs, the SESC vectors, the CoM height, the notes."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from sescid.estimation import fit_notes
from sescid.report.coverage import Coverage
from sescid.report.figures import body_labels, paper_order, r_magnitude_std
from sescid.report.inputs import ReportContent
from sescid.report.text import KIND_TITLES, cell, esc, in_mm, kg, percent, table

#: what each kind of unseen direction is, in a reader's words
UNSEEN_WORDS = {
    "support-vertical": "support body, vertical",
    "support-horizontal": "support body, horizontal",
    "joint-axis": "along a joint axis",
    "not-excited": "not excited by these poses",
}


def _name(cov: Coverage) -> str:
    if len(cov.kinds) > 1:
        return "pooled: " + " + ".join(KIND_TITLES[k] for k in cov.kinds)
    return KIND_TITLES[cov.kinds[0]]


def _support(cov: Coverage) -> int:
    return cov.count("support-vertical") + cov.count("support-horizontal")


def coverage_words(covs: tuple[Coverage, ...], support: str) -> list[str]:
    """Sentences: what each kind determines, what pooling adds, what no data here can see;
    ``support`` names the support body (and its link)."""
    by = {c.kinds: c for c in covs}
    out = []
    n_par = covs[0].n_par
    if ("cop",) in by:
        out.append(
            f"The CoP determines {by['cop',].rank} of {n_par} combinations. It never sees the "
            f"vertical moment of the support body ({support}): that body never moves, so it "
            "never shifts the CoP (it only offsets the CoM height)."
        )
    if ("tau",) in by:
        out.append(
            f"Joint torques determine {by['tau',].rank} of {n_par}. They never see the support "
            f"body's own moments ({support}; x, y and z), whose weight goes to the floor (or the "
            "fixture) without crossing a joint. In the CoM, the horizontal ones are a constant "
            "horizontal shift, the same in every pose: only a floor sensor (the CoP) sees it."
        )
    pooled = [c for c in covs if len(c.kinds) > 1]
    if pooled:
        p, cop, tau = pooled[0].rank, by["cop",].rank, by["tau",].rank
        gain = (
            f"{p - tau} more than torques alone (the support body's horizontal moments, from "
            f"the CoP) and {p - cop} more than the CoP alone"
        )
        out.append(
            f"Pooled, each kind weighed by its own noise: {p} of {n_par}, {gain}. Where both "
            "see a combination, pooling adds precision."
        )
    elif ("tau",) in by:
        out.append(
            "A floor sensor (CoP data pooled with these torques) would add the support body's "
            "two horizontal moments, i.e. the constant horizontal CoM shift."
        )
    axis = covs[-1].count("joint-axis")
    if axis:
        out.append(
            f"Along each joint axis a body's moment turns with its parent only, so only their "
            f"sum is seen: {axis} such directions, for any kind of static data."
        )
    lost = covs[-1].count("not-excited")
    out.append(
        f"{lost} directions are not excited by these poses (a joint that barely moves, or too "
        "few poses): more varied poses would determine them."
        if lost
        else "Every direction these kinds of data can see is excited by these poses."
    )
    return out


def identifiability_section(c: ReportContent) -> str:
    """Per kind and pooled: determined combinations and the named unseen directions."""
    fit = c.fit
    rows = [
        [esc(_name(cov)), f"{cov.rank} of {cov.n_par}", str(_support(cov)),
         str(cov.count("joint-axis")), str(cov.count("not-excited"))]
        for cov in c.coverage
    ]  # fmt: skip
    head = ["data", "determined", "support body's moments", "along joint axes", "not excited"]
    support = f"{fit.robot.body_names[0]}, which carries {fit.robot.support}"
    words = "".join(f"<li>{esc(s)}</li>" for s in coverage_words(c.coverage, support))
    prior = ""
    if fit.map is not None:
        total = fit.r.size if fit.bodies is None else fit.bodies.x.size
        prior = (
            f"<p>MAP fit: the prior (CAD model), not the data, decided {fit.map.prior_decided} "
            f"of {total} directions (unseen, or where the data carry less than half of "
            "the information).</p>"
        )
    if fit.bodies is not None:
        prior += _stances_table(fit.bodies)
    base = "".join(
        f"<tr><td><code>{esc(b.label())}</code></td><td>{cell(in_mm(b.value, 3))}</td>"
        f"<td>{cell(in_mm(b.std, 3))}</td></tr>"
        for b in fit.base
    )
    null = "".join(
        f"<tr><td><code>{esc(u.label())}</code></td><td>{esc(UNSEEN_WORDS.get(u.kind, u.kind))}"
        f"</td><td>{esc(u.reason)}</td></tr>"
        for u in fit.unidentifiable
    )
    return (
        "<h2>Identifiability: what the data determine</h2>\n"
        f"<p>Combinations of the SESC vectors (3 per body, {fit.r.size} in all) that the "
        "report's data determine, by kind of data (sensor offsets and friction bands "
        "marginalised):</p>\n"
        f'{table(head, rows)}\n<ul class="words">{words}</ul>\n{prior}'
        f"<p>The fit (its own data): {len(fit.base)} identifiable base combinations (value ± "
        f"1σ, mm) and {len(fit.unidentifiable)} directions the data cannot determine (filled "
        "from the prior model).</p>\n"
        "<details><summary>Base combinations</summary>\n<table><tr><th>combination</th>"
        f"<th>value [mm]</th><th>±1σ [mm]</th></tr>{base}</table></details>\n"
        "<details><summary>Unidentifiable directions</summary>\n<table><tr><th>direction</th>"
        f"<th>kind</th><th>reason</th></tr>{null}</table></details>"
    )


def _stances_table(b) -> str:
    """A pooled fit: what each stance determines alone, pooled, and what pooling adds."""
    rows = [[esc(st.support), str(st.n_poses), str(st.n_rows), f"{st.rank} of {b.x.size}"]
            for st in b.stances]  # fmt: skip
    rows.append(["pooled", str(sum(st.n_poses for st in b.stances)),
                 str(sum(st.n_rows for st in b.stances)), f"{b.rank} of {b.x.size}"])  # fmt: skip
    added = "".join(f"<li><code>{esc(a)}</code></li>" for a in b.added)
    return (
        "<p>Stances pooled over the body parameters they share (each body's mass and first "
        "moment): combinations determined by each stance alone and together.</p>\n"
        f"{table(['stance', 'poses', 'rows', 'body-parameter combinations'], rows)}\n"
        + (f"<p>Pooling adds, beyond the best single stance:</p><ul>{added}</ul>" if added else "")
    )


def masses_section(c: ReportContent) -> str:
    """Identified masses and CoMs of a consistent fit, against the CAD model's."""
    if c.masses is None:
        return (
            "<h2>Masses and CoMs</h2>\n<p>This fit carries no physical masses: "
            "<code>sescid identify --method consistent</code> (or <code>sescid.to_consistent"
            "</code>) gives a mass and a CoM per body.</p>"
        )
    rows = []
    for m in c.masses:
        com = [cell(in_mm(float(v), 1)) for v in m.com_link]
        active = esc("; ".join(m.active) or "none")
        rows.append(
            [f"<code>{esc(m.body)}</code>", cell(kg(m.cad_mass)), cell(kg(m.mass)),
             cell(percent(m.change)), *com, cell(in_mm(m.com_shift, 1)), active]
        )  # fmt: skip
    cad = sum(m.cad_mass for m in c.masses)
    total = sum(m.mass for m in c.masses)
    rows.append(
        ["<b>total</b>", kg(cad), kg(total), percent((total - cad) / cad if cad > 0 else np.nan)]
        + [""] * 5
    )
    head = [
        "body",
        "CAD mass [kg]",
        "identified [kg]",
        "change [%]",
        "CoM x [mm]",
        "CoM y [mm]",
        "CoM z [mm]",
        "CoM shift from CAD [mm]",
        "active constraints",
    ]
    b = c.fit.inertials
    assert b is not None
    return (
        "<h2>Masses and CoMs (physically consistent)</h2>\n"
        f"<p>Each body's mass and CoM (in the frame of its link as named in the model file), "
        f"from the {esc(b.source_method)} fit: total {b.total_mass:.4f} kg; "
        f"{len(b.active_constraints)} active constraints (a mass at its floor, a CoM on a face "
        "of its box).</p>\n"
        f"{table(head, rows, 'lrrrrrrrl')}"
    )


def sesc_section(c: ReportContent, figs: Mapping[str, str]) -> str:
    """The SESC vector magnitudes (Fig. 6) and their table; a ±1σ that is exactly 0 (R_i from
    the prior model alone) is "not determined"."""
    fit, robot = c.fit, c.fit.robot
    labels = body_labels(robot)
    r0 = np.linalg.norm(fit.r_prior, axis=1)
    std = r_magnitude_std(fit)
    std = np.where(std > 0, std, np.nan)
    rows = [
        [esc(labels[i]), esc(robot.body_names[i]), in_mm(r0[i]), cell(in_mm(fit.r_magnitudes[i])),
         cell(in_mm(std[i]))]
        for i in paper_order(robot)
    ]  # fmt: skip
    head = ["#", "body", "R_i manufacturer [mm]", "R_i identified [mm]",
            "±1σ [mm] (identified directions)"]  # fmt: skip
    return (
        f"<h2>SESC vector magnitudes (Fig. 6)</h2>{figs.get('fig6_r_magnitudes.png', '')}\n"
        f"{table(head, rows, 'llrrr')}"
    )


def com_section(c: ReportContent, figs: Mapping[str, str]) -> str:
    """The CoM height per pose (Fig. 8) with the prior's share, and the side view."""
    frac = c.com.prior_fraction
    caveat = (
        f"On these poses {np.mean(frac):.0%} (range {frac.min():.0%}–{frac.max():.0%}) of the "
        "CoM-height regressor row lies outside the identifiable subspace: that part of the "
        f"identified CoM height (mean {in_mm(float(np.mean(c.com.from_prior)), 1)} mm of "
        f"{in_mm(float(np.mean(c.com.fit[:, 2])), 1)} mm) comes from the prior (manufacturer) "
        "model, not from the data. The band counts the identified directions only."
    )
    return (
        f"<h2>CoM height (Fig. 8)</h2>{figs.get('fig8_com_height.png', '')}\n"
        f'<p class="caveat">{esc(caveat)}</p>\n'
        f"<h2>Side view</h2>{figs.get('side_view.png', '')}"
    )


def notes_section(c: ReportContent) -> str:
    """The fit's notes and warnings."""
    notes = "".join(f"<li>{esc(t)}</li>" for t in fit_notes(c.fit))
    warns = "".join(f'<li class="warn">warning: {esc(t)}</li>' for t in c.fit.warnings)
    return f"<h2>Notes</h2><ul>{notes}{warns}</ul>"
