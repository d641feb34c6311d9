"""Plots of granulation statistics (matplotlib).

Functions take an optional ``ax`` and return the axes/figure, so they compose in notebooks. They
never change matplotlib's backend (the command line selects Agg itself).
"""

from __future__ import annotations

import numpy as np

__all__ = ["plot_timeseries", "plot_size_distribution", "stats_figure", "sensitivity_figure", "comparison_figure",
           "frame_figure", "cg_figures"]

_TIMESERIES = (
    ("n_granules_norm", "granules / particles"),
    ("mean_volume_norm", "⟨V_g⟩ / V_p"),
    ("yield_fraction", "yield"),
)


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


def stats_figure(ts, dist=None, window=None, title=None, x="revolutions"):
    """Figure with the time series of granule number, mean volume, yield and the size distribution."""
    import matplotlib.pyplot as plt

    n = len(_TIMESERIES) + (dist is not None)
    fig, axes = plt.subplots(1, n, figsize=(4 * n, 3.4), layout="constrained")
    for ax, (column, ylabel) in zip(np.atleast_1d(axes), _TIMESERIES):
        plot_timeseries(ts, column, ax=ax, window=window, ylabel=ylabel, x=x)
    if dist is not None:
        plot_size_distribution(dist, ax=axes[-1])
        if window is not None:
            unit = "revolutions" if x == "revolutions" else "t [s]"
            axes[-1].set_title(f"{unit} [{window[0]:g}, {window[1]:g}]", fontsize=9)
    if title:
        fig.suptitle(title)
    return fig


def sensitivity_figure(summary, title=None):
    """Heatmaps of yield and mean granule volume over (C_agg, A_agg), and yield and mean volume
    against C_agg for every A_agg (:func:`~granalytics.sensitivity_summary` output)."""
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 4, figsize=(17, 3.8), layout="constrained")
    c_values = np.sort(summary["c_agg"].unique())
    a_values = np.sort(summary["a_agg_deg"].unique())
    for ax, (metric, label) in zip(axes[:2], (("yield_fraction", "yield"), ("mean_volume_norm", "⟨V_g⟩ / V_p"))):
        grid = summary.pivot(index="a_agg_deg", columns="c_agg", values=f"{metric}_mean").loc[a_values, c_values]
        mesh = ax.pcolormesh(_edges(c_values), np.arange(len(a_values) + 1), grid.to_numpy(), shading="flat")
        ax.set_yticks(np.arange(len(a_values)) + 0.5, [f"{a:g}" for a in a_values])
        ax.set_xlabel("C_agg")
        ax.set_ylabel("A_agg [°]")
        fig.colorbar(mesh, ax=ax, label=label)
    for ax, (metric, label) in zip(axes[2:], (("yield_fraction", "yield"), ("mean_volume_norm", "⟨V_g⟩ / V_p"))):
        for a in a_values:
            part = summary[summary["a_agg_deg"] == a].sort_values("c_agg")
            ax.errorbar(part["c_agg"], part[f"{metric}_mean"], yerr=part[f"{metric}_std"], marker=".",
                        ms=3, lw=1, capsize=2, label=f"A_agg = {a:g}°")
        ax.set_xlabel("C_agg")
        ax.set_ylabel(label)
    axes[3].set_yscale("log")
    axes[2].legend(fontsize=8)
    if title:
        fig.suptitle(title)
    return fig


def comparison_figure(stats, pairs, title=None):
    """Yield and granule number per method, and the adjusted Rand index of each pair, against
    revolutions (:func:`~granalytics.compare_methods` output)."""
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(13, 3.6), layout="constrained")
    for name, part in stats.groupby("method", sort=False):
        plot_timeseries(part, "yield_fraction", ax=axes[0], label=name, ylabel="yield")
        plot_timeseries(part, "n_granules_norm", ax=axes[1], label=name, ylabel="granules / particles")
    for (a, b), part in pairs.groupby(["method_a", "method_b"], sort=False):
        plot_timeseries(part, "ari", ax=axes[2], label=f"{a} vs {b}", ylabel="adjusted Rand index")
    axes[2].set_ylim(-0.05, 1.05)
    for ax in axes:
        ax.legend(fontsize=8)
    if title:
        fig.suptitle(title)
    return fig


