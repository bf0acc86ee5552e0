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
