"""Figures of one run's statistics: a metric against revolutions, a size distribution, and
the time series of every headline metric beside the size distribution (``granalytics stats --plot``)."""

from __future__ import annotations

import numpy as np

from granalytics.analysis.metrics import BY_FIGURE, METRICS
from granalytics.report.figures._axes import SIZE_LABELS, add_key, legend_keys_last, plain_log_ticks, sizes_unit, steady_key

__all__ = ["plot_timeseries", "plot_size_distribution", "stats_figure", "FEW_GRANULES"]


def plot_timeseries(ts, column, ax=None, window=None, label=None, ylabel=None, x="revolutions"):
    """One metric of a :func:`~granalytics.run_stats` time series against revolutions.

    Parameters
    ----------
    ts : DataFrame
        Needs ``revolutions`` and ``column``.
    window : (float, float), optional
        Steady-state window (in the unit of ``x``), shaded.
    x : {"revolutions", "time_s"}, default "revolutions"
        Abscissa.
    """
    import matplotlib.pyplot as plt

    ax = ax if ax is not None else plt.gca()
    ax.plot(ts[x], ts[column], marker=".", ms=3, lw=1, label=label)
    if window is not None:
        ax.axvspan(*window, color="0.9", zorder=0)
    ax.set_xlabel("revolutions t·Ω/2π" if x == "revolutions" else "time [s]")
    ax.set_ylabel(ylabel or column)
    return ax


#: A bin of a size distribution with fewer granules than this is drawn with an open marker.
FEW_GRANULES = 3


def plot_size_distribution(dist, ax=None, label=None, *, color=None, explain=True):
    """Probability density of granule sizes (:func:`~granalytics.size_distribution`), log–log.

    The axis says the unit of the sizes (``dist.attrs["size_unit"]``: the run's particles, or
    original-particle equivalents α³·n). Where ``dist`` has ``density_lo`` and ``density_hi``
    (``size_distribution(..., ci=0.95)``) they are drawn as a band (a bootstrap over the
    granules); bins with fewer than :data:`FEW_GRANULES` granules get open markers. With
    ``explain`` the legend says what the band and the open markers are.
    """
    import matplotlib.pyplot as plt
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

    ax = ax if ax is not None else plt.gca()
    unit = sizes_unit(dist)
    occupied = dist[dist["count"] > 0]
    x, y = occupied["size_center"].to_numpy(dtype=float), occupied["density"].to_numpy(dtype=float)
    line, = ax.loglog(x, y, marker="o", ms=4, lw=1, label=label, color=color)
    few = occupied["count"].to_numpy() < FEW_GRANULES
    if few.any():
        ax.plot(x[few], y[few], ls="none", marker="o", ms=6, mfc="white", color=line.get_color())
        if explain:
            add_key(ax, f"open marker: < {FEW_GRANULES} granules in the bin", ls="none", marker="o", ms=6,
                     mfc="white", color="0.4")
    if "density_lo" in occupied and len(occupied):
        floor = y[y > 0].min() / 3 if (y > 0).any() else 1e-12  # a band down to 0 reaches below the lowest point
        lo = np.maximum(occupied["density_lo"].to_numpy(dtype=float), floor)
        ax.fill_between(x, lo, occupied["density_hi"].to_numpy(dtype=float), color=line.get_color(), alpha=0.2, lw=0)
        if explain:
            ci = dist.attrs.get("ci")
            add_key(ax, f"band: bootstrap {ci:.0%} CI over the granules" if ci else "band: bootstrap CI over the granules",
                     patch=True, color="0.5", alpha=0.3, lw=0)
    # granule sizes are small integers: label 2, 5, 10, 20, 50, … rather than powers of ten only; in
    # original-particle equivalents (α³ times larger, more decades) 1, 3, 10, 30, …, 1k, 3k: labels
    # that do not run into each other
    ax.xaxis.set_major_locator(LogLocator(base=10, subs=(1.0, 2.0, 5.0) if unit == "particles" else (1.0, 3.0)))
    ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v / 1000:g}k" if v >= 1000 else f"{v:g}"))
    ax.xaxis.set_minor_formatter(NullFormatter())
    plain_log_ticks(ax.yaxis)
    ax.set_xlabel(SIZE_LABELS[unit])
    ax.set_ylabel("probability density [per particle]" if unit == "particles"
                  else "probability density [per original particle]")
    return ax


def stats_figure(ts, dist=None, window=None, title=None, x="revolutions", steady=None):
    """Figure with the time series of every headline metric (granule number, mean volume, yield)
    and the size distribution.

    With a ``window``, the steady-state window is shaded and its mean ± block s.e.m. drawn over
    it (``steady``: a :func:`~granalytics.steady_state` table; default computed from ``ts``), both
    named in the legend below the panels.
    """
    import warnings

    import matplotlib.pyplot as plt

    panels = list(BY_FIGURE)
    n = len(panels) + (dist is not None)
    fig, axes = plt.subplots(1, n, figsize=(4 * n, 3.6), layout="constrained")
    axes = np.atleast_1d(axes)
    if window is not None and steady is None:
        from granalytics.analysis.stats import steady_state

        with warnings.catch_warnings():  # the caller has said what is wrong with the window
            warnings.simplefilter("ignore")
            steady = steady_state(ts, window=window, columns=panels, by=x)
    for ax, column in zip(axes, panels):
        plot_timeseries(ts, column, ax=ax, window=window, ylabel=METRICS[column].label, x=x, label="per frame")
        if steady is not None and column in steady.index:
            mean, sem = steady.loc[column, "mean"], steady.loc[column, "sem"]
            ax.hlines(mean, *window, color="0.3", lw=2, zorder=3)
            if np.isfinite(sem):
                ax.fill_between(list(window), mean - sem, mean + sem, color="0.5", alpha=0.3, lw=0, zorder=2)
    handles, labels = axes[0].get_legend_handles_labels()
    if window is not None:
        more = steady_key(window, x)
        handles, labels = handles + more[0], labels + more[1]
    fig.legend(handles, labels, loc="outside lower center", ncol=len(labels), fontsize=8, frameon=False)
    if dist is not None:
        plot_size_distribution(dist, ax=axes[-1], label="pooled over the window" if window is not None else None)
        legend_keys_last(axes[-1], fontsize=7)
        if window is not None:
            unit = "revolutions" if x == "revolutions" else "t [s]"
            axes[-1].set_title(f"{unit} [{window[0]:g}, {window[1]:g}]", fontsize=9)
    if title:
        fig.suptitle(title)
    return fig
