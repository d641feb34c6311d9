"""Granule statistics: per granule, per frame, per run (time series and steady state).

Normalisations follow §3.1 of the paper and are CG-aware by construction: counts are divided by
the run's own particle count and volumes by the run's own mean particle volume, so runs with
different CG factors α are directly comparable.
"""

from __future__ import annotations

import math
import warnings
from numbers import Integral, Real

import numpy as np
import pandas as pd

from granalytics.analysis.metrics import HEADLINE, STEADY, GranuleCounts, metric_values
from granalytics.core.windows import clip_window, window_mask, window_tolerance
from granalytics.base.errors import ParameterError, user_stacklevel
from granalytics.analysis.frames import map_frames
from granalytics.identification.granules import granule_table
from granalytics.identification import METHODS, make_identifier
from granalytics.identification.result import RESULT, IdentificationResult
from granalytics.core.snapshot import SNAPSHOT, Snapshot
from granalytics.base.validation import FLAG, WINDOW, Array, Instance, Interval, Options, validate_params

__all__ = [
    "granule_table", "frame_stats", "run_stats", "steady_state", "replica_steady_state", "combine_replicas",
    "size_distribution", "DEFAULT_WINDOW_REV",
]

#: Default steady-state window [revolutions] (Fig. 5 of the paper).
DEFAULT_WINDOW_REV = (3.0, 6.0)

_STEADY_COLUMNS = STEADY
#: the constraints of a steady-state window's parameters (:func:`steady_state`, :func:`replica_steady_state`)
_WINDOW_CONSTRAINTS = {
    "window": [WINDOW],
    "columns": [Instance(str, "a metric name"), Array(ndim=1, dtype=str)],
    "by": [Options(("revolutions", "time_s"))],
}


@validate_params({"snapshot": [SNAPSHOT], "result": [RESULT]})
def frame_stats(snapshot: Snapshot, result: IdentificationResult) -> pd.DataFrame:
    """Granulation metrics of one frame (one-row DataFrame).

    Parameters
    ----------
    snapshot : Snapshot
        The frame (its metadata gives γ, Ω and the run's particle count).
    result : IdentificationResult
        The granules identified in ``snapshot`` (any method).

    Returns
    -------
    DataFrame
        One row with the columns listed in the Notes.

    Notes
    -----
    The columns:

    time_s, step, revolutions
        When (revolutions = t·Ω/2π, NaN without a drum).
    n_particles, n_contacts, n_kept_contacts
        Sizes of the frame (kept = passing the method's criteria, NaN if not contact-based).
    n_granules
        Number of granules G.
    largest_granule_size
        Particles in the largest granule (0 without granules).
    mean_volume_m3
        Mean granule volume [m³] (NaN without granules).
    n_granules_norm, mean_volume_norm, yield_fraction, mean_granule_size, ...
        Every metric of the registry (:data:`granalytics.analysis.metrics.METRICS`), from the
        frame's granule counts: G divided by the run's initial particle count (``meta.n_particles``;
        the frame's count without metadata), Fig. 4 of the paper; the mean granule volume divided
        by the frame's mean particle volume, Fig. 3; the fraction of particles in granules, Fig. 6;
        the mean particles per granule (NaN without granules).
    """
    if result.labels.shape != (snapshot.n_particles,):
        raise ParameterError("result does not belong to this snapshot (label count differs)")
    other = result.snapshot
    if other is not snapshot and (other.time != snapshot.time or other.step != snapshot.step
                                  or not np.array_equal(other.ids, snapshot.ids)):
        raise ParameterError(f"frame_stats: the result was identified on another frame (t = {other.time!r} s, step "
                             f"{other.step}) than the snapshot (t = {snapshot.time!r} s, step {snapshot.step})")
    n = snapshot.n_particles
    n_initial = snapshot.meta.n_particles if snapshot.meta is not None else n
    volume = snapshot.particle_volume
    g = result.n_granules
    member = result.labels >= 0
    counts = GranuleCounts(n_granules=g, n_in_granules=int(member.sum()), granule_volume_m3=volume[member].sum(),
                           n_particles=n, n_initial=n_initial, mean_particle_volume_m3=volume.mean())
    mean_volume = counts.granule_volume_m3 / g if g else math.nan
    row = {
        "time_s": snapshot.time,
        "step": snapshot.step,
        "revolutions": snapshot.revolutions,
        "n_particles": n,
        "n_contacts": snapshot.n_contacts,
        "n_kept_contacts": int(result.kept.sum()) if result.kept is not None else math.nan,
        "n_granules": g,
        "largest_granule_size": int(result.sizes[0]) if g else 0,
        "mean_volume_m3": mean_volume,
        **metric_values(counts),  # every registered metric (granalytics.analysis.metrics)
    }
    return pd.DataFrame([row])


