"""The figure of a method comparison (:func:`granalytics.compare_methods`): each method's
statistics and each pair's agreement per frame."""

from __future__ import annotations

import numpy as np

from granalytics.analysis.metrics import HEADLINE, METRICS
from granalytics.report.figures.timeseries import plot_timeseries

__all__ = ["comparison_figure"]


def comparison_figure(stats, pairs, title=None):
    """Every headline metric per method, and the adjusted Rand index of each pair, against
    revolutions (:func:`~granalytics.compare_methods` output). A method whose statistics equal an
    earlier one's (:func:`~granalytics.identical_methods`) is drawn dotted over it, and named so."""
    import matplotlib.pyplot as plt

    from granalytics.analysis.method_comparison import identical_methods

    headline = list(HEADLINE)
    fig, axes = plt.subplots(1, len(headline) + 1, figsize=(4.3 * (len(headline) + 1), 3.9), layout="constrained")
    methods = list(dict.fromkeys(stats["method"]))
    colour = {name: f"C{k % 10}" for k, name in enumerate(methods)}  # a method's colour in every panel
    same_as = identical_methods(stats, headline)
    for name, part in stats.groupby("method", sort=False):
        label = f"{name} (identical to {same_as[name]})" if name in same_as else name
        for ax, metric in zip(axes, headline):
            plot_timeseries(part, metric, ax=ax, label=label, ylabel=METRICS[metric].label)
            line = ax.lines[-1]
            line.set_color(colour[name])
            if name in same_as:  # on top of the one it equals, visible through it
                line.set(ls=":", lw=2.5, marker="x", ms=4)
    _draw_method_pairs(axes[-1], pairs, len(methods))
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower left", ncol=len(labels), fontsize=8, frameon=False,
               title="method (the same colour in every panel)", title_fontsize=8)
    axes[-1].legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.2), ncol=2, frameon=False)
    if title:
        fig.suptitle(title)
    return fig


def _draw_method_pairs(ax, pairs, n_methods):
    """The adjusted Rand index of each pair of methods against revolutions: other colours than the
    methods' (tab10 after them), each its own dash pattern so that overlapping curves stay visible."""
    dashes = ("--", "-.", ":", (0, (5, 1, 1, 1)), (0, (3, 2)), (0, (1, 2)))
    for k, ((a, b), part) in enumerate(pairs.groupby(["method_a", "method_b"], sort=False)):
        identical = np.allclose(part["ari"].to_numpy(dtype=float), 1.0)
        plot_timeseries(part, "ari", ax=ax, label=f"{a} vs {b}" + (" (identical: ARI 1)" if identical else ""),
                        ylabel="adjusted Rand index")
        ax.lines[-1].set(color=f"C{(n_methods + k) % 10}", ls=dashes[k % len(dashes)], lw=1.5)
    ax.set_ylim(-0.05, 1.05)
