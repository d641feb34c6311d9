"""Rates from tracked granules: event rates per revolution or per second (:func:`event_rates`,
with Poisson errors :func:`rate_errors`), the empirical coalescence kernel β(i, j) on logarithmic
size classes (:func:`coalescence_kernel`, as a class × class matrix :func:`kernel_matrix`) and
the selection (breakage) rate S(i) (:func:`breakage_rate`), the two rate functions of a
population balance.

Units: SI, time in seconds (``_s`` suffix); granule sizes in particles, or with
``size_unit="original"`` in original-particle equivalents α³·n (the unit in which runs at
different CG factors are compared).
"""

from __future__ import annotations

import math
import warnings
from itertools import combinations
from numbers import Real

import numpy as np
import pandas as pd

from granalytics.analysis.stats import SIZE_UNITS, size_unit_factor
from granalytics.analysis.tracking.tracks import GranuleTracks, KINDS, TRACKS
from granalytics.core.windows import window_tolerance
from granalytics.base.errors import ParameterError, user_stacklevel
from granalytics.base.validation import POSITIVE, Array, Instance, Interval, Options, validate_params

#: the constraints of the rates by size class: class edges, whole numbers >= 1
_CLASS_CONSTRAINTS = {"tracks": [TRACKS], "size_bins": [Array(ndim=1, within=Interval(Real, 1, None)), None],
                      "bins_per_decade": [POSITIVE], "size_unit": [Options(SIZE_UNITS)]}


def _steps(tracks):
    t = np.asarray(tracks.times_s, dtype=float)
    if t.size < 2:
        raise ParameterError("rates need at least two tracked frames (one frame interval)")
    return t, np.diff(t)


@validate_params({"tracks": [TRACKS], "revolution_period_s": [POSITIVE, None], "bin_width": [POSITIVE, None]})
def event_rates(tracks: GranuleTracks, revolution_period_s=None, *, bin_width=None) -> pd.DataFrame:
    """Event counts and rates per kind, binned in time.

    Each step k → k+1 (its events and its duration t_{k+1} − t_k) is assigned to the bin that
    holds the step's midpoint.

    Parameters
    ----------
    tracks : GranuleTracks
    revolution_period_s : float, optional
        Drum revolution period 2π/Ω [s]. Given: bins in revolutions and rates also per
        revolution. Not given: bins in seconds, rates per second only.
    bin_width : float, optional
        Bin width in revolutions (with a period; default 1) or in seconds (without; default a
        tenth of the tracked time span).

    Warns
    -----
    UserWarning
        When the frame intervals differ by more than 1.5× (rates of bins with other spacings
        are not comparable: events between frames further apart go uncounted).

    Returns
    -------
    DataFrame
        One row per (bin, kind), kinds in the order birth, death, coalescence, breakage.
        Columns ``bin``; ``rev_start``, ``rev_end`` (bin edges in revolutions, NaN without a
        period); ``time_start_s``, ``time_end_s`` [s]; ``observed_s`` (tracked time inside the
        bin [s]); ``kind``; ``count`` (events); ``rate_per_s`` (count / observed_s [1/s]);
        ``rate_per_rev`` (events per revolution, NaN without a period). Rates are NaN in a bin
        with no tracked time.
    """
    t, dt = _steps(tracks)
    if dt.max() > 1.5 * dt.min():
        warnings.warn(f"the tracked frames are {dt.min():.3g}–{dt.max():.3g} s apart (a run thinned outside a "
                      "window?): events between frames further apart go uncounted, so rates of bins with other "
                      "frame spacings are not comparable; track the evenly spaced part (window=, --window-rev)", stacklevel=user_stacklevel())
    if revolution_period_s is not None:
        period = float(revolution_period_s)
        x = t / period
        width = 1.0 if bin_width is None else float(bin_width)
    else:
        period = None
        x = t
        width = (t[-1] - t[0]) / 10 if bin_width is None else float(bin_width)
    # bin edges with the windows' tolerance: a first frame stamped 2.9999 revolutions opens the bin
    # [3, 4), not an empty [2, 3) (frames lie on whole time steps; granalytics.core.windows)
    tol = window_tolerance(x)
    start = math.floor((x[0] + tol) / width) * width
    n_bins = max(1, math.ceil((x[-1] - tol - start) / width - 1e-9))
    edges = start + width * np.arange(n_bins + 1)
    mid = (x[:-1] + x[1:]) / 2
    step_bin = np.clip(np.floor((mid - start) / width).astype(np.int64), 0, n_bins - 1)
    observed = np.bincount(step_bin, weights=dt, minlength=n_bins)
    ev = tracks.events
    kind_code = pd.Categorical(ev["kind"], categories=list(KINDS)).codes.astype(np.int64)
    ev_bin = step_bin[ev["frame"].to_numpy(dtype=np.int64) - 1]
    counts = np.bincount(ev_bin * len(KINDS) + kind_code, minlength=n_bins * len(KINDS)).reshape(n_bins, len(KINDS))
    with np.errstate(divide="ignore", invalid="ignore"):
        per_s = np.where(observed[:, None] > 0, counts / observed[:, None], np.nan)
    bins = np.repeat(np.arange(n_bins), len(KINDS))
    lo, hi = edges[:-1][bins], edges[1:][bins]
    table = pd.DataFrame({
        "bin": bins,
        "rev_start": lo if period else np.nan,
        "rev_end": hi if period else np.nan,
        "time_start_s": lo * period if period else lo,
        "time_end_s": hi * period if period else hi,
        "observed_s": observed[bins],
        "kind": pd.Categorical.from_codes(np.tile(np.arange(len(KINDS)), n_bins), categories=list(KINDS)),
        "count": counts.reshape(-1),
        "rate_per_s": per_s.reshape(-1),
        "rate_per_rev": per_s.reshape(-1) * period if period else np.nan,
    })
    return table


