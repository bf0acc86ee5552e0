"""The report: PNG figures and one self-contained HTML page (figures embedded) from a fit and
its data; never re-fits."""

from __future__ import annotations

import base64
import html
import math
from pathlib import Path

import numpy as np

from sescid.base.files import atomic_open
from sescid.errors import DataError
from sescid.report.figures import (
    body_labels,
    cop_offset_stats,
    paper_order,
    plot_com_height,
    plot_cop_comparison,
    plot_r_magnitudes,
    plot_residuals,
    plot_side_view,
    r_magnitude_std,
)
from sescid.report.parallel import run_figures
from sescid.report.view3d import scene_data, view3d_html


def write_report(
    fit,
    q,
    cop,
    out_dir,
    cop_se=None,
    pose_ids=None,
    n_side: int = 4,
    progress=None,
    gravity=None,
) -> dict:
    """PNG figures and one self-contained HTML page (figures embedded) from a fit and data.

    ``q`` (n, nq) rad and ``cop`` (n, 2) m are the measured poses; ``cop_se`` (n, 2) m their
    standard errors; ``gravity`` (n, 3) the gravity direction per pose in the support frame
    (None: along −z), under which the predicted CoPs are projected. Never re-fits.
    ``progress(done, total)`` is called after each file.
    Returns the numbers quoted in the page and the paths.
    """
    robot = fit.robot
    q = np.asarray(q, dtype=float)
    cop = np.asarray(cop, dtype=float)
    n = len(q)
    if n == 0:
        raise DataError("report: no poses")
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise DataError(f"{out}: exists and is not a folder")
    out.mkdir(parents=True, exist_ok=True)
    idx = np.arange(1, n + 1)
    labels = [str(p) for p in (pose_ids if pose_ids is not None else range(n))]
    cop_prior = robot.cop(q, fit.r_prior, gravity)
    cop_fit = fit.predict_cop(q, gravity)
    com_prior = robot.com(q, fit.r_prior)
    com_fit = fit.predict_com(q)
    std_z = np.nan_to_num(fit.predict_std(q, rows=(2,))[:, 0])
    from_prior = fit.com_z_from_prior(q)
    frac = fit.com_z_prior_fraction(q)
    before = cop_offset_stats(cop, cop_prior)
    after = cop_offset_stats(cop, cop_fit)
    figs = {
        "fig6_r_magnitudes.png": "R_i = |r_i|: manufacturer model vs identified ±1σ (paper Fig. 6)",
        "fig7_cop.png": "CoP per pose: measured vs manufacturer vs identified (paper Fig. 7)",
        "fig8_com_height.png": "CoM height per pose (paper Fig. 8)",
        "residuals.png": "CoP residuals, predicted − measured",
        "side_view.png": "Side view of a few poses with CoM and CoP",
    }

    short = (
        f"{np.mean(frac):.0%} of the CoM-height regressor row is outside the identifiable "
        f"subspace: {np.mean(from_prior) * 1e3:.1f} mm of the identified height comes from the "
        "prior model"
    )
    predicted = {"manufacturer model": cop_prior, "identified": cop_fit}
    pick = np.unique(np.linspace(0, n - 1, min(n_side, n)).round().astype(int))
    titles = list(figs.values())
    jobs = [  # in the order of ``figs``; the last ones are drawn on the second core
        lambda: plot_r_magnitudes(fit, out / "fig6_r_magnitudes.png", title=titles[0]),
        lambda: plot_cop_comparison(idx, cop, predicted, out / "fig7_cop.png", title=titles[1]),
        lambda: plot_com_height(
            idx, com_prior[:, 2], com_fit[:, 2], std_z, out / "fig8_com_height.png", caveat=short
        ),
        lambda: plot_residuals(idx, cop, predicted, out / "residuals.png"),
        lambda: plot_side_view(
            robot,
            q[pick],
            cop[pick],
            {"identified": com_fit[pick], "manufacturer": com_prior[pick]},
            out / "side_view.png",
            labels=[labels[i] for i in pick],
        ),
    ]

    def mm(x, digits=2):
        return "n/a" if x is None or not math.isfinite(x) else f"{x * 1e3:.{digits}f}"

    esc = html.escape
    order = paper_order(robot)
    blabels = body_labels(robot)
    r0 = np.linalg.norm(fit.r_prior, axis=1)
    rstd = r_magnitude_std(fit)
    rows_r = "".join(
        f"<tr><td>{esc(blabels[i])}</td><td>{esc(robot.body_names[i])}</td>"
        f"<td>{mm(r0[i])}</td><td>{mm(fit.r_magnitudes[i])}</td><td>{mm(rstd[i])}</td></tr>"
        for i in order
    )
    rows_base = "".join(
        f"<tr><td><code>{esc(c.label())}</code></td><td>{mm(c.value, 3)}</td>"
        f"<td>{mm(c.std, 3)}</td></tr>"
        for c in fit.base
    )
    rows_null = "".join(
        f"<tr><td><code>{esc(c.label())}</code></td><td>{esc(c.reason)}</td></tr>"
        for c in fit.unidentifiable
    )
    se_txt = ""
    if cop_se is not None:
        se = np.asarray(cop_se, dtype=float)
        se_txt = (
            f"<p>Mean standard error of a measured CoP: x {mm(se[:, 0].mean(), 3)} mm, "
            f"y {mm(se[:, 1].mean(), 3)} mm.</p>"
        )

    def off_row(name, s):
        return (
            f"<tr><td>{name}</td><td>{mm(s['mean_x'])}</td><td>{mm(s['mean_y'])}</td>"
            f"<td>{mm(s['mean'])}</td><td>{mm(s['rms'])}</td></tr>"
        )

    caveat = (
        f"On these poses {np.mean(frac):.0%} (range {frac.min():.0%}–{frac.max():.0%}) of the "
        "CoM-height regressor row lies outside the identifiable subspace: that part of the "
        f"identified CoM height (mean {mm(float(np.mean(from_prior)), 1)} mm of "
        f"{mm(float(np.mean(com_fit[:, 2])), 1)} mm) comes from the prior (manufacturer) model, "
        "not from the data. The band counts the identified directions only."
    )
    view3d = view3d_html(scene_data(robot, q, com_fit, cop, cop_fit, labels))
    run_figures(jobs, None if progress is None else lambda done: progress(done, len(figs) + 1))
    imgs = []
    for name, caption in figs.items():
        data = base64.b64encode((out / name).read_bytes()).decode("ascii")
        imgs.append(
            f'<figure><img alt="{esc(caption)}" src="data:image/png;base64,{data}">'
            f"<figcaption>{esc(caption)} — <code>{name}</code></figcaption></figure>"
        )
    fig6, fig7, fig8, fig_res, fig_side = imgs
    notes = "".join(f"<li>{esc(t)}</li>" for t in fit.notes)
    page = f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8">
