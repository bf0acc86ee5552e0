"""The report: PNG figures and one self-contained HTML page (figures embedded) from a fit and
its data, for any kinds of data (CoP, joint torques, both); never re-fits.

``write_report(fit, data, out_dir, options)``: the numbers once (``inputs.report_content``), the
figures for the kinds at hand (``figure_jobs``, two cores), then the page from its sections
(``sections``, ``model_sections``, ``view3d``), written atomically.
"""

from __future__ import annotations

import base64
from collections.abc import Iterable
from pathlib import Path

from sescid.base.files import atomic_open
from sescid.errors import DataError
from sescid.estimation import Fit, Measurements
from sescid.report.audit_section import audit_section
from sescid.report.figure_jobs import FigureJob, figure_jobs
from sescid.report.inputs import (
    ReportContent,
    ReportOptions,
    ReportResult,
    as_measurements,
    report_content,
)
from sescid.report.model_sections import (
    com_section,
    identifiability_section,
    masses_section,
    notes_section,
    sesc_section,
)
from sescid.report.parallel import run_figures
from sescid.report.payload_section import payload_section
from sescid.report.sections import cop_section, summary_section, torque_section
from sescid.report.text import esc
from sescid.report.view3d import scene_data, view3d_html

STYLE = """
body { font-family: sans-serif; max-width: 1100px; margin: 1em auto; padding: 0 1em;
  color: #222; }
table { border-collapse: collapse; margin: 0.5em 0; font-size: 0.9em; }
td, th { border: 1px solid #bbb; padding: 2px 6px; text-align: right; }
td.l, th.l { text-align: left; }
img { max-width: 100%; }
figure { margin: 1em 0; }
figcaption { font-size: 0.85em; color: #555; }
.caveat { background: #fff4e0; border-left: 4px solid #e0a000; padding: 0.4em 0.8em; }
.def { background: #eef3fb; border-left: 4px solid #3060b0; padding: 0.4em 0.8em;
  font-size: 0.9em; }
.nd { color: #a05000; font-style: italic; }
.warn { color: #a02000; }
"""

#: the page's own check that every embedded figure decoded (read by the tests in a browser)
CHECK_SCRIPT = """
window.addEventListener("load", function () {
  var ok = 0;
  for (var i = 0; i < document.images.length; i++) {
    var im = document.images[i];
    if (im.complete && im.naturalWidth > 0) { ok++; }
    else { console.error("figure failed to load: " + im.alt); }
  }
  document.body.setAttribute("data-figures-ok", String(ok));
});
"""


def _out_folder(out_dir) -> Path:
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise DataError(f"{out}: exists and is not a folder")
    out.mkdir(parents=True, exist_ok=True)
    return out


def embedded(out: Path, jobs: list[FigureJob]) -> dict[str, str]:
    """Each written figure as an ``<figure>`` with its PNG inline (base64), by file name."""
    out_html = {}
    for job in jobs:
        data = base64.b64encode((out / job.name).read_bytes()).decode("ascii")
        out_html[job.name] = (
            f'<figure><img alt="{esc(job.caption)}" src="data:image/png;base64,{data}">'
            f"<figcaption>{esc(job.caption)} — <code>{job.name}</code></figcaption></figure>"
        )
    return out_html


def page(c: ReportContent, figs: dict[str, str]) -> str:
    """The whole HTML page from its sections."""
    cop, cop_fit = (None, None) if c.cop is None else (c.cop.measured, c.cop.predicted)
    scene = scene_data(
        c.fit.robot,
        c.data.q,
        c.com.fit,
        cop,
        None if cop_fit is None else cop_fit["identified"],
        c.labels,
    )
    sections = [
        summary_section(c),
        payload_section(c),
        view3d_html(scene),
        cop_section(c, figs),
        torque_section(c, figs),
        identifiability_section(c),
        masses_section(c),
        sesc_section(c, figs),
        com_section(c, figs),
        audit_section(c),
        notes_section(c),
    ]
    body = "\n".join(s for s in sections if s)
    return (
        '<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">\n'
        f"<title>sescid report: {esc(c.fit.robot.name)}</title>\n<style>{STYLE}</style></head>\n"
        f"<body>\n{body}\n<script>{CHECK_SCRIPT}</script>\n</body></html>\n"
    )


def write_report(
    fit: Fit,
    data: Measurements | Iterable[Measurements],
    out_dir,
    options: ReportOptions | None = None,
) -> ReportResult:
    """PNG figures and one self-contained HTML page (figures embedded) in ``out_dir``.

    ``data``: the measured poses and what was measured there (``Measurements``: a CoP (n, 2) m
    and/or joint torques (n, J) N·m, gravity (n, 3) when the support is not level), or
    consecutive chunks of them. Never re-fits. Returns the files and the numbers the page shows.
    """
    opts = options or ReportOptions()
    m = as_measurements(fit, data)
    content = report_content(fit, m, opts)
    out = _out_folder(out_dir)
    jobs = figure_jobs(content, out, opts)
    total = len(jobs) + 1
    progress = opts.progress
    run_figures(
        [j.draw for j in jobs], None if progress is None else (lambda done: progress(done, total))
    )
    html_path = out / "report.html"
    with atomic_open(html_path, "w", encoding="utf-8") as fh:
        fh.write(page(content, embedded(out, jobs)))
    if progress is not None:
        progress(total, total)
    return ReportResult(html_path, tuple(out / j.name for j in jobs), content)
