"""The figures of a CG comparison: the paper's Figs 3–6 (:class:`granalytics.CGComparison`)
and the deviation heatmaps of a threshold grid (:func:`granalytics.compare_cg_thresholds`)."""

from __future__ import annotations

import numpy as np

from granalytics.analysis.metrics import BY_FIGURE, METRICS
from granalytics.report.figures._axes import legend_keys_last, steady_key
from granalytics.report.figures.timeseries import plot_size_distribution

__all__ = ["cg_figures", "cg_figure_names", "cg_threshold_figures"]


#: the key of the pooled size distribution (Fig 5) among :func:`cg_figures`
_SIZE_FIGURE = "fig5_size_distribution"


def cg_figure_names() -> list:
    """The keys of :func:`cg_figures`, sorted: each headline metric's ``figure_key``
    (``fig3_mean_volume``, ``fig4_granule_number``, ``fig6_yield``) and ``fig5_size_distribution``."""
    return sorted([*(METRICS[m].figure_key for m in BY_FIGURE), _SIZE_FIGURE])


def cg_figures(comparison, *, size_unit="particles") -> dict:
    """The paper's Figs 3–6 for a :class:`~granalytics.analysis.cg.CGComparison`: ⟨V_g⟩/V_p, N_g/N and
    yield against revolutions (one curve per run, the steady-state window shaded, its mean ± block
    s.e.m. as a band) and the granule size distribution pooled over the window (log axes) with a
    bootstrap 95 % band over the granules (:meth:`~granalytics.CGComparison.size_distributions`)
    and open markers on bins of fewer than :data:`FEW_GRANULES` granules. A group of replicas is
    drawn as the replicas' mean at their common frames with their range (min–max) as a band
    (:meth:`~granalytics.CGComparison.replica_spread`), and its steady-state mean ± the replica
    standard error (the errors of the comparison's table). Each run has one colour in every
    figure; the legends name the window, the mean lines and every band.

    Parameters
    ----------
    comparison : CGComparison
    size_unit : {"particles", "original"}, default "particles"
        Sizes of Fig 5 in each run's own particles, or in original-particle equivalents α³·n
        (the unit in which the CG levels are compared: a CG3 pair is 54 original particles).

    Returns
    -------
    dict of str -> Figure, keyed by :func:`cg_figure_names`.
    """
    import textwrap

    subtitle = "\n".join(textwrap.wrap(comparison.description, 80))  # the figure is ~80 characters wide at 9 pt
    runs = list(dict.fromkeys(comparison.table["run"]))
    colours = {run: f"C{k % 10}" for k, run in enumerate(runs)}  # one colour per run (CG level) in every figure
    figures = {METRICS[m].figure_key: _cg_timeseries_figure(comparison, m, colours, subtitle) for m in BY_FIGURE}
    figures[_SIZE_FIGURE] = _cg_sizes_figure(comparison, colours, size_unit, subtitle)
    return dict(sorted(figures.items()))


def _cg_timeseries_figure(comparison, column, colours, subtitle):
    """One of Figs 3, 4 and 6: ``column`` of every run against revolutions, its steady-state mean
    and error over the window."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4.3), layout="constrained")
    for label, part in comparison.timeseries.groupby("run", sort=False):
        row = comparison.table[comparison.table["run"] == label].iloc[0]
        _draw_cg_run(ax, comparison, part, row, column, colours[label])
    ax.axvspan(*comparison.window, color="0.9", zorder=0)
    ax.set_xlabel("revolutions t·Ω/2π")
    ax.set_ylabel(METRICS[column].label)
    ax.set_title(f"Effect of CG on the {METRICS[column].what}\n{subtitle}", fontsize=9)
    _cg_timeseries_legend(ax, comparison.window, (comparison.table["n_replicas"] > 1).any())
    return fig


def _draw_cg_run(ax, comparison, part, row, column, colour):
    """One run's curve (a group of replicas: their mean and range) and its steady-state mean ±
    error (a group: the replica standard error; one run: the block s.e.m.) over the window."""
    if row["n_replicas"] > 1:
        spread = comparison.replica_spread(row["run"], column)
        ax.plot(spread.index, spread["mean"], lw=1, marker=".", ms=3, color=colour,
                label=f"{row['run']}: replica mean, range")
        ax.fill_between(spread.index, spread["min"], spread["max"], color=colour, alpha=0.2, lw=0)
        sem = row[f"{column}_replica_sem"]
    else:
        ax.plot(part["revolutions"], part[column], lw=1, marker=".", ms=3, color=colour, label=row["run"])
        sem = row[f"{column}_sem"]
    mean = row[f"{column}_mean"]
    lo, hi = comparison.window
    ax.hlines(mean, lo, hi, color=colour, lw=2, alpha=0.8)
    if np.isfinite(sem):
        ax.fill_between([lo, hi], mean - sem, mean + sem, color=colour, alpha=0.15, lw=0)


def _cg_timeseries_legend(ax, window, any_group):
    """The legend below a time-series figure of the CG comparison: the runs, then the window, the
    mean ± error and (with replica groups) their range band, keyed in grey."""
    from matplotlib.patches import Patch

    handles, labels = ax.get_legend_handles_labels()
    error = "block s.e.m. (replica groups: replica s.e.)" if any_group else "block s.e.m."
    more = steady_key(window, error=error)
    if any_group:  # the replicas' range band, in grey like the other keys
        more[0].append(Patch(color="0.5", alpha=0.2, lw=0))
        more[1].append("band over the curve: range (min–max) of the replicas")
    handles, labels = handles + more[0], labels + more[1]
    ax.legend(handles, labels, fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.18), frameon=False,
              ncol=2 if max(map(len, labels)) <= 30 else 1)  # long labels (replica groups): one per line


def _cg_sizes_figure(comparison, colours, size_unit, subtitle):
    """Fig 5: every run's granule sizes pooled over the window, with their bootstrap bands."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4.3), layout="constrained")
    frames = dict(zip(comparison.table["run"], comparison.table["n_frames"]))
    for label, dist in comparison.size_distributions(size_unit, ci=0.95).items():
        plot_size_distribution(dist, ax=ax, color=colours[label],
                               label=f"{label}: {int(dist['count'].sum())} granules in {int(frames[label])} frames")
    what = "particles" if size_unit == "particles" else "original-particle equivalents"
    ax.set_title(f"Granule sizes ({what}) over revolutions [{comparison.window[0]:g}, {comparison.window[1]:g}]"
                 f"\n{subtitle}", fontsize=9)
    legend_keys_last(ax, fontsize=7)
    return fig


