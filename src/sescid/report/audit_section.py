"""The report's section on the model file against the data (``sescid.audit``): the data's noise
and the file's error per kind, what the data reject of the file, the file's model checks."""

from __future__ import annotations

import math

import numpy as np

from sescid.errors import SescidError
from sescid.report.inputs import ReportContent
from sescid.report.text import esc, table

#: poses the section judges at most (evenly spaced over the data: the audit's rows are dense)
MAX_POSES = 4000


def audit_section(c: ReportContent) -> str:
    """What the data say of the fit's model file before any fit (``sescid.audit``)."""
    from sescid.audit import audit
    from sescid.audit.result import AUDIT_TITLES, AUDIT_UNITS

    m = c.data
    note = ""
    if m.n > MAX_POSES:
        m = m.take(np.linspace(0, m.n - 1, MAX_POSES).round().astype(int))
        note = f" (judged on {MAX_POSES} of the {c.data.n} poses, evenly spaced)"
    fit = c.fit
    mass = fit.total_mass if fit.mass_given and math.isfinite(fit.total_mass) else None
    head = "<h2>The model file against the data</h2>\n"
    try:
        res = audit(m, [fit.robot], total_mass=mass, folds=0)
    except SescidError as exc:
        return head + f'<p class="nd">not judged: {esc(str(exc))}</p>'
    cand = res.candidates[0]
    rows = []
    for e in cand.errors:
        _, f, unit = AUDIT_UNITS[e.kind]
        rows.append([esc(AUDIT_TITLES[e.kind]), f"{e.noise * f:.3g} {esc(unit)}",
                     f"{e.prediction * f:.3g} {esc(unit)}", str(e.rows)])  # fmt: skip
    out = head + (
        f"<p>{esc(fit.robot.model_path.name)}'s own predictions, before any fit{esc(note)}: "
        "the data's noise (the residual of their own least-squares fit) and the file's error "
        "(<code>sescid audit</code>).</p>"
    )
    out += table(["kind", "noise of the data", "error of the file", "rows"], rows)
    if cand.rejected:
        items = "".join(f"<li>{esc(r.text())}</li>" for r in cand.rejected)
        out += f"<p>What the data reject of the file (z ≥ {res.level:g}):</p><ul>{items}</ul>"
    else:
        out += "<p>The data reject nothing of the file beyond their noise.</p>"
    if cand.checks:
        items = "".join(f"<li>{esc(ch.body)}: {esc(ch.problem)}</li>" for ch in cand.checks)
        out += f"<p>Model checks:</p><ul>{items}</ul>"
    return out
