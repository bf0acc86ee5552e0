"""The report's section on a payload fit: the payload's mass and CoM with their errors."""

from __future__ import annotations

from sescid.report.inputs import ReportContent
from sescid.report.text import cell, esc, in_mm, kg, table


def payload_section(c: ReportContent) -> str:
    """The payload's mass and CoM (BODY's frame) with standard errors, its base, each kind's
    noise; "" for a fit without a payload."""
    p = c.fit.payload
    if p is None:
        return ""
    rows = [["mass [kg]", cell(kg(p.mass)), "weighed" if p.mass_given else cell(kg(p.mass_std))]]
    for a, v, s in zip("xyz", p.com, p.com_std, strict=True):
        rows.append([f"CoM {a} [mm]", cell(in_mm(float(v), 1)), cell(in_mm(float(s), 1))])
    kinds = "; ".join(
        f"{k.kind}: {k.n_rows} rows, noise {k.sigma:.4g} ({k.sigma_by})" for k in p.kinds
    )
    reason = f"<p>{esc(p.reason)}</p>\n" if p.reason else ""
    return (
        f"<h2>Payload on <code>{esc(p.body)}</code></h2>\n"
        f"<p>Identified on the base ({esc(p.base)}, {p.base_mass:.4g} kg without the payload) "
        f"from {p.n_poses} poses; the CoM in the frame of <code>{esc(p.body)}</code>. Every "
        f"prediction on this page includes the payload. {esc(kinds)}.</p>\n{reason}"
        f"{table(['', 'estimate', 'standard error'], rows, 'lrr')}"
    )
