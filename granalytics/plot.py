"""Plots of granulation statistics (matplotlib).

The figures draw what :mod:`granalytics.analysis` computes (a figure given a result calls the
analysis function that derives what it shows, e.g. :meth:`~granalytics.CGComparison.size_distributions`);
no statistic is computed here, and no analysis module draws. Functions take an optional ``ax``
and return the axes/figure, so they compose in notebooks. They never change matplotlib's backend
(the command line selects Agg itself).
"""

from __future__ import annotations

import math
import os

import typing

import numpy as np
import pandas as pd

from granalytics.analysis.metrics import BY_FIGURE, HEADLINE, METRICS

if typing.TYPE_CHECKING:
    from granalytics.analysis.tracking import GranuleTracks

__all__ = ["plot_timeseries", "plot_size_distribution", "stats_figure", "sensitivity_figure", "comparison_figure",
           "frame_figure", "cg_figures", "cg_figure_names", "tracking_figure", "growth_figure", "cg_threshold_figures",
           "pbm_figure", "calibration_figures"]



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


#: Axis labels of granule sizes in each unit (:data:`granalytics.analysis.stats.SIZE_UNITS`).
SIZE_LABELS = {"particles": "particles per granule",
               "original": "original-particle equivalents per granule (α³·n)"}
#: A bin of a size distribution with fewer granules than this is drawn with an open marker.
FEW_GRANULES = 3


def _plain_log_ticks(axis):
    """Plain numbers on a logarithmic axis ("6", "0.2", "1e-05"), never "6×10⁰": matplotlib's own
    choice of which minor ticks to label (all of them below a decade, some below 2.5 decades)."""
    from matplotlib.ticker import LogFormatter

    class Plain(LogFormatter):
        def _num_to_string(self, x, vmin, vmax):
            return f"{x:g}"

    axis.set_major_formatter(Plain(labelOnlyBase=False))
    axis.set_minor_formatter(Plain(labelOnlyBase=False, minor_thresholds=(1, 0.4)))


def _sizes_unit(table, size_unit=None) -> str:
    """The size unit of a table of :func:`~granalytics.size_distribution` or
    :func:`~granalytics.coalescence_kernel` (its ``attrs``), unless given."""
    unit = size_unit or getattr(table, "attrs", {}).get("size_unit", "particles")
    if unit not in SIZE_LABELS:
        from granalytics.base.errors import ParameterError

        raise ParameterError(f"size_unit must be one of {', '.join(SIZE_LABELS)}, got {unit!r}")
    return unit


def _add_key(ax, label, **style):
    """A legend entry that explains a style (drawn once per axes, nothing on the plot)."""
    if label not in ax.get_legend_handles_labels()[1]:
        if style.pop("patch", False):
            ax.fill_between([], [], [], label=label, **style)
        else:
            ax.plot([], [], label=label, **style)


def _legend_keys_last(ax, **kwargs):
    """The axes' legend with the curves first and the keys of :func:`_add_key` (band, open
    markers) after them."""
    handles, labels = ax.get_legend_handles_labels()
    keyed = [lab.startswith(("band:", "open marker:")) for lab in labels]
    order = [i for i, k in enumerate(keyed) if not k] + [i for i, k in enumerate(keyed) if k]
    return ax.legend([handles[i] for i in order], [labels[i] for i in order], **kwargs)


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
    unit = _sizes_unit(dist)
    shown = dist[dist["count"] > 0]
    x, y = shown["size_center"].to_numpy(dtype=float), shown["density"].to_numpy(dtype=float)
    line, = ax.loglog(x, y, marker="o", ms=4, lw=1, label=label, color=color)
    few = shown["count"].to_numpy() < FEW_GRANULES
    if few.any():
        ax.plot(x[few], y[few], ls="none", marker="o", ms=6, mfc="white", color=line.get_color())
        if explain:
            _add_key(ax, f"open marker: < {FEW_GRANULES} granules in the bin", ls="none", marker="o", ms=6,
                     mfc="white", color="0.4")
    if "density_lo" in shown and len(shown):
        floor = y[y > 0].min() / 3 if (y > 0).any() else 1e-12  # a band down to 0 reaches below the lowest point
        lo = np.maximum(shown["density_lo"].to_numpy(dtype=float), floor)
        ax.fill_between(x, lo, shown["density_hi"].to_numpy(dtype=float), color=line.get_color(), alpha=0.2, lw=0)
        if explain:
            ci = dist.attrs.get("ci")
            _add_key(ax, f"band: bootstrap {ci:.0%} CI over the granules" if ci else "band: bootstrap CI over the granules",
                     patch=True, color="0.5", alpha=0.3, lw=0)
    # granule sizes are small integers: label 2, 5, 10, 20, 50, … rather than powers of ten only; in
    # original-particle equivalents (α³ times larger, more decades) 1, 3, 10, 30, …, 1k, 3k: labels
    # that do not run into each other
    ax.xaxis.set_major_locator(LogLocator(base=10, subs=(1.0, 2.0, 5.0) if unit == "particles" else (1.0, 3.0)))
    ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v / 1000:g}k" if v >= 1000 else f"{v:g}"))
    ax.xaxis.set_minor_formatter(NullFormatter())
    _plain_log_ticks(ax.yaxis)
    ax.set_xlabel(SIZE_LABELS[unit])
    ax.set_ylabel("probability density [per particle]" if unit == "particles"
                  else "probability density [per original particle]")
    return ax