@validate_params({"method": [Options(METHODS)], "progress": [FLAG], "return_sizes": [FLAG]})
def run_stats(frames, method="gna", *, progress=False, return_sizes=False, jobs=1, scheduler=None, **params):
    """Time series of :func:`frame_stats` over the frames of a run.

    Parameters
    ----------
    frames : Run, RunSlice or sequence of Snapshot
        For example ``open_run(path)`` or ``run.select(revolutions=(3, 6))``.
    method : str, default "gna"
        Identification method; ``params`` go to its constructor (e.g. ``c_agg``, ``a_agg_deg``).
    progress : bool, default False
        Show a progress bar over frames.
    return_sizes : bool, default False
        Also return the granule sizes (particles per granule) of every frame.
    jobs, scheduler :
        Where the frames are analysed: ``jobs`` threads here, or a dask cluster (a scheduler's
        address or a ``distributed.Client``); see :func:`granalytics.analysis.frames.map_frames`.

    Returns
    -------
    DataFrame
        One row per frame (columns of :func:`frame_stats`, plus ``frame``: the frame's index in
        the run file (in the list for a plain sequence), ``method`` and ``cohesion``: the
        cohesion convention, None for methods without one); and, with ``return_sizes``, a list of int arrays, one per frame.
    """
    identifier = make_identifier(method, **params)

    def one_frame(snapshot):
        result = identifier.identify(snapshot)
        return frame_stats(snapshot, result), result.sizes

    frame_ids, results = map_frames(frames, one_frame, progress=progress, desc="stats", jobs=jobs,
                                    scheduler=scheduler)
    rows = [row for row, _ in results]
    sizes = [s for _, s in results]
    for k, row in zip(frame_ids, rows):
        row.insert(0, "frame", int(k))
    table = pd.concat(rows, ignore_index=True)
    table["method"] = method
    table["cohesion"] = getattr(identifier, "cohesion", None)
    return (table, sizes) if return_sizes else table


def check_window(axis, window, *, by="revolutions", source=None, warn=True):
    """The frames of a steady-state window: ``(mask, tolerance)`` over the frame times ``axis``
    (revolutions, or seconds with ``by="time_s"``), with the edge tolerance of
    :func:`granalytics.core.windows.window_tolerance`.

    Raises
    ------
    ParameterError
        No frames or no finite values on the axis (a revolution axis of a run
        without drum rotation), or no frame in the window; errors name ``source``.

    Warns
    -----
    UserWarning
        With ``warn``: the run does not reach an edge of the window, or the window holds a
        single frame.
    """
    lo, hi = (float(w) for w in window)
    unit = "revolutions" if by == "revolutions" else "s"
    where = f"{source}: " if source else ""
    axis = np.asarray(axis, dtype=float)
    if not np.isfinite(axis).any():
        if axis.size and by == "revolutions":
            raise ParameterError(f"{where}the run has no drum rotation (Ω = 0): revolution windows are undefined; "
                                 "use a time window (by='time_s'; `granalytics stats --window-time T0:T1` in seconds)")
        raise ParameterError(f"{where}no frames with a finite {by} to take a window of")
    tol = window_tolerance(axis)
    mask = window_mask(axis, lo, hi, tol)
    first, last = np.nanmin(axis), np.nanmax(axis)
    covered = f"the run covers [{first:.3g}, {last:.3g}]"
    n = int(mask.sum())
    if n == 0:
        other = "--window-time T0:T1 in seconds" if by == "revolutions" else "--window R0:R1 in revolutions"
        raise ParameterError(f"{where}no frame in the window [{lo:g}, {hi:g}] {unit}; {covered} {unit}: give a window "
                             f"inside it (or {other})")
    if warn and (hi > last + tol or lo < first - tol):
        used = clip_window(axis, lo, hi, tol)
        past = "runs past the run's end" if lo >= first - tol else (
            "starts before the run" if hi <= last + tol else "is wider than the run")
        warnings.warn(f"{where}the window [{lo:g}, {hi:g}] {unit} {past} ({covered}): clipped to "
                      f"[{used[0]:.4g}, {used[1]:.4g}], {n} frame{'s' if n > 1 else ''}", stacklevel=user_stacklevel())
    elif warn and n == 1:
        warnings.warn(f"{where}the window [{lo:g}, {hi:g}] {unit} holds a single frame: its steady state has "
                      "no spread", stacklevel=user_stacklevel())
    span = float(np.nanmax(axis[mask]) - np.nanmin(axis[mask]))
    if warn and by == "revolutions" and n > 1 and span < 1 - tol:
        warnings.warn(f"{where}the window's frames span {span:.3g} revolutions, less than one turn of the drum: the "
                      "bed's cycle is not averaged over, so their mean is not a steady state", stacklevel=user_stacklevel())
    return mask, tol


