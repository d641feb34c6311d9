"""The figure of a threshold sensitivity pass (:func:`granalytics.sensitivity_summary`):
heatmaps and line plots over C_agg × A_agg."""

from __future__ import annotations

import numpy as np

from granalytics.analysis.metrics import HEADLINE, METRICS
from granalytics.report.figures._axes import cell_edges, plain_log_ticks

__all__ = ["sensitivity_figure"]


def sensitivity_figure(summary, title=None):
    """Heatmaps of every headline metric over (C_agg, A_agg) (or (C_agg, rigid_tol)) (top row), and
    each against C_agg for every co-motion threshold (bottom row)
    (:func:`~granalytics.sensitivity_summary` output)."""
    import matplotlib.pyplot as plt

    from granalytics.analysis.sensitivity import comotion_column

    column = comotion_column(summary)
    name, unit = ("A_agg", "°") if column == "a_agg_deg" else ("rigid_tol", "")
    headline = list(HEADLINE)
    fig, axes = plt.subplots(2, len(headline), figsize=(4.6 * len(headline), 7.2), layout="constrained", squeeze=False)
    a_values = np.sort(summary[column].unique())
    for ax, metric in zip(axes[0], headline):
        _draw_sensitivity_heatmap(fig, ax, summary, column, metric, f"{name} [{unit}]" if unit else name)
    for ax, metric in zip(axes[1], headline):
        for a in a_values:
            part = summary[summary[column] == a].sort_values("c_agg")
            ax.errorbar(part["c_agg"], part[f"{metric}_mean"], yerr=part[f"{metric}_std"], marker=".",
                        ms=3, lw=1, capsize=2, label=f"{name} = {a:g}{unit}")
        ax.set_xlabel("C_agg")
        ax.set_ylabel(METRICS[metric].label)
        if METRICS[metric].log_scale:
            ax.set_yscale("log")
            plain_log_ticks(ax.yaxis)
    # the legend below the panels, where it covers no curve
    handles, labels = axes[1, 0].get_legend_handles_labels()
    middle = axes[1, len(headline) // 2]
    middle.legend(handles, labels, loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=min(len(labels), 6),
                  fontsize=8, title="bars: ± std over the frames", title_fontsize=8, frameon=False)
    fig.text(0.5, -0.01, "heatmaps: mean over the window's frames; white cells: no granules at that pair (⟨V_g⟩ "
             "undefined); line plots: mean ± standard deviation over the frames (frame-to-frame spread, not an "
             "error of the mean)\nthe cliff: a contact is kept when F_coh ≥ C_agg·2πγR, so every statistic falls "
             "to 0 at C_agg above the largest F_coh/(2πγR) of the run (docs/identification.md)",
             ha="center", va="top", fontsize=8)
    if title:
        fig.suptitle(title)
    return fig


def _draw_sensitivity_heatmap(fig, ax, summary, column, metric, ylabel):
    """One metric's mean over the (C_agg, co-motion threshold) grid of a sensitivity summary, with
    its colour bar."""
    c_values = np.sort(summary["c_agg"].unique())
    a_values = np.sort(summary[column].unique())
    grid = summary.pivot(index=column, columns="c_agg", values=f"{metric}_mean").loc[a_values, c_values]
    mesh = ax.pcolormesh(cell_edges(c_values), np.arange(len(a_values) + 1), grid.to_numpy(), shading="flat")
    ax.set_yticks(np.arange(len(a_values)) + 0.5, [f"{a:g}" for a in a_values])
    ax.set_xlabel("C_agg")
    ax.set_ylabel(ylabel)
    fig.colorbar(mesh, ax=ax, label=METRICS[metric].label)