def _steady_key(window, x="revolutions", error="block s.e.m."):
    """Legend handles and labels of the steady-state window (shaded) and its mean ± error (a
    line over a band), in grey: one entry each, whatever the colours of the curves."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    unit = "rev" if x == "revolutions" else "s"
    return ([Patch(color="0.9"), (Patch(color="0.5", alpha=0.3, lw=0), Line2D([], [], color="0.3", lw=2))],
            [f"steady-state window [{window[0]:g}, {window[1]:g}] {unit}", f"steady-state mean ± {error}"])


def stats_figure(ts, dist=None, window=None, title=None, x="revolutions", steady=None):
    """Figure with the time series of every headline metric (granule number, mean volume, yield)
    and the size distribution.

    With a ``window``, the steady-state window is shaded and its mean ± block s.e.m. drawn over
    it (``steady``: a :func:`~granalytics.steady_state` table; default computed from ``ts``), both
    named in the legend below the panels.
    """
    import warnings

    import matplotlib.pyplot as plt

    shown = list(BY_FIGURE)
    n = len(shown) + (dist is not None)
    fig, axes = plt.subplots(1, n, figsize=(4 * n, 3.6), layout="constrained")
    axes = np.atleast_1d(axes)
    if window is not None and steady is None:
        from granalytics.analysis.stats import steady_state

        with warnings.catch_warnings():  # the caller has said what is wrong with the window
            warnings.simplefilter("ignore")
            steady = steady_state(ts, window=window, columns=shown, by=x)
    for ax, column in zip(axes, shown):
        plot_timeseries(ts, column, ax=ax, window=window, ylabel=METRICS[column].label, x=x, label="per frame")
        if steady is not None and column in steady.index:
            mean, sem = steady.loc[column, "mean"], steady.loc[column, "sem"]
            ax.hlines(mean, *window, color="0.3", lw=2, zorder=3)
            if np.isfinite(sem):
                ax.fill_between(list(window), mean - sem, mean + sem, color="0.5", alpha=0.3, lw=0, zorder=2)
    handles, labels = axes[0].get_legend_handles_labels()
    if window is not None:
        more = _steady_key(window, x)
        handles, labels = handles + more[0], labels + more[1]
    fig.legend(handles, labels, loc="outside lower center", ncol=len(labels), fontsize=8, frameon=False)
    if dist is not None:
        plot_size_distribution(dist, ax=axes[-1], label="pooled over the window" if window is not None else None)
        _legend_keys_last(axes[-1], fontsize=7)
        if window is not None:
            unit = "revolutions" if x == "revolutions" else "t [s]"
            axes[-1].set_title(f"{unit} [{window[0]:g}, {window[1]:g}]", fontsize=9)
    if title:
        fig.suptitle(title)
    return fig


def sensitivity_figure(summary, title=None):
    """Heatmaps of every headline metric over (C_agg, A_agg) (or (C_agg, rigid_tol)) (top row), and
    each against C_agg for every co-motion threshold (bottom row)
    (:func:`~granalytics.sensitivity_summary` output)."""
    import matplotlib.pyplot as plt

    from granalytics.analysis.sensitivity import comotion_column

    column = comotion_column(summary)
    name, unit = ("A_agg", "°") if column == "a_agg_deg" else ("rigid_tol", "")
    shown = list(HEADLINE)
    fig, axes = plt.subplots(2, len(shown), figsize=(4.6 * len(shown), 7.2), layout="constrained", squeeze=False)
    a_values = np.sort(summary[column].unique())
    for ax, metric in zip(axes[0], shown):
        _draw_sensitivity_heatmap(fig, ax, summary, column, metric, f"{name} [{unit}]" if unit else name)
    for ax, metric in zip(axes[1], shown):
        for a in a_values:
            part = summary[summary[column] == a].sort_values("c_agg")
            ax.errorbar(part["c_agg"], part[f"{metric}_mean"], yerr=part[f"{metric}_std"], marker=".",
                        ms=3, lw=1, capsize=2, label=f"{name} = {a:g}{unit}")
        ax.set_xlabel("C_agg")
        ax.set_ylabel(METRICS[metric].label)
        if METRICS[metric].log_scale:
            ax.set_yscale("log")
            _plain_log_ticks(ax.yaxis)
    # the legend below the panels, where it covers no curve
    handles, labels = axes[1, 0].get_legend_handles_labels()
    middle = axes[1, len(shown) // 2]
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
    mesh = ax.pcolormesh(_edges(c_values), np.arange(len(a_values) + 1), grid.to_numpy(), shading="flat")
    ax.set_yticks(np.arange(len(a_values)) + 0.5, [f"{a:g}" for a in a_values])
    ax.set_xlabel("C_agg")
    ax.set_ylabel(ylabel)
    fig.colorbar(mesh, ax=ax, label=METRICS[metric].label)


def comparison_figure(stats, pairs, title=None):
    """Every headline metric per method, and the adjusted Rand index of each pair, against
    revolutions (:func:`~granalytics.compare_methods` output). A method whose statistics equal an
    earlier one's (:func:`~granalytics.identical_methods`) is drawn dotted over it, and named so."""
    import matplotlib.pyplot as plt

    from granalytics.analysis.method_comparison import identical_methods

    shown = list(HEADLINE)
    fig, axes = plt.subplots(1, len(shown) + 1, figsize=(4.3 * (len(shown) + 1), 3.9), layout="constrained")
    methods = list(dict.fromkeys(stats["method"]))
    colour = {name: f"C{k % 10}" for k, name in enumerate(methods)}  # a method's colour in every panel
    same_as = identical_methods(stats, shown)
    for name, part in stats.groupby("method", sort=False):
        label = f"{name} (identical to {same_as[name]})" if name in same_as else name
        for ax, metric in zip(axes, shown):
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
    lo, hi = s.position.min(axis=0) - s.radius.max(), s.position.max(axis=0) + s.radius.max()
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_zlim(lo[2], hi[2])
    ax.set_aspect("equal")
    # marker diameter = the particle's diameter on the axes' scale (points per metre from the axes'
    # width and the longest data span; exact for the view straight along an axis)
    width_pt = ax.get_position().width * ax.figure.get_figwidth() * 72
    points_per_m = width_pt / float((hi - lo).max()) / 1.6  # a 3-D box fills ~1/1.6 of the axes' width
    size = (2 * s.radius * points_per_m) ** 2
    ax.scatter(s.position[:, 0], s.position[:, 1], s.position[:, 2], c=colours, s=size, depthshade=False)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_zlabel("z [m]")
    ax.set_title(f"t = {s.time:.3f} s: {result.n_granules} granules, yield {result.n_granulated / s.n_particles:.2f}")
    return ax.figure


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
    more = _steady_key(window, error=error)
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
    _legend_keys_last(ax, fontsize=7)
    return fig