@validate_params({"rates": [Instance(pd.DataFrame, "an event_rates table")], "column": [Options(("rate_per_rev", "rate_per_s"))]})
def rate_errors(rates, column="rate_per_rev") -> pd.Series:
    """Poisson standard errors of the rates of :func:`event_rates`: a bin's rate times
    1/√count (± √count events over the bin's tracked time); 0 where the bin has no event or no
    tracked time.

    Parameters
    ----------
    rates : DataFrame
        :func:`event_rates` output.
    column : {"rate_per_rev", "rate_per_s"}, default "rate_per_rev"
        The rate whose errors are returned (in its unit: per revolution, or per second [1/s]).

    Returns
    -------
    Series
        Indexed as ``rates``.
    """
    count = rates["count"]
    return np.sqrt(count.to_numpy(dtype=float)) * (rates[column] / count.where(count > 0)).fillna(0)


def _size_classes(tracks, size_bins, bins_per_decade):
    """Integer class edges (lower inclusive, upper exclusive) and a classifier."""
    if size_bins is not None:
        edges = np.asarray(size_bins)
        if edges.size < 2 or (edges != np.round(edges)).any() or (np.diff(edges) <= 0).any():
            raise ParameterError(f"size_bins must be at least two increasing whole numbers, got {edges.tolist()}")
        edges = edges.astype(np.int64)
    else:
        all_sizes = np.concatenate([s[s > 0] for s in tracks.sizes_by_frame] + [np.zeros(0, np.int64)])
        lo = int(all_sizes.min()) if all_sizes.size else 2
        top = (int(all_sizes.max()) if all_sizes.size else lo) + 1
        n = max(1, math.ceil(bins_per_decade * math.log10(top / lo)))
        edges = np.unique(np.ceil(np.geomspace(lo, top, n + 1)).astype(np.int64))
        edges[0], edges[-1] = lo, max(edges[-1], top)

    def classify(sizes):
        sizes = np.asarray(sizes, dtype=np.int64)
        c = np.searchsorted(edges, sizes, side="right") - 1
        return np.where((c >= 0) & (c < edges.size - 1), c, -1)

    return edges, classify


def _mean_numbers(tracks, classify, n_classes, dt):
    """Time-averaged number of granules per class over the frames that start a step [granules]."""
    total = np.zeros(n_classes)
    for sizes, w in zip(tracks.sizes_by_frame[:-1], dt):
        c = classify(sizes[sizes > 0])
        total += w * np.bincount(c[c >= 0], minlength=n_classes)
    return total / dt.sum()


def _in_unit(table, columns, size_unit, alpha, caller):
    """``columns`` of a class table converted from the run's particles to ``size_unit``; the unit
    and the CG factor recorded in ``attrs``."""
    factor = size_unit_factor(size_unit, alpha, caller=caller)
    if size_unit == "original":
        for column in columns:
            table[column] = table[column] * factor
    table.attrs.update(size_unit=size_unit, alpha=None if size_unit == "particles" else round(factor ** (1 / 3), 12))
    return table