def _edges(values):
    """Cell edges around sorted centre values (for pcolormesh)."""
    values = np.asarray(values, dtype=float)
    if values.size == 1:
        return np.array([values[0] - 0.5, values[0] + 0.5])
    mid = (values[1:] + values[:-1]) / 2
    return np.r_[values[0] - (mid[0] - values[0]), mid, values[-1] + (values[-1] - mid[-1])]


def frame_figure(result, ax=None, max_colours=20):
    """3-D scatter of one identified frame, particles sized by radius and coloured by granule
    (the largest ``max_colours`` granules in distinct colours, other granules grey, free
    particles light grey)."""
    import matplotlib.pyplot as plt

    s = result.snapshot
    if ax is None:
        fig = plt.figure(figsize=(6, 6))
        ax = fig.add_subplot(projection="3d")
    colours = np.full((s.n_particles, 4), (0.85, 0.85, 0.85, 0.25))
    member = result.labels >= 0
    colours[member] = (0.45, 0.45, 0.45, 0.8)
    palette = plt.get_cmap("tab20")
    for g in range(min(result.n_granules, max_colours)):
        colours[result.labels == g] = palette(g % 20)
    size = (s.radius / s.radius.max()) ** 2 * 30
    ax.scatter(s.position[:, 0], s.position[:, 1], s.position[:, 2], c=colours, s=size, depthshade=False)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_zlabel("z [m]")
    ax.set_title(f"t = {s.time:.3f} s: {result.n_granules} granules, yield {result.n_granulated / s.n_particles:.2f}")
    ax.set_aspect("equal")
    return ax.figure


def cg_figures(comparison) -> dict:
    """The paper's Figs 3–6 for a :class:`~granalytics.cg.CGComparison`: ⟨V_g⟩/V_p, N_g/N and
    yield against revolutions (one curve per run, the steady-state window shaded, its mean ± s.e.m.
    as a band) and the particles-per-granule distribution pooled over the window (log axes).

    Returns
    -------
    dict of str -> Figure, keyed ``fig3_mean_volume``, ``fig4_granule_number``,
    ``fig5_size_distribution``, ``fig6_yield``.
    """
    import matplotlib.pyplot as plt

    panels = (("fig3_mean_volume", "mean_volume_norm", "⟨V_g⟩ / V_p", "mean granule volume"),
              ("fig4_granule_number", "n_granules_norm", "N_g / N", "number of granules"),
              ("fig6_yield", "yield_fraction", "yield (fraction of particles in granules)", "granulation yield"))
    subtitle = comparison.description
    figures = {}
    for name, column, ylabel, what in panels:
        fig, ax = plt.subplots(figsize=(6, 4), layout="constrained")
        for k, (label, part) in enumerate(comparison.timeseries.groupby("run", sort=False)):
            colour = f"C{k}"
            ax.plot(part["revolutions"], part[column], lw=1, marker=".", ms=3, color=colour, label=label)
            row = comparison.table[comparison.table["run"] == label].iloc[0]
            mean, sem = row[f"{column}_mean"], row[f"{column}_sem"]
            lo, hi = comparison.window
            ax.hlines(mean, lo, hi, color=colour, lw=2, alpha=0.8)
            if np.isfinite(sem):
                ax.fill_between([lo, hi], mean - sem, mean + sem, color=colour, alpha=0.15, lw=0)
        ax.axvspan(*comparison.window, color="0.93", zorder=0)
        ax.set_xlabel("revolutions t·Ω/2π")
        ax.set_ylabel(ylabel)
        ax.set_title(f"Effect of CG on the {what}\n{subtitle}", fontsize=9)
        ax.legend(fontsize=8)
        figures[name] = fig
    fig, ax = plt.subplots(figsize=(6, 4), layout="constrained")
    for k, (label, part) in enumerate(comparison.distributions.groupby("run", sort=False)):
        if part["count"].sum():
            plot_size_distribution(part, ax=ax, label=f"{label}: {int(part['count'].sum())} granules")
    ax.set_title(f"Particles per granule over revolutions [{comparison.window[0]:g}, {comparison.window[1]:g}]"
                 f"\n{subtitle}", fontsize=9)
    ax.legend(fontsize=8)
    figures["fig5_size_distribution"] = fig
    return dict(sorted(figures.items()))