@validate_params({"timeseries": [Instance(pd.DataFrame, "a DataFrame (run_stats' result)"), Instance((list, tuple), "a list of them (replicas)")],
                  **_WINDOW_CONSTRAINTS, "n_blocks": [Interval(Integral, 1, None), None]})
def steady_state(timeseries: pd.DataFrame, window=DEFAULT_WINDOW_REV, columns=_STEADY_COLUMNS, *,
                 by="revolutions", n_blocks=None, source=None) -> pd.DataFrame:
    """Steady-state averages over a window of revolutions (default) or of time.

    Parameters
    ----------
    timeseries : DataFrame, or list of DataFrame
        Output of :func:`run_stats` (needs the ``by`` column). A list (of at least two) is a
        set of replicas (runs of one system at other seeds): the result is then
        :func:`replica_steady_state`'s (mean over the replicas, ``replica_sem`` beside
        ``block_sem``).
    window : (float, float), default (3, 6)
        Closed interval, in revolutions, or in seconds with ``by="time_s"``; a frame within a
        tenth of the smallest frame spacing of an edge counts as inside (frames lie on whole time steps, so the
        frame of revolution 6 may be stamped 5.9999). A window that the run does not cover is
        clipped to the run's frames, with a warning (``(3, 9)`` on a run that ends at revolution 6
        gives the numbers of ``(3, 6)``); one that holds a single frame gives a warning.
    columns : sequence of str
        Metrics to average.
    by : {"revolutions", "time_s"}, default "revolutions"
        ``"time_s"`` for runs without drum rotation (static beds, hoppers).
    n_blocks : int, optional
        Equal blocks for the standard error (of one time series, not of replicas). Default for
        revolution windows: blocking (:func:`blocking_sem`): blocks of a quarter revolution (one baffle passage of the
        four-baffle drum), merged pairwise level after level, the largest error over the levels
        with at least 4 blocks, so that it covers frames correlated over several passages; 5
        equal blocks for ``by="time_s"``.
    source : str, optional
        What the time series is of (e.g. the run file), named in errors and warnings.

    Returns
    -------
    DataFrame indexed by metric with columns ``mean``, ``std`` (over frames), ``sem`` (standard
    error from block means, see ``n_blocks``; the blocks start at the window's opening edge and
    its closing edge joins the last block, an edge beyond the run's first or last frame being
    moved onto it (with the warning), so that the error depends only on the frames used — NaN
    with fewer than two blocks),
    ``n_frames`` (frames in the window with a finite value), ``n_blocks``.
    """
    if not isinstance(timeseries, pd.DataFrame):  # a list of replicas
        if n_blocks is not None:
            raise ParameterError("steady_state: n_blocks is for one time series; replicas get the default blocks")
        return replica_steady_state(timeseries, window, columns, by=by, source=source)
    columns = (columns,) if isinstance(columns, str) else tuple(columns)
    if not columns:
        raise ParameterError("steady_state: columns must name at least one metric, got none")
    missing = [c for c in (by, *columns) if c not in timeseries]
    if missing:
        raise ParameterError(f"steady_state: the time series has no column {missing[0]!r} "
                             f"(it has {', '.join(map(str, timeseries.columns))})")
    axis = timeseries[by].to_numpy(dtype=float)
    lo, hi = (float(w) for w in window)
    mask, tol = check_window(axis, (lo, hi), by=by, source=source)
    # the blocks span the frames the window holds: an edge beyond the run is moved onto its first or
    # last frame, so that [3, 9] on a run ending at 6 gives the blocks, and the s.e.m., of [3, 6]
    lo, hi = clip_window(axis, lo, hi, tol)
    inside = timeseries[mask]
    out, block = _block_statistics(inside, columns, by, lo, hi, tol, n_blocks)
    _warn_if_drifting(inside, by, block, out, lo, hi, source)
    table = pd.DataFrame(out).T
    table.index.name = "metric"
    return table.astype({"n_frames": int, "n_blocks": int})


