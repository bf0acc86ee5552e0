"""Figures (PNG) from a fit and data, drawn with matplotlib's object API (no pyplot, no global
backend switch); never re-fits."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from sescid.base.files import atomic_path
from sescid.robot import Robot
from sescid.robots import body_table

if TYPE_CHECKING:
    from sescid.report.inputs import ComNumbers

#: resolution of the paper's figures (Figs. 3, 6, 7, pose selection) and of the report's others
PAPER_DPI = 120
REPORT_DPI = 110
#: margins (left, right, bottom, top) in inches around the axes: room for tick labels of up to
#: six characters, an axis label and a title (a fixed layout instead of matplotlib's tight
#: layout, which measures every tick label in one more pass: a third of a figure's time)
MARGINS = (0.85, 0.2, 0.6, 0.4)
#: titles sit just above their axes (where matplotlib puts them when nothing is drawn there);
#: given explicitly, matplotlib skips measuring every tick label to find that place
TITLE_Y = 1.0
#: colours of the two models, the same in every figure (others: matplotlib's cycle)
MODEL_COLOURS = {"manufacturer model": "0.45", "identified": "tab:blue"}
#: half-length [m] of the sole drawn in the side view of a robot without a known sole
SOLE_FALLBACK = 0.05


def new_figure(*args: Any, dpi: float = REPORT_DPI, **kwargs: Any) -> tuple[Any, Any]:
    """A figure and its axes, like ``pyplot.subplots`` but owned by no global state."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=kwargs.pop("figsize", None), dpi=dpi)
    return fig, fig.subplots(*args, **kwargs)


def save_figure(fig, path, margins=MARGINS, **space: float) -> None:
    """Write ``fig`` as PNG at its own resolution, atomically. ``margins`` (left, right, bottom,
    top) in inches fix the layout, ``space`` (``wspace``, ``hspace``) the gaps between axes;
    ``margins=None``: matplotlib's tight layout (for labels of unknown length)."""
    if margins is None:
        fig.tight_layout()
    else:
        w, h = fig.get_size_inches()
        left, right, bottom, top = margins
        fig.subplots_adjust(left / w, bottom / h, 1 - right / w, 1 - top / h, **space)
    with atomic_path(path) as tmp:  # zlib level 3: 40 % less time than 6, 8 % larger files
        fig.savefig(tmp, format="png", dpi="figure", pil_kwargs={"compress_level": 3})


def _table(robot: Robot) -> list[dict[str, str]] | None:
    """The profile's paper Table 1 when it names exactly the robot's bodies."""
    rows = body_table(robot.profile)
    if rows is None or sorted(r["link"] for r in rows) != sorted(robot.body_names):
        return None
    return rows


def body_labels(robot: Robot) -> list[str]:
    """Body labels for plots: the paper's Table 1 index where the profile has it, else names."""
    rows = _table(robot)
    if rows is None:
        return list(robot.body_names)
    index = {row["link"]: row["paper_index"] for row in rows}
    return [f"{index[b]}" for b in robot.body_names]


def paper_order(robot: Robot) -> np.ndarray:
    """Body indices in the paper's Table 1 order where the profile has it (else identity)."""
    rows = _table(robot)
    if rows is None:
        return np.arange(len(robot.body_names))
    pos = {b: i for i, b in enumerate(robot.body_names)}
    return np.array([pos[row["link"]] for row in rows])


def plot_r_magnitudes(fit, path, title: str = "SESC vector magnitudes R_i = |r_i|") -> None:
    """Bar chart of R_i, manufacturer model vs identified, with 1σ error bars (paper Fig. 3a)."""
    order = paper_order(fit.robot)
    labels = [body_labels(fit.robot)[i] for i in order]
    r0 = np.linalg.norm(fit.r_prior, axis=1)[order] * 1e3
    r1 = fit.r_magnitudes[order] * 1e3
    std = r_magnitude_std(fit)[order] * 1e3
    x = np.arange(len(order))
    fig, ax = new_figure(figsize=(10, 4), dpi=PAPER_DPI)
    ax.bar(x - 0.2, r0, 0.4, label="manufacturer model", color="0.4")
    ax.bar(x + 0.2, r1, 0.4, yerr=std, label="identified (±1σ)", color="tab:blue", capsize=2)
    indexed = _table(fit.robot) is not None  # short paper indices, else body names
    ax.set_xticks(x, labels, rotation=0 if indexed else 90)
    ax.set_xlabel("body (paper Table 1 index)" if indexed else "body")
    ax.set_ylabel("R_i [mm]")
    ax.set_title(title, y=TITLE_Y)
    ax.legend()
    save_figure(fig, path, MARGINS if indexed else None)  # names of any length: tight layout


#: pose ticks drawn at most on a per-pose axis
POSE_TICKS = 20


