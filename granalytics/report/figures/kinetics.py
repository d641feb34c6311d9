"""The figures of granule kinetics: the tracks' event rates, size histories and kernel
(:func:`granalytics.track_granules`), and a population-balance prediction (:func:`granalytics.population_balance`)."""

from __future__ import annotations

import typing

import numpy as np
import pandas as pd

from granalytics.report.figures._axes import SIZE_LABELS, sizes_unit

if typing.TYPE_CHECKING:
    from granalytics.analysis.tracking import GranuleTracks

__all__ = ["tracking_figure", "pbm_figure"]


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

    unit = sizes_unit(kernel, size_unit)
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
    what = "particles" if sizes_unit(kernel) == "particles" else "original-particle equivalents α³·n"
    ax.set_xlabel(f"size class j [{what}]")
    ax.set_ylabel(f"size class i [{what}]")
    ax.set_title("coalescence kernel (events annotated)", fontsize=10)


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