def _block_statistics(inside, columns, by, lo, hi, tol, n_blocks) -> tuple[dict, np.ndarray]:
    """:func:`steady_state`'s row of every column of the frames ``inside`` the window [lo, hi]
    (``mean``, ``std``, ``sem``, ``n_frames``, ``n_blocks``), and the block of every frame: blocks
    of ``n_blocks`` equal widths from ``lo``, the closing edge joining the last block; with
    ``n_blocks`` None, blocking (:func:`blocking_sem`) from quarter revolutions, or 5 blocks for
    ``by="time_s"``."""
    blocking = by == "revolutions" and n_blocks is None
    n_blocks = max(1, round((hi - lo) / 0.25)) if blocking else 5 if n_blocks is None else int(n_blocks)
    width = (hi - lo) / n_blocks
    # with the window's tolerance: a frame stamped just before a block edge belongs after it
    position = (inside[by].to_numpy() - lo + tol) / width if width > 0 else np.zeros(len(inside))
    block = np.clip(np.floor(position), 0, n_blocks - 1).astype(int)
    out = {}
    for col in columns:
        values = inside[col].to_numpy(dtype=float)
        ok = np.isfinite(values)
        grouped = pd.Series(values[ok]).groupby(block[ok])
        if blocking:
            sem, nb = blocking_sem(grouped.sum().to_numpy(), grouped.size().to_numpy())
        else:
            block_means = grouped.mean().to_numpy()
            nb = block_means.size
            sem = block_means.std(ddof=1) / math.sqrt(nb) if nb > 1 else math.nan
        out[col] = {
            "mean": values[ok].mean() if ok.any() else math.nan,
            "std": values[ok].std(ddof=1) if ok.sum() > 1 else math.nan,
            "sem": sem,
            "n_frames": int(ok.sum()),
            "n_blocks": int(nb),
        }
    return out, block


#: a window drifts when a linear trend over its blocks has a p-value below this and changes the
#: metric by more than DRIFT_FRACTION of its mean over the window (measured on the bundled lab runs:
#: windows that start at revolution 0 drift, p 0.02-0.17 and changes of 60-130 %; later ones do
#: not, p 0.24-0.99 and changes below 30 %)
DRIFT_P_VALUE = 0.05
DRIFT_FRACTION = 0.1


def _warn_if_drifting(inside, by, block, out, lo, hi, source) -> None:
    """Warn when a window is not steady: a headline metric whose block means (the blocks of the
    standard error, a quarter revolution each by default) follow a linear trend with a p-value below
    :data:`DRIFT_P_VALUE` (scipy's ``linregress``; four blocks at least) that changes it by more
    than :data:`DRIFT_FRACTION` of its mean. The block s.e.m. cannot tell: a drift inflates it
    instead of moving the mean out of it."""
    from scipy.stats import linregress

    drifting = []
    for col in out:
        if col not in HEADLINE:
            continue
        values = inside[col].to_numpy(dtype=float)
        ok = np.isfinite(values)
        frame = pd.DataFrame({"t": inside[by].to_numpy()[ok], "v": values[ok]}).groupby(block[ok]).mean()
        if len(frame) < 4 or frame["v"].nunique() < 2:
            continue
        fit = linregress(frame["t"], frame["v"])
        change = fit.slope * (hi - lo)
        if fit.pvalue < DRIFT_P_VALUE and abs(change) > DRIFT_FRACTION * abs(values[ok].mean()):
            drifting.append(f"{col} changes by {change:+.3g} over it (p = {fit.pvalue:.1g})")
    if drifting:
        where = f"{source}: " if source else ""
        warnings.warn(f"{where}the window [{lo:g}, {hi:g}] {by} is not a steady state: {'; '.join(drifting)}, a trend "
                      "over its blocks; choose a later window or a longer run", stacklevel=user_stacklevel())


