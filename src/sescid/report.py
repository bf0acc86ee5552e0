"""Figures (PNG) from a fit and data; never re-fits."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from .io import atomic_path  # noqa: E402


def body_labels(robot) -> list[str]:
    """Body labels for plots: the paper's Table 1 index for the embedded OP2, else names."""
    if robot.source == "op2":
        from .robots import op2_table1

        index = {row["link"]: row["paper_index"] for row in op2_table1()}
        return [f"{index[b]}" for b in robot.body_names]
    return list(robot.body_names)


def paper_order(robot) -> np.ndarray:
    """Body indices in the paper's Table 1 order for the OP2 (identity for other robots)."""
    if robot.source != "op2":
        return np.arange(len(robot.body_names))
    from .robots import op2_table1

    pos = {b: i for i, b in enumerate(robot.body_names)}
    return np.array([pos[row["link"]] for row in op2_table1()])


def plot_r_magnitudes(fit, path, title: str = "SESC vector magnitudes R_i = |r_i|") -> None:
    """Bar chart of R_i, manufacturer model vs identified, with 1σ error bars (paper Fig. 3a)."""
    order = paper_order(fit.robot)
    labels = [body_labels(fit.robot)[i] for i in order]
    r0 = np.linalg.norm(fit.r_prior, axis=1)[order] * 1e3
    r1 = fit.r_magnitudes[order] * 1e3
    # 1σ of |r| by linearisation: (r/|r|)ᵀ Σ_i (r/|r|)
    std = []
    for i in order:
        u = fit.r[i] / max(np.linalg.norm(fit.r[i]), 1e-15)
        blk = fit.cov[3 * i : 3 * i + 3, 3 * i : 3 * i + 3]
        std.append(np.sqrt(max(u @ np.nan_to_num(blk) @ u, 0.0)) * 1e3)
    x = np.arange(len(order))
    fig, ax = plt.subplots(figsize=(10, 4))
    ax.bar(x - 0.2, r0, 0.4, label="manufacturer model", color="0.4")
    ax.bar(x + 0.2, r1, 0.4, yerr=std, label="identified (±1σ)", color="tab:blue", capsize=2)
    ax.set_xticks(x, labels, rotation=0 if fit.robot.source == "op2" else 90)
    ax.set_xlabel("body (paper Table 1 index)" if fit.robot.source == "op2" else "body")
    ax.set_ylabel("R_i [mm]")
    ax.set_title(title)
    ax.legend()
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", dpi=120)
    plt.close(fig)


def plot_cop_comparison(poses_idx, measured, predicted, path, extra=None, title=None) -> None:
    """CoP_x and CoP_y per pose: measured vs predicted curves (paper Fig. 3b / Fig. 7).

    ``predicted`` and ``extra`` map a label to an (n, 2) array in metres.
    """
    fig, axes = plt.subplots(2, 1, figsize=(10, 6), sharex=True)
    styles = ["-", "--", ":", "-."]
    for k, ax in enumerate(axes):
        ax.plot(poses_idx, measured[:, k] * 1e3, "o-", color="tab:red", ms=3, label="measured")
        for s, (lab, arr) in enumerate({**predicted, **(extra or {})}.items()):
            ax.plot(poses_idx, arr[:, k] * 1e3, styles[s % 4], marker=".", label=lab)
        ax.set_ylabel(f"CoP_{'xy'[k]} [mm]")
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8, ncol=2)
    axes[-1].set_xlabel("pose")
    if title:
        axes[0].set_title(title)
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", dpi=120)
    plt.close(fig)


# --- the experiment report (paper §4: Figs. 6-8 and more) ------------------------------------
def _save(fig, path, tight: bool = True) -> None:
    if tight:
        fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", dpi=110)
    plt.close(fig)


