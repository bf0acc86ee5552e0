"""Joint-torque figures (PNG): residuals per pose and joint, and the support leg's torques
across the poses, measured against both models; never re-fits."""

from __future__ import annotations

import numpy as np

from sescid.report.figures import MODEL_COLOURS, TITLE_Y, new_figure, pose_ticks, save_figure

#: inches per joint row of the residual map, and around it
ROW_INCH, MAP_EXTRA_INCH = 0.24, 1.6


def plot_torque_residuals(
    idx, joints, residual: dict, path, model: str = "identified", labels=None
) -> None:
    """Residual map measured − predicted [N·m] per pose (x) and joint (y) of ``model``, beside
    each joint's residual RMS for every model in ``residual`` (label → (n, J) N·m)."""
    res = np.asarray(residual[model], dtype=float)
    joints = list(joints)
    nj = len(joints)
    height = max(3.0, ROW_INCH * nj + MAP_EXTRA_INCH)
    fig, (ax, bar) = new_figure(
        1, 2, figsize=(10, height), sharey=True, gridspec_kw={"width_ratios": [3, 1]}
    )
    lim = float(np.max(np.abs(res))) or 1.0
    img = ax.imshow(
        res.T,
        aspect="auto",
        cmap="RdBu_r",
        vmin=-lim,
        vmax=lim,
        interpolation="nearest",
        extent=(idx[0] - 0.5, idx[-1] + 0.5, nj - 0.5, -0.5),
    )
    ax.set_yticks(np.arange(nj), joints, fontsize=7 if nj > 24 else 8)
    ax.set_xlabel("pose")
    pose_ticks(ax, labels)
    ax.set_title(f"torque residual, measured − predicted ({model}) [N·m]", y=TITLE_Y, fontsize=10)
    fig.colorbar(img, ax=ax, fraction=0.04, pad=0.01, label="N·m")
    y = np.arange(nj)
    width = 0.8 / max(len(residual), 1)
    for k, (label, r) in enumerate(residual.items()):
        rms = np.sqrt(np.mean(np.asarray(r, dtype=float) ** 2, axis=0))
        offset = (k - (len(residual) - 1) / 2) * width
        bar.barh(y + offset, rms, width, color=MODEL_COLOURS.get(label, f"C{k}"), label=label)
    bar.set_xlabel("residual RMS [N·m]")
    bar.grid(axis="x", alpha=0.3)
    bar.legend(fontsize=7, loc="lower center", bbox_to_anchor=(0.5, 1.0), frameon=False)
    save_figure(fig, path, None)  # joint names of any length: tight layout


def plot_leg_torques(
    idx, joints, measured, predicted: dict, path, title: str = "", labels=None
) -> None:
    """Torque per pose of a few joints: measured (n, k) against each model's prediction
    (label → (n, k)), all N·m, one panel per joint."""
    k = len(joints)
    fig, axes = new_figure(k, 1, figsize=(10, 1.35 * k + 1.0), sharex=True, squeeze=False)
    for j, ax in enumerate(axes[:, 0]):
        ax.plot(idx, measured[:, j], "o", color="tab:red", ms=3, label="measured")
        for s, (label, arr) in enumerate(predicted.items()):
            style = "--" if label == "manufacturer model" else "-"
            colour = MODEL_COLOURS.get(label, f"C{s}")
            ax.plot(idx, arr[:, j], style, color=colour, lw=1.2, label=label)
        ax.set_ylabel(f"{joints[j]}\n[N·m]", fontsize=8)
        ax.grid(alpha=0.3)
    axes[0, 0].legend(  # above the panels, clear of the data
        fontsize=7, ncol=3, loc="lower right", bbox_to_anchor=(1.0, 1.0), frameon=False
    )
    axes[-1, 0].set_xlabel("pose")
    pose_ticks(axes[-1, 0], labels)
    if title:
        axes[0, 0].set_title(title, y=TITLE_Y, fontsize=10, loc="left")
    save_figure(fig, path, None)