@validate_params({"timeseries": [Instance((list, tuple), "a list of run_stats tables (one per replica)")],
                  **_WINDOW_CONSTRAINTS})
def replica_steady_state(timeseries, window=DEFAULT_WINDOW_REV, columns=_STEADY_COLUMNS, *, by="revolutions",
                         source=None) -> pd.DataFrame:
    """Steady state over replicas: runs of one system that differ only in their random seed.

    A steady-state mean from one run hides the run-to-run spread; here every replica's
    :func:`steady_state` is computed and the replicas' means are averaged.

    Parameters
    ----------
    timeseries : sequence of DataFrame
        One :func:`run_stats` time series per replica (at least two).
    window, columns, by, source :
        As for :func:`steady_state`.

    Returns
    -------
    DataFrame indexed by metric: ``mean`` (over replicas of each replica's mean),
    ``replica_sem`` (standard deviation of the replica means / √n, the run-to-run error),
    ``block_sem`` (√(Σ sem_i²)/n, what the replicas' block errors say of the same mean),
    ``replica_std`` (of the replica means), ``n_replicas``.
    """
    series = list(timeseries)
    wrong = next((ts for ts in series if not isinstance(ts, pd.DataFrame)), None)
    if wrong is not None:
        raise ParameterError(f"replica_steady_state: timeseries must be a list of run_stats tables (one per replica), "
                             f"got a {type(wrong).__name__} in it")
    if len(series) < 2:
        raise ParameterError(f"replica_steady_state needs at least two replicas, got {len(series)}")
    out = combine_steady_states([steady_state(ts, window, columns, by=by, source=source) for ts in series])
    out.index.name = "metric"
    return out


def combine_steady_states(tables) -> pd.DataFrame:
    """:func:`combine_replicas` of the :func:`steady_state` tables of replicas (their ``mean``
    and ``sem`` columns, one table per replica, numbered from 1 in the order given)."""
    numbers = range(1, len(tables) + 1)
    return combine_replicas(pd.concat([t["mean"] for t in tables], axis=1, keys=numbers),
                            pd.concat([t["sem"] for t in tables], axis=1, keys=numbers))