def plot_com_height(idx, z_prior, z_fit, std, path, caveat: str = "", title=None) -> None:
    """CoM height per pose: prior (manufacturer) vs identified ± 2σ band (paper Fig. 8).

    ``z_prior``, ``z_fit``, ``std`` (n,) in m; ``caveat`` is printed under the curves (say how
    much of the identified height comes from the prior).
    """
    fig, ax = plt.subplots(figsize=(10, 3.8))
    ax.plot(idx, z_prior * 1e3, "s--", color="0.2", ms=3, label="manufacturer model")
    ax.plot(idx, z_fit * 1e3, "o-", color="tab:blue", ms=3, label="identified")
    ax.fill_between(
        idx,
        (z_fit - 2 * std) * 1e3,
        (z_fit + 2 * std) * 1e3,
        color="tab:blue",
        alpha=0.2,
        label="identified ±2σ (identified directions only)",
    )
    ax.set_xlabel("pose")
    ax.set_ylabel("CoM_z [mm]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="lower right")
    ax.set_title(title or "CoM height per pose (paper Fig. 8)")
    if caveat:
        fig.text(0.01, 0.01, caveat, fontsize=7, color="tab:orange", wrap=True)
        fig.tight_layout(rect=(0, 0.08, 1, 1))
    _save(fig, path, tight=not caveat)


def plot_residuals(idx, measured, predicted: dict, path, title=None) -> None:
    """Residuals predicted − measured CoP per pose and their histogram; (n, 2) arrays in m."""
    fig, axes = plt.subplots(2, 2, figsize=(10, 5), gridspec_kw={"width_ratios": [3, 1]})
    for k in range(2):
        for lab, arr in predicted.items():
            res = (arr[:, k] - measured[:, k]) * 1e3
            axes[k, 0].plot(idx, res, ".-", ms=3, label=lab)
            axes[k, 1].hist(res, bins=15, alpha=0.6, orientation="horizontal", label=lab)
        axes[k, 0].axhline(0, color="k", lw=0.8)
        axes[k, 0].set_ylabel(f"Δ CoP_{'xy'[k]} [mm]")
        axes[k, 0].grid(alpha=0.3)
        axes[k, 1].set_xlabel("poses")
    axes[1, 0].set_xlabel("pose")
    axes[0, 0].legend(fontsize=8)
    axes[0, 0].set_title(title or "CoP residuals: predicted − measured")
    _save(fig, path)


def plot_side_view(robot, q, cop, coms: dict, path, labels=None) -> None:
    """Stick figures (x–z, support frame) of a few poses with CoM(s) and the measured CoP.

    ``q`` (k, nq) rad, ``cop`` (k, 2) m, ``coms`` label → (k, 3) m.
    """
    _, origins = robot.forward(q)
    parents = [b.parent for b in robot.model.bodies]
    k = len(q)
    fig, axes = plt.subplots(1, k, figsize=(2.6 * k + 0.5, 4.2), sharey=True, squeeze=False)
    colors = ["tab:blue", "0.2", "tab:green"]
    for i, ax in enumerate(axes[0]):
        o = origins[i] * 1e3
        for b, p in enumerate(parents):
            if p >= 0:
                ax.plot([o[p, 0], o[b, 0]], [o[p, 2], o[b, 2]], "-", color="0.55", lw=2)
        ax.plot(o[:, 0], o[:, 2], "o", color="0.35", ms=3)
        ax.axhline(0, color="k", lw=0.8)
        ax.plot([-52.5, 52.5], [0, 0], "-", color="tab:brown", lw=4, alpha=0.6)
        for c, (lab, com) in enumerate(coms.items()):
            x, z = com[i, 0] * 1e3, com[i, 2] * 1e3
            ax.plot([x], [z], "X", ms=9, color=colors[c % 3], label=f"CoM {lab}")
            ax.plot([x, x], [0, z], ":", color=colors[c % 3], lw=1)
        ax.plot([cop[i, 0] * 1e3], [0], "^", ms=9, color="tab:red", label="CoP measured")
        ax.set_aspect("equal")
        ax.set_xlabel("x [mm]")
        ax.set_title(f"pose {labels[i] if labels is not None else i}", fontsize=9)
        ax.grid(alpha=0.3)
    axes[0, 0].set_ylabel("z [mm]")
    axes[0, -1].legend(fontsize=7, loc="upper right")
    _save(fig, path)


def cop_offset_stats(measured, predicted) -> dict:
    """Mean offset (x, y, norm) and RMS per component of predicted − measured CoP, m."""
    d = np.asarray(predicted) - np.asarray(measured)
    mean = d.mean(axis=0)
    return {
        "mean_x": float(mean[0]),
        "mean_y": float(mean[1]),
        "mean": float(np.hypot(mean[0], mean[1])),
        "rms": float(np.sqrt(np.mean(d**2))),
    }


def _r_std(fit) -> np.ndarray:
    """1σ of R_i = |r_i| by linearisation, m."""
    out = []
    for i in range(len(fit.r)):
        u = fit.r[i] / max(np.linalg.norm(fit.r[i]), 1e-15)
        blk = np.nan_to_num(fit.cov[3 * i : 3 * i + 3, 3 * i : 3 * i + 3])
        out.append(np.sqrt(max(u @ blk @ u, 0.0)))
    return np.array(out)


def write_report(
    fit, q, cop, out_dir, cop_se=None, pose_ids=None, n_side: int = 4, progress=None
) -> dict:
    """PNG figures and one self-contained HTML page (figures embedded) from a fit and data.

    ``q`` (n, nq) rad and ``cop`` (n, 2) m are the measured poses; ``cop_se`` (n, 2) m their
    standard errors. Never re-fits. ``progress(done, total)`` is called after each file.
    Returns the numbers quoted in the page and the paths.
    """
    import base64
    import html
    import math
    from pathlib import Path

    from .errors import SescidError
    from .io import atomic_open

    robot = fit.robot
    q = np.asarray(q, dtype=float)
    cop = np.asarray(cop, dtype=float)
    n = len(q)
    if n == 0:
        raise SescidError("report: no poses")
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise SescidError(f"{out}: exists and is not a folder")
    out.mkdir(parents=True, exist_ok=True)
    idx = np.arange(1, n + 1)
    labels = [str(p) for p in (pose_ids if pose_ids is not None else range(n))]
    cop_prior = robot.cop(q, fit.r_prior)
    cop_fit = fit.predict_cop(q)
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

    def tick(done):
        if progress is not None:
            progress(done, len(figs) + 1)

    plot_r_magnitudes(fit, out / "fig6_r_magnitudes.png", title=list(figs.values())[0])
    tick(1)
    plot_cop_comparison(
        idx,
        cop,
        {"manufacturer model": cop_prior, "identified": cop_fit},
        out / "fig7_cop.png",
        title=list(figs.values())[1],
    )
    tick(2)
    short = (
        f"{np.mean(frac):.0%} of the CoM-height regressor row is outside the identifiable "
        f"subspace: {np.mean(from_prior) * 1e3:.1f} mm of the identified height comes from the "
        "prior model"
    )
    plot_com_height(
        idx, com_prior[:, 2], com_fit[:, 2], std_z, out / "fig8_com_height.png", caveat=short
    )
    tick(3)
    plot_residuals(
        idx, cop, {"manufacturer model": cop_prior, "identified": cop_fit}, out / "residuals.png"
    )
    tick(4)
    pick = np.unique(np.linspace(0, n - 1, min(n_side, n)).round().astype(int))
    plot_side_view(
        robot,
        q[pick],
        cop[pick],
        {"identified": com_fit[pick], "manufacturer": com_prior[pick]},
        out / "side_view.png",
        labels=[labels[i] for i in pick],
    )

    tick(5)

    def mm(x, digits=2):
        return "n/a" if x is None or not math.isfinite(x) else f"{x * 1e3:.{digits}f}"

    esc = html.escape
    order = paper_order(robot)
    blabels = body_labels(robot)
    r0 = np.linalg.norm(fit.r_prior, axis=1)
    rstd = _r_std(fit)
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
<p>{esc(fit.method)} fit, support {esc(robot.support)}: {fit.n_poses} poses, rank {fit.rank}
of {fit.r.size}, residual RMS {mm(fit.rms, 3)} mm, MAE {mm(fit.mae, 3)} mm.
Report data: {n} poses.</p>
<h2>CoP offset, predicted − measured [mm]</h2>
<table><tr><th>model</th><th>mean x</th><th>mean y</th><th>|mean|</th><th>RMS</th></tr>
{off_row("manufacturer model", before)}{off_row("identified", after)}</table>
{se_txt}
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
    tick(len(figs) + 1)
    return {
        "html": out / "report.html",
        "figures": [out / f for f in figs],
        "before": before,
        "after": after,
        "com_z_prior_fraction": float(np.mean(frac)),
    }