def tracking_figure(tracks: GranuleTracks, rates: pd.DataFrame, kernel: pd.DataFrame | None = None, *,
                    n_histories=8, title=None, size_unit=None, alpha=None):
    """Event rates per bin, a few granule size histories and (optionally) the coalescence kernel.

    The rates are drawn with Poisson error bars (± √count over the bin's tracked time,
    :func:`~granalytics.rate_errors`), as markers and lines, or as bars per event kind when there
    is a single bin (a one-revolution window); every legend sits below its panel, never over the
    tracks.

    Parameters
    ----------
    tracks : GranuleTracks
    rates : DataFrame
        Output of :func:`event_rates` (per revolution when it has a period, else per second).
    kernel : DataFrame, optional
        Output of :func:`coalescence_kernel`: shown as a heatmap of log10 β with the number of
        coalescence events annotated in each cell (:func:`~granalytics.kernel_matrix`).
    n_histories : int, default 8
        Size histories shown: the longest-lived tracks, ties the largest
        (:func:`~granalytics.size_histories`).
    title : str, optional
    size_unit : {"particles", "original"}, optional
        Unit of the sizes (histories and kernel classes): default the kernel's (its ``attrs``;
        ``coalescence_kernel(..., size_unit=...)``), else the run's particles. ``"original"``:
        original-particle equivalents α³·n.
    alpha : float, or a run or its metadata, optional
        The CG factor, for ``"original"`` histories (default the kernel's).

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib.pyplot as plt

    from granalytics.analysis.tracking import size_histories

    unit = _sizes_unit(kernel, size_unit)
    if unit == "original" and alpha is None and kernel is not None:
        alpha = kernel.attrs.get("alpha")
    histories = size_histories(tracks, n_histories, size_unit=unit, alpha=alpha)
    n = 3 if kernel is not None else 2
    fig, axes = plt.subplots(1, n, figsize=(5.2 * n, 4.6), layout="constrained")
    per_rev = rates["rate_per_rev"].notna().any()
    _draw_event_rates(axes[0], rates, per_rev)
    # the same abscissa as the rates beside it: revolutions when the rates are per revolution
    scale = (rates["rev_end"] - rates["rev_start"]).max() / (rates["time_end_s"] - rates["time_start_s"]).max() \
        if per_rev else 1.0
    _draw_size_histories(axes[1], histories, scale, per_rev)
    axes[1].set_title(f"size histories ({tracks.n_tracks} tracks)", fontsize=10)
    if kernel is not None:
        _draw_kernel(fig, axes[2], kernel)
    if title:
        fig.suptitle(title)
    return fig


#: a legend below its panel (the tracking figure's): never over the curves
_BELOW = dict(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.16), frameon=False)


def _draw_event_rates(ax, rates, per_rev):
    """The event rates of :func:`event_rates` with their Poisson errors: markers and lines over
    the bins, or one bar per kind (its count on top) when there is a single bin."""
    from granalytics.analysis.tracking import KINDS, rate_errors

    column = "rate_per_rev" if per_rev else "rate_per_s"
    errors = rate_errors(rates, column)
    n_bins = rates["bin"].nunique() if "bin" in rates else len(rates) // max(1, len(KINDS))
    for k, kind in enumerate(KINDS):
        mine = rates["kind"] == kind
        part, y, err = rates[mine], rates.loc[mine, column], errors[mine]
        if n_bins == 1:  # one bin (a one-revolution window): a bar per kind, its count on top
            height, e = float(np.nan_to_num(y.iloc[0])), float(err.iloc[0])
            ax.bar(k, height, yerr=e, color=f"C{k}", capsize=3, label=kind)
            ax.text(k, height + e, f"{int(part['count'].iloc[0])}", ha="center", va="bottom", fontsize=7)
        else:
            x = (part["rev_start"] + part["rev_end"]) / 2 if per_rev else (part["time_start_s"] + part["time_end_s"]) / 2
            ax.errorbar(x, y, yerr=err, marker="o", ms=5, lw=1, capsize=2, color=f"C{k}", label=kind)
    if n_bins == 1:
        lo, hi = (rates["rev_start"].iloc[0], rates["rev_end"].iloc[0]) if per_rev else \
            (rates["time_start_s"].iloc[0], rates["time_end_s"].iloc[0])
        ax.set_xticks(range(len(KINDS)), list(KINDS), fontsize=8)
        ax.set_xlabel(f"event kind ({'revolutions' if per_rev else 't [s]'} {lo:g}–{hi:g}; events on the bars)")
    else:
        ax.set_xlabel("revolutions t·Ω/2π" if per_rev else "time [s]")
    ax.set_ylabel("events per revolution" if per_rev else "events per second [1/s]")
    ax.set_title("event rates (bars: Poisson ± √count)", fontsize=10)
    ax.legend(ncol=len(KINDS), **_BELOW)


def _draw_size_histories(ax, histories, scale, per_rev):
    """The size histories of :func:`~granalytics.size_histories` on a logarithmic size axis, time
    times ``scale`` (revolutions per second, or 1)."""
    from matplotlib.ticker import FuncFormatter, LogLocator

    for track, history in histories.groupby("track", sort=False):
        first = history.iloc[0]
        ax.plot(history["time_s"].to_numpy() * scale, history["size"].to_numpy(), marker=".", ms=3, lw=1,
                label=f"track {track} ({first['origin']} → {first['end']})")
    if len(histories):
        ax.legend(ncol=2, **_BELOW)  # below the panel: never over the tracks
    ax.set_yscale("log")
    ax.yaxis.set_minor_locator(LogLocator(subs=(2.0, 5.0)))
    for axis_formatter in (ax.yaxis.set_major_formatter, ax.yaxis.set_minor_formatter):
        axis_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    ax.set_xlabel("revolutions t·Ω/2π" if per_rev else "time [s]")
    ax.set_ylabel(SIZE_LABELS[histories.attrs["size_unit"]])


def _draw_kernel(fig, ax, kernel):
    """The coalescence kernel as a heatmap of log10 β (cells with events only), the number of
    events annotated in every cell."""
    from granalytics.analysis.tracking import kernel_matrix

    counts = kernel_matrix(kernel, "n_events")
    beta = kernel_matrix(kernel, "beta_per_s")
    grid = np.log10(beta.where((counts > 0) & np.isfinite(beta) & (beta > 0))).to_numpy()
    mesh = ax.imshow(grid, origin="lower", cmap="viridis", aspect="auto")
    fig.colorbar(mesh, ax=ax, label="log10 β [1/s]")
    nc = len(counts)
    for i in range(nc):
        for j in range(nc):
            dark = np.isfinite(grid[i, j]) and mesh.norm(grid[i, j]) < 0.6
            ax.text(j, i, str(int(counts.iat[i, j])), ha="center", va="center", fontsize=7, color="w" if dark else "k")
    if nc:
        ax.set_xticks(range(nc), list(counts.columns), rotation=45, fontsize=7)
        ax.set_yticks(range(nc), list(counts.index), fontsize=7)
    what = "particles" if _sizes_unit(kernel) == "particles" else "original-particle equivalents α³·n"
    ax.set_xlabel(f"size class j [{what}]")
    ax.set_ylabel(f"size class i [{what}]")
    ax.set_title("coalescence kernel (events annotated)", fontsize=10)


def growth_figure(table, fit=None, cohesion="acting"):
    """The paper's Fig 7: ⟨V_g⟩/V_p against γ of the original system, one curve per Ω (error
    bars: block s.e.m.; band: the replica standard error where there are replicas), the fitted law
    and the paper's β = 70, γ₁ = 0.027 N/m for reference.

    The points are :func:`~granalytics.growth_points` of the table: rows of one (Ω, γ) (e.g.
    several seeds) averaged, the replicas' spread as the band; rows that
    ``study_table(replicas=...)`` already combined bring their replica s.e.; points without
    granules are drawn at 0 with open markers.

    Parameters
    ----------
    table : DataFrame
        :func:`study_table` output.
    fit : GrowthFit, optional
        Default: :func:`~granalytics.analysis.study.fit_growth_of_table` of the table's rows (no
        fitted line if that fails).
    cohesion : str, default "acting"
        Convention whose rows are drawn (named in the title).

    Returns
    -------
    matplotlib Figure
    """
    import matplotlib.pyplot as plt

    from granalytics.analysis.study import fit_growth_of_table, growth_points, select_cohesion
    from granalytics.base.errors import ParameterError

    points = growth_points(table, cohesion)
    if fit is None:
        try:
            fit = fit_growth_of_table(table, cohesion)
        except ParameterError:
            fit = None
    fig, ax = plt.subplots(figsize=(6.4, 4.4), layout="constrained")
    _draw_growth_points(ax, points)
    _draw_growth_laws(ax, fit, float(points["gamma"].min()), float(points["gamma"].max()))
    ax.set_xlabel("γ of the original system [N/m] (paper Fig 7 convention)")
    ax.set_ylabel("⟨V_g⟩ / V_p")
    part = select_cohesion(table, cohesion)
    alphas = sorted(part["alpha"].dropna().unique()) if "alpha" in part else []
    cg = f", CG{'/'.join(f'{a:g}' for a in alphas)}" if alphas else ""
    ax.set_title(f"Mean granule volume in steady state vs surface tension{cg}\ncohesion convention: {cohesion}",
                 fontsize=10)
    ax.legend(fontsize=8)
    return fig


def _draw_growth_points(ax, points):
    """The points of :func:`~granalytics.growth_points`, one colour per Ω: block s.e.m. as error
    bars, the replica s.e. as a band, open markers where there are no granules; a legend key of
    the errors."""
    drew_band = False
    for k, (omega, agg) in enumerate(points.groupby("omega", sort=True)):
        colour = f"C{k}"
        gamma, v, rsem = agg["gamma"], agg["mean_volume_norm"], agg["replica_sem"]
        ax.errorbar(gamma, v, yerr=agg["block_sem"], color=colour, marker="o", ms=5, lw=1, capsize=3,
                    label=f"Ω = {omega:g} rad/s")
        band = rsem.notna()
        if band.any():
            ax.fill_between(gamma[band], (v - rsem)[band], (v + rsem)[band], color=colour, alpha=0.2, lw=0)
            drew_band = True
        none = agg["no_granules"]
        if none.any():
            ax.plot(gamma[none], v[none], ls="none", marker="o", ms=5, mfc="white", color=colour)
    if drew_band:
        ax.fill_between([], [], [], color="0.6", alpha=0.3, lw=0, label="band: replica s.e.; bars: block s.e.m.")
    else:
        ax.errorbar([], [], yerr=[], color="0.4", marker="o", ms=5, lw=1, capsize=3, label="bars: block s.e.m.")


def _draw_growth_laws(ax, fit, gmin, gmax):
    """The fitted law where the data show growth (else the reason in the legend) and the paper's,
    over γ from below the paper's onset to ``gmax`` [N/m]."""
    from granalytics.analysis.study import PAPER_BETA, PAPER_GAMMA_1, paper_growth_law

    grid = np.linspace(min(gmin, PAPER_GAMMA_1 * 0.5), gmax, 200)
    if fit is not None and fit.shows_growth:
        ax.plot(grid, fit.predict(grid), color="k", lw=1.5,
                label=f"fit: β = {fit.beta:.3g} [{fit.beta_ci[0]:.3g}, {fit.beta_ci[1]:.3g}], "
                      f"γ₁ = {fit.gamma_1:.3g} [{fit.gamma_1_ci[0]:.3g}, {fit.gamma_1_ci[1]:.3g}] N/m")
    elif fit is not None:  # the data show no growth: no law is drawn (GrowthFit.shows_growth)
        ax.plot([], [], ls="none", label=f"no growth law: {fit.no_growth_reason()}")
    ax.plot(grid, paper_growth_law(grid), color="0.5", ls="--", lw=1,
            label=f"paper: β ≈ {PAPER_BETA:g}, γ₁ ≈ {PAPER_GAMMA_1:g} N/m")


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
                shown = f"{grid[i, j]:+.0f}" + (f"\n±{error[i, j]:.0f}" if np.isfinite(error[i, j]) else "")
                ax.text(j + 0.5, i + 0.5, shown, ha="center", va="center", fontsize=6, color="w" if dark else "k")
    ax.set_xticks(np.arange(c.size) + 0.5, [f"{x:.3g}" for x in c], fontsize=7)
    ax.set_yticks(np.arange(a.size) + 0.5, [f"{x:g}" for x in a], fontsize=7)
    ax.set_xlabel("C_agg")
    ax.set_ylabel("A_agg [deg]")
    return mesh