def combine_replicas(means, sems) -> pd.DataFrame:
    """Combine the steady-state means of replicas (one column per replica, one row per metric).

    The one rule every replica statistic of granalytics uses (:func:`replica_steady_state`,
    :func:`~granalytics.compare_cg` with replica groups, :func:`~granalytics.study_table` with
    ``replicas=``, the replica bands of the figures).

    Parameters
    ----------
    means, sems : DataFrame or 2-D array (metrics × replicas)
        Each replica's steady-state mean and block s.e.m. (NaN where it has none).

    Returns
    -------
    DataFrame (index of ``means``) with ``mean`` (over replicas), ``replica_sem`` (standard
    deviation of the replica means / √n: the run-to-run error; NaN for one replica),
    ``block_sem`` (√(Σ sem_i²)/n: what the replicas' block errors say of the same mean; NaN when
    a replica has none), ``replica_std`` and ``n_replicas``; n counts, metric by metric, the
    replicas with a value (a replica with no granule in its window has no ⟨V_g⟩/V_p: it is left
    out of that metric, with a warning).
    """
    means, sems = pd.DataFrame(means), pd.DataFrame(sems)
    n = means.shape[1]
    if n < 1 or sems.shape != means.shape:
        raise ParameterError(f"combine_replicas: means {means.shape} and sems {sems.shape} must be metrics × replicas, "
                             "with at least one replica")
    finite = means.notna().to_numpy()
    counts = finite.sum(axis=1)
    short = [(metric, [str(c) for c, ok in zip(means.columns, row) if not ok])
             for metric, row in zip(means.index, finite) if 0 < row.sum() < n]  # none at all: undefined, not short
    if short:  # a replica without a value (no granule in its window): the others' statistics, said
        warnings.warn("combine_replicas: " + "; ".join(f"{metric} has no value in replica(s) {', '.join(names)}"
                                                        for metric, names in short)
                      + ": its mean and errors are over the replicas that have one", stacklevel=user_stacklevel())
    std = means.std(axis=1, ddof=1).where(counts > 1)
    block_sq = np.where(finite, sems.to_numpy(dtype=float) ** 2, 0.0).sum(axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        return pd.DataFrame({
            "mean": means.mean(axis=1),
            "replica_sem": std / np.sqrt(counts),
            "block_sem": np.where(counts > 0, np.sqrt(block_sq) / counts, np.nan),
            "replica_std": std,
            "n_replicas": counts,
        }, index=means.index)


def blocking_sem(block_sums, block_counts, *, min_blocks=4) -> tuple:
    """Standard error of a mean over correlated, time-ordered blocks (Flyvbjerg & Petersen's blocking).

    The blocks are merged pairwise, level after level; at each level with at least
    ``min_blocks`` blocks the standard error is std(block means)/√n, and the largest of them is
    returned. Correlated frames (a granule population that changes over a fraction of a
    revolution) make short blocks report too small an error; the error grows with the block
    length until the blocks are independent (its plateau), so the largest estimate covers the
    correlation where the window allows (for an AR(1) series with a correlation time of a
    twentieth of the window it gives about 0.8 of the true error, fixed blocks of a twenty-fourth
    about 0.4: ``tests/test_stats.py``).

    Parameters
    ----------
    block_sums, block_counts : arrays
        Sum and number of the values in each block, in time order.

    Returns
    -------
    (sem, n_blocks) : (float, int)
        The error and the number of blocks of the level that gave it; NaN with fewer than two blocks.
    """
    sums = np.asarray(block_sums, dtype=float)
    counts = np.asarray(block_counts, dtype=float)
    best = (math.nan, int(sums.size))
    while sums.size >= 2:
        n = sums.size
        means = sums / counts
        sem = float(means.std(ddof=1) / math.sqrt(n))
        if n >= min(min_blocks, int(np.asarray(block_sums).size)) and not sem <= best[0]:
            best = (sem, int(n))
        if n < 2 * min_blocks:
            break
        m = n // 2 * 2  # merge pairs; an odd last block joins the last pair
        new_sums, new_counts = sums[:m:2] + sums[1:m:2], counts[:m:2] + counts[1:m:2]
        if n > m:
            new_sums[-1] += sums[-1]
            new_counts[-1] += counts[-1]
        sums, counts = new_sums, new_counts
    return best


#: Units of granule sizes (:func:`size_distribution`, :func:`~granalytics.coalescence_kernel`):
#: ``"particles"``, the run's own particles; ``"original"``, original-particle equivalents α³·n
#: (a CG particle of factor α has the volume of α³ original ones), the unit in which runs at
#: different CG factors are compared.
SIZE_UNITS = ("particles", "original")


def size_unit_factor(size_unit, alpha=None, *, caller="size_distribution") -> float:
    """The factor from the run's particles to ``size_unit``: 1 for ``"particles"``, α³ for
    ``"original"`` (``size_unit`` checked by the caller). ``alpha`` is the CG factor: a number, or
    a run or its metadata (their ``alpha``); needed for ``"original"`` only."""
    if size_unit == "particles":
        return 1.0
    if alpha is None:
        raise ParameterError(f"{caller}: size_unit='original' needs the CG factor alpha (a number, a run or its meta)")
    value = getattr(getattr(alpha, "meta", alpha), "alpha", alpha)
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)) \
            or not (math.isfinite(value) and value > 0):
        raise ParameterError(f"{caller}: alpha must be a positive number (the CG factor), got {alpha!r}")
    return float(value) ** 3