<title>sescid report: {esc(robot.name)}</title>
<style>
body {{ font-family: sans-serif; max-width: 1100px; margin: 1em auto; padding: 0 1em;
  color: #222; }}
table {{ border-collapse: collapse; margin: 0.5em 0; font-size: 0.9em; }}
td, th {{ border: 1px solid #bbb; padding: 2px 6px; text-align: right; }}
td:first-child, th:first-child {{ text-align: left; }}
img {{ max-width: 100%; }}
figure {{ margin: 1em 0; }}
figcaption {{ font-size: 0.85em; color: #555; }}
.caveat {{ background: #fff4e0; border-left: 4px solid #e0a000; padding: 0.4em 0.8em; }}
</style></head>
<body>
<h1>Mass-distribution identification of {esc(robot.name)}</h1>
<p>{esc(fit.method_label)} fit, support {esc(robot.support)}: {fit.n_poses} poses, rank {fit.rank}
of {fit.r.size}, residual RMS {mm(fit.rms, 3)} mm, MAE {mm(fit.mae, 3)} mm.
Report data: {n} poses.</p>
<h2>CoP offset, predicted − measured [mm]</h2>
<table><tr><th>model</th><th>mean x</th><th>mean y</th><th>|mean|</th><th>RMS</th></tr>
{off_row("manufacturer model", before)}{off_row("identified", after)}</table>
{se_txt}
{view3d}
<h2>SESC vector magnitudes (Fig. 6)</h2>{fig6}
<table><tr><th>#</th><th>body</th><th>R_i manufacturer [mm]</th><th>R_i identified [mm]</th>
<th>±1σ [mm]</th></tr>{rows_r}</table>
<h2>CoP per pose (Fig. 7)</h2>{fig7}
<h2>CoM height (Fig. 8)</h2>{fig8}
<p class="caveat">{esc(caveat)}</p>
<h2>Residuals</h2>{fig_res}
<h2>Side view</h2>{fig_side}
<h2>Identifiability</h2>
<p>{len(fit.base)} identifiable base combinations (value ± 1σ, mm) and {len(fit.unidentifiable)}
directions the data cannot determine (filled from the prior model).</p>
<details open><summary>Base combinations</summary>
<table><tr><th>combination</th><th>value [mm]</th><th>±1σ [mm]</th></tr>{rows_base}</table>
</details>
<details open><summary>Unidentifiable directions</summary>
<table><tr><th>direction</th><th>reason</th></tr>{rows_null}</table></details>
<h2>Notes</h2><ul>{notes}</ul>
<script>
window.addEventListener("load", function () {{
  var ok = 0;
  for (var i = 0; i < document.images.length; i++) {{
    var im = document.images[i];
    if (im.complete && im.naturalWidth > 0) {{ ok++; }}
    else {{ console.error("figure failed to load: " + im.alt); }}
  }}
  document.body.setAttribute("data-figures-ok", String(ok));
}});
</script>
</body></html>
"""
    with atomic_open(out / "report.html", "w", encoding="utf-8") as fh:
        fh.write(page)
    if progress is not None:
        progress(len(figs) + 1, len(figs) + 1)
    return {
        "html": out / "report.html",
        "figures": [out / f for f in figs],
        "before": before,
        "after": after,
        "com_z_prior_fraction": float(np.mean(frac)),
    }