@validate_params(_CLASS_CONSTRAINTS)
def coalescence_kernel(tracks: GranuleTracks, size_bins=None, *, bins_per_decade=4, size_unit="particles",
                       alpha=None) -> pd.DataFrame:
    """Empirical coalescence kernel β(i, j) on logarithmic size classes.

    β(i, j) = r(i, j) / (N_i·N_j) for i ≠ j and r(i, i) / (N_i²/2) for i = j, where r(i, j) is
    the rate of binary coalescences between a granule of class i and one of class j [1/s] and
    N_i the time-averaged number of granules of class i (the number of distinct pairs is
    N_i·N_j, or N_i²/2 within a class, as in the Smoluchowski equation dN/dt = ½ΣβN_iN_j − …).

    Parent sizes are taken at the frame before the event. A coalescence of p parents counts as
    p − 1 binary coalescences, shared equally among its p(p−1)/2 parent pairs (weight 2/p each).
    N_i is averaged over the frames that start a step, weighted by the step's duration, from
    :attr:`GranuleTracks.sizes_by_frame` (the same numbers as the tracks' size histories); the
    rate divides by the tracked time t_K − t_0.

    Parameters
    ----------
    tracks : GranuleTracks
    size_bins : int array, optional
        Class edges in particles per granule, increasing; class i holds sizes
        ``size_bins[i] <= s < size_bins[i+1]``; sizes outside are ignored. Default: logarithmic
        classes of integers from the smallest to the largest tracked granule.
    bins_per_decade : float, default 4
        Classes per decade of size, for the default classes.
    size_unit : {"particles", "original"}, default "particles"
        Unit of the returned class bounds: the run's particles, or original-particle equivalents
        α³·n (``size_min_i`` … are then α³ times the others). The classes themselves, and
        ``size_bins``, are in the run's particles either way; β is per pair of granules in both.
    alpha : float, or a run or its metadata
        The CG factor (its ``alpha``), for ``size_unit="original"``.

    Returns
    -------
    DataFrame
        One row per unordered pair of classes i <= j (empty cells included). Columns
        ``class_i``, ``class_j``; ``size_min_i``, ``size_max_i``, ``size_min_j``,
        ``size_max_j`` (inclusive bounds [particles, or α³·n in ``"original"``]); ``n_events`` (coalescence events with a
        parent pair in the cell); ``n_pairs`` (parent pairs in the cell); ``n_binary`` (weighted
        binary coalescences); ``rate_per_s`` (n_binary / tracked time [1/s]); ``n_mean_i``,
        ``n_mean_j`` (time-averaged granule numbers); ``beta_per_s`` (β [1/s per pair of
        granules]; NaN where a class is never populated). Read β only where ``n_events`` is
        large enough: a cell with a handful of events is noise.
    """
    t, dt = _steps(tracks)
    edges, classify = _size_classes(tracks, size_bins, bins_per_decade)
    nc = edges.size - 1
    n_mean = _mean_numbers(tracks, classify, nc, dt)
    n_events = np.zeros((nc, nc))
    n_pairs = np.zeros((nc, nc))
    weight = np.zeros((nc, nc))
    coal = tracks.events.loc[tracks.events["kind"] == "coalescence", "parent_sizes"]
    for parent_sizes in coal:  # one iteration per coalescence event
        cls = classify(parent_sizes).tolist()
        p = len(cls)
        touched = set()
        for ci, cj in combinations(cls, 2):
            if ci < 0 or cj < 0:
                continue
            ci, cj = min(ci, cj), max(ci, cj)
            n_pairs[ci, cj] += 1
            weight[ci, cj] += 2.0 / p
            touched.add((ci, cj))
        for cell in touched:
            n_events[cell] += 1
    iu, ju = np.triu_indices(nc)
    rate = weight[iu, ju] / dt.sum()
    pairs = np.where(iu == ju, n_mean[iu] ** 2 / 2, n_mean[iu] * n_mean[ju])
    with np.errstate(divide="ignore", invalid="ignore"):
        beta = np.where(pairs > 0, rate / pairs, np.nan)
    table = pd.DataFrame({
        "class_i": iu, "class_j": ju,
        "size_min_i": edges[iu], "size_max_i": edges[iu + 1] - 1,
        "size_min_j": edges[ju], "size_max_j": edges[ju + 1] - 1,
        "n_events": n_events[iu, ju].astype(np.int64),
        "n_pairs": n_pairs[iu, ju].astype(np.int64),
        "n_binary": weight[iu, ju],
        "rate_per_s": rate,
        "n_mean_i": n_mean[iu], "n_mean_j": n_mean[ju],
        "beta_per_s": beta,
    })
    return _in_unit(table, ("size_min_i", "size_max_i", "size_min_j", "size_max_j"), size_unit, alpha,
                    "coalescence_kernel")