@validate_params({
    "sizes": [Array(ndim=1), Instance((list, tuple), "one array of sizes per frame")], "bins_per_decade": [Interval(Integral, 1, None)],
    "min_size": [Interval(Integral, 1, None)], "size_unit": [Options(SIZE_UNITS)],
    "ci": [Interval(Real, 0, 1, closed="neither"), None], "n_boot": [Interval(Integral, 1, None)],
})
def size_distribution(sizes, bins_per_decade=5, min_size=2, *, size_unit="particles", alpha=None, ci=None,
                      n_boot=2000, seed=0) -> pd.DataFrame:
    """Distribution of particles per granule on logarithmic bins of integers.

    Parameters
    ----------
    sizes : int array, or list of int arrays (pooled, e.g. over the frames of a window)
        Particles per granule.
    bins_per_decade : int, default 5
    min_size : int, default 2
        Smallest granule size.
    size_unit : {"particles", "original"}, default "particles"
        Unit of the returned sizes: the run's particles, or original-particle equivalents α³·n
        (for comparing runs at different CG factors). The bins are the same integer bins of the
        run's particles either way: in ``"original"`` the bounds and centres are α³ times the
        others and the density is per original particle (divided by α³).
    alpha : float, or a run or its metadata
        The CG factor, for ``size_unit="original"``.
    ci : float, optional
        Confidence level (e.g. 0.95) of a bootstrap over the granules: ``density_lo`` and
        ``density_hi`` are the percentile interval of each bin's density over ``n_boot``
        resamples of the granules with replacement (seeded: ``seed``). Granules pooled over
        frames are not independent (a granule is counted in every frame it lives), so read the
        interval as a lower bound on the uncertainty.

    Returns
    -------
    DataFrame with one row per non-empty-range bin: ``size_min``, ``size_max`` (inclusive
    integer bounds in particles; α³ times them in ``"original"``), ``size_center`` (geometric
    centre), ``count`` (granules), ``probability`` (count / total), ``density`` (probability per
    unit size: probability / integers in bin, / α³ in ``"original"``), and with ``ci``
    ``density_lo``, ``density_hi``. ``attrs``: ``size_unit``, ``alpha`` (None in particles)
    and ``ci``.
    """
    factor = size_unit_factor(size_unit, alpha)
    if isinstance(sizes, (list, tuple)) and sizes and np.ndim(sizes[0]) == 0:  # one list of sizes
        sizes = np.asarray(sizes)
    elif isinstance(sizes, (list, tuple)):  # one array of sizes per frame
        sizes = np.concatenate([np.asarray(s, dtype=np.int64) for s in sizes]) if sizes else np.zeros(0, np.int64)
    sizes = np.asarray(sizes, dtype=np.int64)
    if (sizes < min_size).any():
        raise ParameterError(f"granule sizes must be >= {min_size}, found {sizes.min()}")
    top = max(int(sizes.max()) if sizes.size else min_size, min_size) + 1
    n_bins = max(1, math.ceil(bins_per_decade * math.log10(top / min_size)))
    edges = np.unique(np.ceil(np.geomspace(min_size, top, n_bins + 1)).astype(np.int64))
    edges[0], edges[-1] = min_size, max(edges[-1], top)
    count = np.histogram(sizes, bins=edges)[0] if sizes.size else np.zeros(edges.size - 1, np.int64)
    width = np.diff(edges) * factor
    total = count.sum()
    probability = count / total if total else np.zeros_like(count, dtype=float)
    scale = factor if size_unit == "original" else 1  # integers stay integers in particles
    out = pd.DataFrame(
        {
            "size_min": edges[:-1] * scale,
            "size_max": (edges[1:] - 1) * scale,
            "size_center": np.sqrt(edges[:-1] * (edges[1:] - 1)) * factor,
            "count": count,
            "probability": probability,
            "density": probability / width,
        }
    )
    if ci is not None:
        if total:  # resampling the granules with replacement = a multinomial draw of the bin counts
            draws = np.random.default_rng(seed).multinomial(total, probability, size=int(n_boot)) / total / width
            out["density_lo"], out["density_hi"] = np.quantile(draws, [(1 - ci) / 2, (1 + ci) / 2], axis=0)
        else:
            out["density_lo"] = out["density_hi"] = np.nan
    out.attrs.update(size_unit=size_unit, alpha=None if size_unit == "particles" else round(factor ** (1 / 3), 12), ci=ci)
    return out