def pose_ticks(ax, labels) -> None:
    """Label a per-pose x axis (positions 0 … n−1) with the poses' ids as the files name them
    (``labels``; None: leave the positions), at most ``POSE_TICKS`` of them."""
    if labels is None or not len(labels):
        return
    n = len(labels)
    at = np.arange(0, n, -(-n // POSE_TICKS))  # every pose, or every 2nd, 3rd, …
    long = max(len(str(labels[i])) for i in at) > 3
    ax.set_xticks(at, [str(labels[i]) for i in at], rotation=90 if long else 0, fontsize=8)
    ax.set_xlabel("pose (id as in the file)")


def plot_cop_comparison(
    poses_idx, measured, predicted, path, extra=None, title=None, labels=None
) -> None:
    """CoP_x and CoP_y per pose: measured vs predicted curves (paper Fig. 3b / Fig. 7).

    ``predicted`` and ``extra`` map a label to an (n, 2) array in metres; ``labels``: the
    poses' ids for the x axis (``pose_ticks``).
    """
    fig, axes = new_figure(2, 1, figsize=(10, 6), sharex=True, dpi=PAPER_DPI)
    styles = ["-", "--", ":", "-."]
    for k, ax in enumerate(axes):
        ax.plot(poses_idx, measured[:, k] * 1e3, "o-", color="tab:red", ms=3, label="measured")
        for s, (lab, arr) in enumerate({**predicted, **(extra or {})}.items()):
            colour = MODEL_COLOURS.get(lab, f"C{s + 1}")
            ax.plot(poses_idx, arr[:, k] * 1e3, styles[s % 4], marker=".", label=lab, c=colour)
        ax.set_ylabel(f"CoP_{'xy'[k]} [mm]")
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8, ncol=2)
    axes[-1].set_xlabel("pose")
    pose_ticks(axes[-1], labels)
    if title:
        axes[0].set_title(title, y=TITLE_Y)
    save_figure(fig, path, hspace=0.1)


# --- the experiment report (paper §4: Figs. 6-8 and more) ------------------------------------
def plot_com_height(idx, com: ComNumbers, path, caveat: str = "", title=None, labels=None) -> None:
    """CoM height per pose: prior (manufacturer) vs identified ± 2σ band (paper Fig. 8).

    ``com``: the CoM of both models per pose and the identified height's standard error, in m;
    ``caveat`` is printed under the curves (say how much of the identified height comes from
    the prior).
    """
    z_prior, z_fit, std = com.prior[:, 2], com.fit[:, 2], com.std_z
    fig, ax = new_figure(figsize=(10, 3.8))
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
    pose_ticks(ax, labels)
    ax.set_ylabel("CoM_z [mm]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="lower right")
    ax.set_title(title or "CoM height per pose (paper Fig. 8)", y=TITLE_Y)
    left, right, bottom, top = MARGINS
    if caveat:
        fig.text(0.01, 0.01, caveat, fontsize=7, color="tab:orange", wrap=True)
        bottom += 0.3  # the caveat's line(s) under the axis label
    save_figure(fig, path, (left, right, bottom, top))


def plot_residuals(idx, measured, predicted: dict, path, title=None, labels=None) -> None:
    """Residuals measured − predicted CoP per pose and their histogram; (n, 2) arrays in m."""
    fig, axes = new_figure(2, 2, figsize=(10, 5), gridspec_kw={"width_ratios": [3, 1]})
    for k in range(2):
        for s, (lab, arr) in enumerate(predicted.items()):
            res = (measured[:, k] - arr[:, k]) * 1e3
            colour = MODEL_COLOURS.get(lab, f"C{s + 1}")
            axes[k, 0].plot(idx, res, ".-", ms=3, label=lab, color=colour)
            axes[k, 1].hist(  # one filled outline per histogram, not a patch per bar
                res, bins=15, alpha=0.6, orientation="horizontal", label=lab,
                histtype="stepfilled", color=colour,
            )  # fmt: skip
        axes[k, 0].axhline(0, color="k", lw=0.8)
        axes[k, 0].set_ylabel(f"Δ CoP_{'xy'[k]} [mm]")
        axes[k, 0].grid(alpha=0.3)
        axes[k, 1].set_xlabel("poses")
    axes[1, 0].set_xlabel("pose")
    pose_ticks(axes[1, 0], labels)
    axes[0, 0].legend(fontsize=8)
    axes[0, 0].set_title(title or "CoP residuals: measured − predicted", y=TITLE_Y)
    save_figure(fig, path, wspace=0.12, hspace=0.35)  # the histograms' own tick labels between


def sole_x_range(robot: Robot) -> tuple[float, float]:
    """The x extent [m] of the support sole in the support frame (the profile's or the geometry's;
    ±SOLE_FALLBACK without a sole)."""
    sole = robot.sole
    if sole is None:
        return -SOLE_FALLBACK, SOLE_FALLBACK
    corners = sole.corners @ robot.model.root_rotation.T + robot.model.root_origin
    return float(corners[:, 0].min()), float(corners[:, 0].max())


def plot_side_view(robot: Robot, q, cop, coms: dict, path, labels=None) -> None:
    """Stick figures (x–z, support frame) of a few poses with CoM(s) and the measured CoP.

    ``q`` (k, nq) rad, ``cop`` (k, 2) m or None (no CoP measured), ``coms`` label → (k, 3) m.
    Every panel spans the same x width and z range (one size, one scale); the legend sits
    below the panels, clear of the robot.
    """
    _, origins = robot.forward(q)
    sole = np.array(sole_x_range(robot)) * 1e3
    floor = robot.floor * 1e3
    parents = [b.parent for b in robot.model.bodies]
    k = len(q)
    fig, axes = new_figure(1, k, figsize=(2.6 * k + 0.5, 4.6), squeeze=False)
    colors = ["tab:blue", "0.2", "tab:green"]
    links = np.array([(p, b) for b, p in enumerate(parents) if p >= 0]).reshape(-1, 2)
    for i, ax in enumerate(axes[0]):
        o = origins[i] * 1e3
        # every link parent → child as one line broken by NaNs (one artist, the same picture)
        seg = np.full((len(links), 3, 2), np.nan)
        seg[:, 0], seg[:, 1] = o[links[:, 0]][:, [0, 2]], o[links[:, 1]][:, [0, 2]]
        ax.plot(seg[..., 0].ravel(), seg[..., 1].ravel(), "-", color="0.55", lw=2)
        ax.plot(o[:, 0], o[:, 2], "o", color="0.35", ms=3)
        ax.axhline(floor, color="k", lw=0.8)
        ax.plot(sole, [floor, floor], "-", color="tab:brown", lw=4, alpha=0.6)
        for c, (lab, com) in enumerate(coms.items()):
            x, z = com[i, 0] * 1e3, com[i, 2] * 1e3
            ax.plot([x], [z], "X", ms=9, color=colors[c % 3], label=f"CoM {lab}")
            ax.plot([x, x], [floor, z], ":", color=colors[c % 3], lw=1)
        if cop is not None:
            ax.plot([cop[i, 0] * 1e3], [floor], "^", ms=9, color="tab:red", label="CoP measured")
        ax.set_xlabel("x [mm]")
        ax.set_title(f"pose {labels[i] if labels is not None else i}", fontsize=9, y=TITLE_Y)
        ax.grid(alpha=0.3)
    xs = [np.r_[origins[i][:, 0] * 1e3, sole] for i in range(k)]
    zs = np.r_[origins[..., 2].ravel() * 1e3, floor]
    half = max(float(np.ptp(x)) for x in xs) / 2 * 1.08 + 5.0
    z_lo, z_hi = float(zs.min()) - 15.0, float(zs.max()) + 15.0
    for ax, x in zip(axes[0], xs, strict=True):
        mid = (float(x.max()) + float(x.min())) / 2
        ax.set_xlim(mid - half, mid + half)
        ax.set_ylim(z_lo, z_hi)
        ax.set_aspect("equal", adjustable="box")
    for ax in axes[0, 1:]:
        ax.tick_params(labelleft=False)
    axes[0, 0].set_ylabel("z [mm]")
    handles, names = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, names, fontsize=8, ncol=len(names), loc="lower center", frameon=False)
    left, right, bottom, top = MARGINS
    save_figure(fig, path, (left, right, bottom + 0.35, top), wspace=0.15)


def r_magnitude_std(fit) -> np.ndarray:
    """1σ of R_i = |r_i| by linearisation, m."""
    out = []
    for i in range(len(fit.r)):
        u = fit.r[i] / max(np.linalg.norm(fit.r[i]), 1e-15)
        blk = np.nan_to_num(fit.cov[3 * i : 3 * i + 3, 3 * i : 3 * i + 3])
        out.append(np.sqrt(max(u @ blk @ u, 0.0)))
    return np.array(out)


def design_figure(curve: dict[str, np.ndarray], path, title: str | None = None) -> None:
    """PNG of expected CoP error [mm] vs number of poses, D-optimal vs random."""
    k = curve["k"]
    fig, ax = new_figure(figsize=(6.4, 4.2), dpi=PAPER_DPI)
    ax.plot(k, curve["d_optimal"] * 1e3, "o-", color="C0", label="D-optimal")
    ax.plot(k, curve["random_median"] * 1e3, "s-", color="C1", label="random (median)")
    ax.fill_between(
        k,
        curve["random_p10"] * 1e3,
        curve["random_p90"] * 1e3,
        color="C1",
        alpha=0.25,
        label="random 10–90 %",
    )
    ax.set_xlabel("number of poses K")
    ax.set_ylabel("expected CoP error on fresh poses [mm]")
    ax.set_yscale("log")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    ax.set_title(title or "Pose selection: expected noise-free CoP error", y=TITLE_Y)
    save_figure(fig, path)