def cg_threshold_figures(table) -> dict:
    """Heatmaps of :func:`~granalytics.compare_cg_thresholds`: one figure per headline statistic,
    one panel per coarse-grained run, the relative deviation from the finest run at every
    (C_agg, A_agg) in a diverging scale centred on 0 (red: the CG run gives more, blue: less),
    each cell annotated in percent; grey cells: the finest run has a zero mean there (no granules),
    so no relative deviation exists."""
    import matplotlib.pyplot as plt
    from matplotlib.colors import TwoSlopeNorm
    from matplotlib.ticker import FuncFormatter

    finest = table.loc[table["alpha"].idxmin(), "run"]
    runs = [r for r in table["run"].unique() if r != finest]
    figures = {}
    for metric in BY_FIGURE:
        values = 100 * table.loc[table["run"].isin(runs), f"{metric}_rel_dev"].to_numpy(dtype=float)  # percent
        span = np.nanmax(np.abs(values)) if np.isfinite(values).any() else 1.0
        norm = TwoSlopeNorm(vcenter=0.0, vmin=-max(span, 1e-9), vmax=max(span, 1e-9))
        fig, axes = plt.subplots(1, len(runs), figsize=(4.8 * len(runs), 3.8), layout="constrained", squeeze=False)
        for ax, run in zip(axes[0], runs):
            mesh = _draw_cg_threshold_panel(ax, table[table["run"] == run], metric, norm, span)
            ax.set_title(f"{run} vs {finest}", fontsize=9)
        bar = fig.colorbar(mesh, ax=axes[0].tolist(), label=f"relative deviation from {finest} [%]")
        bar.ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:+.0f}" if v else "0"))
        fig.suptitle(f"CG deviation of {METRICS[metric].label} ({METRICS[metric].figure}) at every threshold pair [%]\n"
                     "± its standard error (from both runs' block s.e.m.)\n"
                     "grey: no granules in the finest run (no relative deviation)", fontsize=9)
        figures[f"cg_thresholds_{metric}"] = fig
    return figures


def _draw_cg_threshold_panel(ax, rows, metric, norm, span):
    """One run's relative deviation of ``metric`` over the threshold grid, in percent, each cell
    annotated (± its standard error where the table has one); grey where it has none. Returns
    the mesh (for the colour bar)."""
    col = f"{metric}_rel_dev"
    part = rows.pivot(index="a_agg_deg", columns="c_agg", values=col)
    c, a = part.columns.to_numpy(dtype=float), part.index.to_numpy(dtype=float)
    grid = np.ma.masked_invalid(100 * part.to_numpy(dtype=float))
    ax.set_facecolor("0.8")
    mesh = ax.pcolormesh(np.arange(c.size + 1), np.arange(a.size + 1), grid, cmap="RdBu_r", norm=norm)
    error = (100 * rows.pivot(index="a_agg_deg", columns="c_agg", values=f"{col}_se").to_numpy(dtype=float)
             if f"{col}_se" in rows else np.full(grid.shape, np.nan))
    for i in range(a.size):
        for j in range(c.size):
            if not np.ma.is_masked(grid[i, j]):
                dark = abs(grid[i, j]) > 0.6 * span
                cell_text = f"{grid[i, j]:+.0f}" + (f"\n±{error[i, j]:.0f}" if np.isfinite(error[i, j]) else "")
                ax.text(j + 0.5, i + 0.5, cell_text, ha="center", va="center", fontsize=6, color="w" if dark else "k")
    ax.set_xticks(np.arange(c.size) + 0.5, [f"{x:.3g}" for x in c], fontsize=7)
    ax.set_yticks(np.arange(a.size) + 0.5, [f"{x:g}" for x in a], fontsize=7)
    ax.set_xlabel("C_agg")
    ax.set_ylabel("A_agg [deg]")
    return mesh
