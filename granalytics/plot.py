"""Plots of granulation statistics (matplotlib).

Functions take an optional ``ax`` and return the axes/figure, so they compose in notebooks.
"""

from __future__ import annotations

import numpy as np

__all__ = ["plot_timeseries", "plot_size_distribution", "stats_figure"]

_TIMESERIES = (
    ("n_granules_norm", "granules / particles"),
    ("mean_volume_norm", "⟨V_g⟩ / V_p"),
    ("yield_fraction", "yield"),
)


def plot_timeseries(ts, column, ax=None, window=None, label=None, ylabel=None):
    """One metric of a :func:`~granalytics.run_stats` time series against revolutions.

    Parameters
    ----------
    ts : DataFrame
        Needs ``revolutions`` and ``column``.
    window : (float, float), optional
        Steady-state window [revolutions], shaded.
    """
    import matplotlib.pyplot as plt

    ax = ax if ax is not None else plt.gca()
    ax.plot(ts["revolutions"], ts[column], marker=".", ms=3, lw=1, label=label)
    if window is not None:
        ax.axvspan(*window, color="0.9", zorder=0)
    ax.set_xlabel("revolutions t·Ω/2π")
    ax.set_ylabel(ylabel or column)
    return ax


def plot_size_distribution(dist, ax=None, label=None):
    """Probability density of particles per granule (:func:`~granalytics.size_distribution`), log–log."""
    import matplotlib.pyplot as plt

    ax = ax if ax is not None else plt.gca()
    from matplotlib.ticker import NullFormatter

    shown = dist[dist["count"] > 0]
    ax.loglog(shown["size_center"], shown["density"], marker="o", ms=4, lw=1, label=label)
    ax.xaxis.set_minor_formatter(NullFormatter())
    ax.set_xlabel("particles per granule")
    ax.set_ylabel("probability density")
    return ax


def stats_figure(ts, dist=None, window=None, title=None):
    """Figure with the time series of granule number, mean volume, yield and the size distribution."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    n = len(_TIMESERIES) + (dist is not None)
    fig, axes = plt.subplots(1, n, figsize=(4 * n, 3.4), layout="constrained")
    for ax, (column, ylabel) in zip(np.atleast_1d(axes), _TIMESERIES):
        plot_timeseries(ts, column, ax=ax, window=window, ylabel=ylabel)
    if dist is not None:
        plot_size_distribution(dist, ax=axes[-1])
        if window is not None:
            axes[-1].set_title(f"revolutions [{window[0]:g}, {window[1]:g}]", fontsize=9)
    if title:
        fig.suptitle(title)
    return fig