@validate_params({"kernel": [Instance(pd.DataFrame, "a coalescence_kernel table")], "column": [Instance(str, "a column name")]})
def kernel_matrix(kernel, column="beta_per_s") -> pd.DataFrame:
    """One column of a :func:`coalescence_kernel` table as a symmetric class × class matrix.

    Parameters
    ----------
    kernel : DataFrame
        :func:`coalescence_kernel` output (every pair of classes i <= j).
    column : str, default "beta_per_s"
        The column, e.g. ``"beta_per_s"`` or ``"n_events"``.

    Returns
    -------
    DataFrame
        Rows i and columns j, both labelled by the class bounds in the kernel's unit (``"5"`` for
        a class of one size, ``"6–10"``); the entry of (i, j) and of (j, i) is the pair's value.
    """
    if column not in kernel:
        raise ParameterError(f"kernel_matrix: column must be a column of the kernel "
                             f"({', '.join(map(str, kernel.columns))}), got {column!r}")
    nc = int(max(kernel["class_i"].max(), kernel["class_j"].max())) + 1 if len(kernel) else 0
    values = np.full((nc, nc), np.nan)
    i, j = kernel["class_i"].to_numpy(dtype=np.int64), kernel["class_j"].to_numpy(dtype=np.int64)
    values[i, j] = values[j, i] = kernel[column].to_numpy(dtype=float)
    bounds = kernel.drop_duplicates("class_i").sort_values("class_i")
    names = [f"{lo:g}" if lo == hi else f"{lo:g}–{hi:g}" for lo, hi in zip(bounds["size_min_i"], bounds["size_max_i"])]
    return pd.DataFrame(values, index=names, columns=names)


@validate_params(_CLASS_CONSTRAINTS)
def breakage_rate(tracks: GranuleTracks, size_bins=None, *, bins_per_decade=4, size_unit="particles",
                  alpha=None) -> pd.DataFrame:
    """Empirical selection (breakage) rate S(i) on logarithmic size classes.

    S(i) = (breakage events of granules of class i per unit time) / N_i, with the size of the
    breaking granule at the frame before the event and N_i the time-averaged number of granules
    of class i (as in :func:`coalescence_kernel`).

    Parameters
    ----------
    tracks : GranuleTracks
    size_bins : int array, optional
        Class edges in particles per granule (see :func:`coalescence_kernel`).
    bins_per_decade : float, default 4
    size_unit, alpha
        As in :func:`coalescence_kernel`: ``size_min``, ``size_max`` in original-particle
        equivalents α³·n with ``size_unit="original"``.

    Returns
    -------
    DataFrame
        One row per class: ``class``, ``size_min``, ``size_max`` (inclusive [particles]),
        ``n_events`` (breakages), ``fragments_mean`` (mean number of fragments, NaN without
        events), ``rate_per_s`` (n_events / tracked time [1/s]), ``n_mean`` (time-averaged
        number of granules), ``selection_rate_per_s`` (S(i) [1/s]; NaN where N_i = 0).
    """
    t, dt = _steps(tracks)
    edges, classify = _size_classes(tracks, size_bins, bins_per_decade)
    nc = edges.size - 1
    n_mean = _mean_numbers(tracks, classify, nc, dt)
    br = tracks.events[tracks.events["kind"] == "breakage"]
    c = classify(br["n_particles"].to_numpy(dtype=np.int64))
    n_children = np.fromiter((len(x) for x in br["children"]), dtype=np.int64, count=len(br))
    ok = c >= 0
    n_events = np.bincount(c[ok], minlength=nc)
    fragments = np.bincount(c[ok], weights=n_children[ok], minlength=nc)
    rate = n_events / dt.sum()
    with np.errstate(divide="ignore", invalid="ignore"):
        selection = np.where(n_mean > 0, rate / n_mean, np.nan)
        fragments_mean = np.where(n_events > 0, fragments / n_events, np.nan)
    table = pd.DataFrame({
        "class": np.arange(nc),
        "size_min": edges[:-1], "size_max": edges[1:] - 1,
        "n_events": n_events.astype(np.int64),
        "fragments_mean": fragments_mean,
        "rate_per_s": rate,
        "n_mean": n_mean,
        "selection_rate_per_s": selection,
    })
    return _in_unit(table, ("size_min", "size_max"), size_unit, alpha, "breakage_rate")