def pbm_figure(prediction, times=None, title=None):
    """A population-balance prediction against its DEM (:class:`~granalytics.PBMPrediction`): the
    DEM as points, the PBM as lines; mean granule size and yield over the prediction window
    (:meth:`~granalytics.PBMPrediction.summary`), and the cumulative number distribution of
    granules at ``times`` [revolutions] (default the middle and the last frame;
    :meth:`~granalytics.PBMPrediction.cumulative_fractions`). Returns a matplotlib Figure; the
    backend is not changed."""
    from matplotlib.figure import Figure

    table = prediction.summary()
    if times is None:
        times = (prediction.revolutions[len(prediction.revolutions) // 2], prediction.revolutions[-1])
    fig = Figure(figsize=(13, 4), layout="constrained")
    ax = fig.subplots(1, 3)
    for a, col, label in ((ax[0], "mean_size", "mean granule size [particles]"),
                          (ax[1], "yield_fraction", "yield (fraction of particles in granules)")):
        a.plot(table["revolution"], table["dem_" + col], "o", ms=3, label="DEM")
        a.plot(table["revolution"], table["pbm_" + col], "-", label="PBM")
        a.set_xlabel("revolutions")
        a.set_ylabel(label)
        a.legend()
    for k, rev in enumerate(times):
        cumulative = prediction.cumulative_fractions(rev)
        for source, style, what in (("dem", "o", "DEM"), ("pbm", "-", "PBM")):
            part = cumulative[cumulative["source"] == source]
            ax[2].plot(part["size"].to_numpy(), part["fraction"].to_numpy(), style, color=f"C{k}", ms=3,
                       label=f"{what}, rev {part['revolution'].iloc[0]:.2f}")
    ax[2].set_xscale("log")
    ax[2].set_xlabel("granule size [particles]")
    ax[2].set_ylabel("cumulative number fraction of granules")
    ax[2].legend(fontsize=8)
    fig.suptitle(title or f"{prediction.run}: rates on revolutions {prediction.fit_window[0]:g}–{prediction.fit_window[1]:g}, "
                          f"prediction from {prediction.revolutions[0]:.2f}")
    return fig


def calibration_figures(calibration) -> dict:
    """The two figures of a threshold calibration (:func:`granalytics.calibrate_thresholds`).

    Returns
    -------
    dict
        ``"calibration_objective"``: χ² over the grid (log colour scale) with the best point, the
        bootstrap confidence region (outlined cells) and the Δχ² region (dots);
        ``"calibration_distributions"``: the measured and best-fit simulated distributions,
        cumulative mass fraction passing against aperture and mass fraction per class, with errors
        (measured σ; simulated block-bootstrap s.e.).
    """
    s = calibration.settings
    caption = (f"{', '.join(os.path.basename(str(r)) for r in s['runs'])}; window [{s['window_rev'][0]:g}, "
               f"{s['window_rev'][1]:g}] rev; size = {'volume-equivalent diameter' if s['measure'] == 'volume' else 'second principal extent'}; "
               f"cohesion={s['cohesion']}")
    return {"calibration_objective": _calibration_objective_figure(calibration, caption),
            "calibration_distributions": _calibration_distributions_figure(calibration, caption)}


def _threshold_names(calibration):
    """The calibration's co-motion threshold: (axis label, short name)."""
    if calibration.threshold_column == "a_agg_deg":
        return "A_agg [deg]", "A_agg"
    return "rigid tolerance", "rigid_tol"


def _calibration_objective_figure(cal, caption):
    """χ² over the threshold grid with the best point and the two confidence regions."""
    import matplotlib.pyplot as plt
    from matplotlib.colors import LogNorm
    from matplotlib.patches import Rectangle

    col = cal.threshold_column
    name, short = _threshold_names(cal)
    grid, s = cal.grid, cal.settings
    c_vals, a_vals = np.unique(grid.c_agg), np.unique(grid[col])
    table = grid.pivot(index=col, columns="c_agg", values="chi2").reindex(index=a_vals, columns=c_vals)
    fig, ax = plt.subplots(figsize=(6.4, 4.8))
    values = np.clip(table.to_numpy(), max(1e-3, np.nanmin(table.to_numpy()[table.to_numpy() > 0], initial=1.0) / 2), None)
    c_edges, a_edges = _edges(c_vals), _edges(a_vals)
    mesh = ax.pcolormesh(c_edges, a_edges, values, norm=LogNorm(), cmap="viridis_r", shading="flat")
    fig.colorbar(mesh, ax=ax, label="χ² (cumulative passing, weighted by errors)")
    cw, aw = np.diff(c_edges), np.diff(a_edges)
    for _, row in grid[grid.in_region].iterrows():
        i, j = np.searchsorted(c_vals, row.c_agg), np.searchsorted(a_vals, row[col])
        ax.add_patch(Rectangle((c_edges[i], a_edges[j]), cw[i], aw[j], fill=False, ec="white", lw=1.5))
    chi = grid[grid.in_chi2_region]
    ax.plot(chi.c_agg, chi[col], ".", color="orange", ms=4,
            label=f"Δχ² region ({100 * s['level']:g} %, Gaussian approximation; for comparison only)")
    ax.plot([cal.best["c_agg"]], [cal.best[col]], "*", color="red", ms=14, mec="white",
            label=f"best: C_agg = {cal.best['c_agg']:g}, {short} = {cal.best[col]:g}")
    ax.plot([], [], "s", mfc="none", mec="grey",
            label=f"confidence region ({100 * s['level']:g} %, bootstrap): the one the summary reports")
    ax.set_xlabel("C_agg")
    ax.set_ylabel(name)
    ax.legend(loc="lower right", fontsize=7, framealpha=0.8)
    title = f"calibration against {os.path.basename(str(s['measured']))}"
    if cal.poor_fit:
        title += "\nPOOR FIT: no grid point reproduces it"
    ax.set_title(title, fontsize=10)
    fig.text(0.01, 0.005, caption + f"\nC_agg: {cal.constraint['c_agg']}; {short}: {cal.constraint[col]}",
             fontsize=7, va="bottom")
    fig.subplots_adjust(bottom=0.2)
    return fig


def _calibration_distributions_figure(cal, caption):
    """The measured and the best pair's simulated distributions: cumulative mass fraction passing
    against aperture, and mass fraction per sieve class, with their errors."""
    import matplotlib.pyplot as plt

    _, short = _threshold_names(cal)
    d = cal.distributions
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 4.2))
    upper_mm = d.upper_m.to_numpy() * 1e3
    finite = np.isfinite(upper_mm)
    ax1.errorbar(upper_mm[finite], d.measured_passing[finite], yerr=d.measured_sigma[finite], fmt="o", color="k",
                 capsize=3, label="measured (σ)")
    ax1.errorbar(upper_mm[finite], d.simulated_passing[finite], yerr=d.simulated_passing_error[finite].fillna(0),
                 fmt="s-", color="tab:blue", ms=4, capsize=3, label="simulated, best pair (bootstrap s.e.)")
    ax1.set_xscale("log")
    ax1.set_xticks(upper_mm[finite])  # the apertures themselves: a decade's ticks would be 10⁰ and 10¹ only
    ax1.set_xticklabels([f"{a:.3g}" for a in upper_mm[finite]], rotation=45, ha="right", fontsize=7)
    ax1.minorticks_off()
    ax1.set_xlabel("aperture [mm] (original-system sizes)")
    ax1.set_ylabel("cumulative mass fraction passing")
    ax1.set_ylim(-0.02, 1.02)
    ax1.legend(fontsize=8)
    k = np.arange(len(d))
    labels = [f"{lo * 1e3:.3g}–{hi * 1e3:.3g}" if math.isfinite(hi) else f"≥ {lo * 1e3:.3g}"
              for lo, hi in zip(d.lower_m, d.upper_m)]
    ax2.bar(k - 0.2, d.measured_fraction, width=0.4, color="0.6", label="measured")
    ax2.bar(k + 0.2, d.simulated_fraction, width=0.4, yerr=d.simulated_fraction_error, color="tab:blue", capsize=2,
            label="simulated, best pair")
    ax2.set_xticks(k)
    ax2.set_xticklabels(labels, rotation=45, ha="right", fontsize=7)
    ax2.set_xlabel("sieve class [mm]")
    ax2.set_ylabel("mass fraction per class")
    ax2.legend(fontsize=8)
    fig.suptitle(f"best pair C_agg = {cal.best['c_agg']:g}, {short} = {cal.best[cal.threshold_column]:g}: χ² = "
                 f"{cal.chi2_min:.3g} on {cal.dof} degrees of freedom (p = {cal.p_value:.2g})", fontsize=10)
    fig.text(0.01, 0.005, caption, fontsize=7, va="bottom")
    fig.tight_layout(rect=(0, 0.04, 1, 1))
    return fig
