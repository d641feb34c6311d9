"""The population balance fed by the DEM: every rate measured on tracked granules
(:func:`fit_pbm_rates`, :class:`PBMRates`), and the prediction of a run's later size
distribution from the rates of an earlier window, beside the DEM's own (:func:`pbm_from_run`,
:class:`PBMPrediction`).

Units: time in seconds; granule sizes in primary particles (of the run: CG particles in a CG run).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from numbers import Integral, Real

import numpy as np
import pandas as pd

from granalytics.analysis.population_balance.grid import (RATIO, distribution_summary, ks_distance, pbm_grid,
                                                          project_counts, size_counts)
from granalytics.analysis.population_balance.model import PopulationBalance, population_balance
from granalytics.analysis.tracking import breakage_rate, coalescence_kernel, track_run
from granalytics.analysis.tracking.tracks import TRACKS
from granalytics.base.errors import ParameterError
from granalytics.base.validation import FLAG, POSITIVE, WINDOW, Array, Instance, Interval, validate_params
from granalytics.core.reader import Run, RunSlice


@dataclass(eq=False)
class PBMRates:
    """Population-balance rates measured on tracked granules (:func:`fit_pbm_rates`).

    Attributes
    ----------
    kernel : DataFrame
        :func:`granalytics.coalescence_kernel` on the classes of ``classes`` (β [1/s per pair]).
    classes : DataFrame
        One row per size class: ``class``, ``size_min``, ``size_max`` [particles] (a first row
        of size 1, free particles: nucleation), ``n_mean`` (time-averaged number of granules),
        ``n_breakage``, ``fragments_mean``, ``selection_rate_per_s`` (S [1/s], from
        :func:`granalytics.breakage_rate`), ``n_layering`` (free particles that joined a granule of
        the class; for size 1, nucleations), ``layering_per_s`` (λ [1/s per (free particle,
        granule) pair]; for size 1 the nucleation rate per pair of free particles), ``n_erosion``
        (particles that left a granule of the class for the free state) and ``erosion_per_s``
        (E [1/s per granule]).
    n_particles : int
        Particles of the system.
    min_fragment : int
        The tracking's ``min_fragment`` (smallest breakage fragment).
    window_s : (float, float)
        First and last tracked time [s].
    free_mean : float
        Time-averaged number of free particles.
    """

    kernel: pd.DataFrame
    classes: pd.DataFrame
    n_particles: int
    min_fragment: int
    window_s: tuple
    free_mean: float

    def predict(self, initial, t, **kwargs) -> PopulationBalance:
        """:func:`population_balance` with these rates (coalescence, breakage with the measured
        fragment numbers, layering, nucleation, erosion); ``kwargs`` go there (``grid``, ``ratio``, …)."""
        kwargs.setdefault("min_fragment", self.min_fragment)
        if kwargs.get("grid") is None:
            kwargs.setdefault("n_max", int(self.n_particles))
        return population_balance(self.kernel, self.classes, initial, t, layering=self.classes,
                                  erosion=self.classes, **kwargs)


@validate_params({"tracks": [TRACKS], "n_particles": [Interval(Integral, 1, None)],
                  "size_bins": [Array(ndim=1, within=Interval(Real, 1, None)), None], "bins_per_decade": [POSITIVE]})
def fit_pbm_rates(tracks, n_particles, size_bins=None, *, bins_per_decade=4) -> PBMRates:
    """Measure every rate of :func:`population_balance` on tracked granules.

    Coalescence kernel and selection rate are :func:`granalytics.coalescence_kernel` and
    :func:`granalytics.breakage_rate` on common classes. Layering and erosion come from the
    particles each granule receives from, and gives to, the free particles between frames
    (``from_free_by_frame``, ``to_free_by_frame``): a granule that received L free particles and
    holds s particles was of size s − L before, and grew through sizes s − L, …, s − 1 (one
    layering event at each); a granule made only of free particles is one nucleation and layering
    at sizes 2, …, s − 1. A granule of s particles that gave E particles to the free state eroded at
    sizes s, s − 1, …, max(s − E + 1, 2) (the last erosion of a pair frees both). Rates divide the
    events per second of tracked time by the time-averaged numbers of the participants (as
    :func:`granalytics.coalescence_kernel` does): λ(x) by N̄₁·N̄(x), nucleation by N̄₁²/2, E(x)
    by N̄(x).

    Parameters
    ----------
    tracks : GranuleTracks
        From :func:`granalytics.track_run` (or :func:`granalytics.track_granules`).
    n_particles : int
        Particles of the run (``run.meta.n_particles``); the particles in no granule are free.
    size_bins : int array, optional
        Class edges [particles per granule]; default logarithmic (``bins_per_decade``), as
        :func:`granalytics.coalescence_kernel`.
    bins_per_decade : float, default 4

    Returns
    -------
    PBMRates
        Rates per second; ``PBMRates.predict(initial, t)`` integrates the population balance.
    """
    times = np.asarray(tracks.times_s, dtype=float)
    if times.size < 2:
        raise ParameterError("fit_pbm_rates: the tracks need at least two frames (one frame interval)")
    n_particles = int(n_particles)
    sizes_by_frame = [np.asarray(s, dtype=np.int64) for s in tracks.sizes_by_frame]
    if any((s == 1).any() for s in sizes_by_frame):
        raise ParameterError("fit_pbm_rates: the tracks hold granules of one particle (identified with min_size=1); "
                             "the population balance counts a free particle as size 1: track granules of two or "
                             "more particles")
    in_granules = max(int(s.sum()) for s in sizes_by_frame)
    if n_particles < in_granules:
        raise ParameterError(f"fit_pbm_rates: n_particles={n_particles} is below the {in_granules} particles in "
                             "granules of a frame")
    breakage = breakage_rate(tracks, size_bins, bins_per_decade=bins_per_decade)
    edges = np.append(breakage["size_min"].to_numpy(), breakage["size_max"].to_numpy()[-1] + 1)
    kernel = coalescence_kernel(tracks, size_bins=edges)
    dt = np.diff(times)
    span = dt.sum()
    free_mean = float(np.dot(dt, [n_particles - s.sum() for s in sizes_by_frame[:-1]]) / span)
    nc = edges.size - 1

    def classify(sizes):
        c = np.searchsorted(edges, sizes, side="right") - 1
        return c[(c >= 0) & (c < nc)]

    layer = np.zeros(nc)
    nucleation = 0
    for k in range(1, times.size):
        sizes = sizes_by_frame[k]
        gained = np.asarray(tracks.from_free_by_frame[k], dtype=np.int64)
        for s, got in zip(sizes[(sizes > 0) & (gained > 0)], gained[(sizes > 0) & (gained > 0)]):
            before = s - got
            if before < 2:
                nucleation += 1
                start = 2
            else:
                start = before
            steps = np.arange(start, s)
            layer += np.bincount(classify(steps), minlength=nc)
    erode = np.zeros(nc)
    for k in range(times.size - 1):
        sizes = sizes_by_frame[k]
        lost = np.asarray(tracks.to_free_by_frame[k], dtype=np.int64)
        for s, gone in zip(sizes[(sizes > 0) & (lost > 0)], lost[(sizes > 0) & (lost > 0)]):
            steps = np.arange(max(s - gone + 1, 2), s + 1)
            erode += np.bincount(classify(steps), minlength=nc)
    n_mean = breakage["n_mean"].to_numpy(dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        lam = np.where(n_mean > 0, layer / span / (free_mean * n_mean), np.nan) if free_mean > 0 else np.full(nc, np.nan)
        ero = np.where(n_mean > 0, erode / span / n_mean, np.nan)
    nuc = nucleation / span / (free_mean ** 2 / 2) if free_mean > 0 else float("nan")
    classes = pd.DataFrame({
        "class": np.arange(-1, nc),
        "size_min": np.concatenate([[1], breakage["size_min"].to_numpy()]),
        "size_max": np.concatenate([[1], breakage["size_max"].to_numpy()]),
        "n_mean": np.concatenate([[free_mean], n_mean]),
        "n_breakage": np.concatenate([[0], breakage["n_events"].to_numpy()]),
        "fragments_mean": np.concatenate([[np.nan], breakage["fragments_mean"].to_numpy(dtype=float)]),
        "selection_rate_per_s": np.concatenate([[0.0], breakage["selection_rate_per_s"].to_numpy(dtype=float)]),
        "n_layering": np.concatenate([[nucleation], layer]).astype(np.int64),
        "layering_per_s": np.concatenate([[nuc], lam]),
        "n_erosion": np.concatenate([[0], erode]).astype(np.int64),
        "erosion_per_s": np.concatenate([[0.0], ero]),
    })
    return PBMRates(kernel=kernel, classes=classes, n_particles=n_particles, min_fragment=int(tracks.min_fragment),
                    window_s=(float(times[0]), float(times[-1])), free_mean=free_mean)


@dataclass(eq=False)
class PBMPrediction:
    """Rates measured on one window of a run and the population balance over a later one, beside
    the DEM's own distributions (:func:`pbm_from_run`).

    Attributes
    ----------
    rates : PBMRates
        Measured on the fit window.
    pbm : PopulationBalance
        Started from the DEM's distribution at the first frame of the prediction window, output at
        every DEM frame of it.
    dem_numbers : (T, G) float array
        The DEM's granules of each frame of the prediction window on the pivots of ``pbm.grid``
        (:func:`project_counts`).
    revolutions : (T,) float array
        Those frames' drum revolutions.
    fit_window, predict_window : (float, float)
        The windows [revolutions].
    run : str
        The run's file name.
    setting : dict
        Identification method and parameters.
    run_path : str
        The run file's path, as it was opened.
    bins_per_decade : float
        Size classes of the rates per decade (:func:`fit_pbm_rates`).
    ratio : float
        Pivot ratio of the grid (:func:`pbm_grid`).
    """

    rates: PBMRates
    pbm: PopulationBalance
    dem_numbers: np.ndarray
    revolutions: np.ndarray
    fit_window: tuple
    predict_window: tuple
    run: str = ""
    setting: dict = field(default_factory=dict)
    run_path: str = ""
    bins_per_decade: float = 4
    ratio: float = 2 ** 0.25

    def to_json(self) -> dict:
        """What the prediction was computed from and how, for ``settings.json``: ``run`` (the
        path), ``fit_window_rev``, ``predict_rev``, the identification ``setting``,
        ``bins_per_decade``, ``ratio``, ``n_particles``, the ``pivots`` of the grid [particles],
        ``mass_error`` (relative change of the particles over the integration) and ``units``."""
        return {"run": self.run_path, "fit_window_rev": list(self.fit_window), "predict_rev": list(self.predict_window),
                **self.setting, "bins_per_decade": self.bins_per_decade, "ratio": self.ratio,
                "n_particles": self.rates.n_particles, "pivots": self.pbm.grid.tolist(),
                "mass_error": self.pbm.mass_error, "units": "rates per second; sizes in particles of the run"}

    def summary(self, min_size=2) -> pd.DataFrame:
        """Per frame of the prediction window: ``revolution``, ``t_s``, the PBM's and the DEM's
        ``n_granules``, ``mean_size`` [particles] and ``yield_fraction`` (prefixes ``pbm_`` and
        ``dem_``), ``ks_d`` (KS distance between their number distributions of granules,
        :func:`ks_distance`) and ``ks_d_persistence`` (the same for the DEM's first frame of the
        window taken as the prediction: the baseline a model must beat)."""
        grid = self.pbm.grid
        p = distribution_summary(self.pbm.numbers, grid, min_size=min_size)
        d = distribution_summary(self.dem_numbers, grid, min_size=min_size)
        out = pd.DataFrame({"revolution": self.revolutions, "t_s": self.pbm.t_s})
        for prefix, table in (("pbm_", p), ("dem_", d)):
            for col in ("n_granules", "mean_size", "yield_fraction"):
                out[prefix + col] = table[col].to_numpy()
        out["ks_d"] = [ks_distance(a, b, grid, min_size) for a, b in zip(self.pbm.numbers, self.dem_numbers)]
        out["ks_d_persistence"] = [ks_distance(self.dem_numbers[0], b, grid, min_size) for b in self.dem_numbers]
        return out

    def at(self, revolutions, min_size=2) -> pd.DataFrame:
        """:meth:`summary` at the frames nearest the given revolutions."""
        table = self.summary(min_size)
        rows = [int(np.argmin(np.abs(self.revolutions - r))) for r in np.atleast_1d(revolutions)]
        return table.iloc[rows].reset_index(drop=True)

    def distributions(self) -> pd.DataFrame:
        """Long table of both distributions: ``source`` (``"dem"`` or ``"pbm"``), ``revolution``,
        ``t_s``, ``size`` (pivot [particles]; 1 = free particles), ``number`` (granules at the pivot)."""
        frames = []
        for source, numbers in (("dem", self.dem_numbers), ("pbm", self.pbm.numbers)):
            r, g = np.meshgrid(self.revolutions, self.pbm.grid, indexing="ij")
            t = np.broadcast_to(self.pbm.t_s[:, None], r.shape)
            frames.append(pd.DataFrame({"source": source, "revolution": r.ravel(), "t_s": t.ravel(),
                                        "size": g.ravel(), "number": numbers.ravel()}))
        return pd.concat(frames, ignore_index=True)

    def cumulative_fractions(self, revolutions, min_size=2) -> pd.DataFrame:
        """The cumulative number distributions of granules (pivots of ``min_size`` particles or
        more; negative PBM numbers taken as 0) of the DEM and the PBM at the frames nearest the
        given revolutions.

        Returns
        -------
        DataFrame
            For each frame, the DEM's then the PBM's rows: ``source`` (``"dem"`` or ``"pbm"``),
            ``revolution`` (the frame's), ``size`` (pivot [particles]) and ``fraction`` (the
            fraction of the granules at that pivot or below; NaN in a frame without granules).
        """
        grid = self.pbm.grid
        keep = grid >= min_size
        frames = []
        for rev in np.atleast_1d(revolutions):
            i = int(np.argmin(np.abs(self.revolutions - rev)))
            for source, numbers in (("dem", self.dem_numbers[i]), ("pbm", self.pbm.numbers[i])):
                n = np.clip(numbers[keep], 0, None)
                with np.errstate(divide="ignore", invalid="ignore"):
                    fraction = np.cumsum(n) / n.sum()
                frames.append(pd.DataFrame({"source": source, "revolution": self.revolutions[i], "size": grid[keep],
                                            "fraction": fraction}))
        return pd.concat(frames, ignore_index=True)


@validate_params({"run": [Instance((Run, RunSlice), "an open run (granalytics.open_run)")], "fit_window": [WINDOW],
                  "predict_window": [WINDOW], "min_fragment": [Interval(Integral, 1, None)], "ratio": [RATIO],
                  "progress": [FLAG]})
def pbm_from_run(run, fit_window, predict_window, *, method="gna", min_fragment=2, size_bins=None,
                 bins_per_decade=4, ratio=2 ** 0.25, progress=False, **params) -> PBMPrediction:
    """Measure the rates on ``fit_window`` of a run and predict its size distribution over
    ``predict_window``.

    Granules are identified and tracked (:func:`granalytics.track_run`) in both windows; the rates
    come from the fit window (:func:`fit_pbm_rates`); the population balance starts from the DEM's
    granules at the first frame of the prediction window and is output at every frame of it.

    Parameters
    ----------
    run : Run
        ``granalytics.open_run(path)``; its drum must turn (windows are in revolutions).
    fit_window, predict_window : (float, float)
        Closed windows of drum revolutions; each needs two frames or more.
    method : str, default "gna"
        Identification method; ``params`` go to it (``c_agg``, ``a_agg_deg``, ``cohesion``, …).
    min_fragment : int, default 2
        Tracking's smallest fragment, and the PBM's.
    size_bins, bins_per_decade
        Classes of the rates (:func:`fit_pbm_rates`).
    ratio : float, default 2**0.25
        Pivot ratio of the grid (:func:`pbm_grid`, up to the run's particle count).
    progress : bool, default False
        Progress bars over the frames.

    Returns
    -------
    PBMPrediction
    """
    import os

    fit_window = tuple(float(v) for v in fit_window)
    predict_window = tuple(float(v) for v in predict_window)
    n = int(run.meta.n_particles)
    sets = {}
    for name, w in (("fit_window", fit_window), ("predict_window", predict_window)):
        frames = run.select(revolutions=w)
        if len(frames) < 2:
            raise ParameterError(f"{os.path.basename(str(run.path))}: {name} {w[0]:g}:{w[1]:g} holds {len(frames)} "
                                 "frame(s), at least two are needed")
        sets[name] = frames
    fit_tracks = track_run(sets["fit_window"], method, progress=progress, min_fragment=min_fragment, **params)
    if not any(len(sizes) for sizes in fit_tracks.sizes_by_frame):
        shown = ", ".join(f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}" for k, v in params.items())
        raise ParameterError(f"{os.path.basename(str(run.path))}: no granule in the fit window {fit_window[0]:g}:"
                             f"{fit_window[1]:g} with {method} ({shown or 'its defaults'}): there are no rates to fit "
                             "(a threshold above every contact's cohesion finds none)")
    rates = fit_pbm_rates(fit_tracks, n, size_bins, bins_per_decade=bins_per_decade)
    frames = sets["predict_window"]
    pred_tracks = track_run(frames, method, progress=progress, min_fragment=min_fragment, **params)
    grid = pbm_grid(n, ratio)
    dem = np.array([project_counts(size_counts(s, n), grid) for s in pred_tracks.sizes_by_frame])
    t = np.asarray(pred_tracks.times_s, dtype=float)
    pbm = rates.predict(size_counts(pred_tracks.sizes_by_frame[0], n), t, grid=grid)
    return PBMPrediction(rates=rates, pbm=pbm, dem_numbers=dem, revolutions=np.asarray(frames.revolutions, dtype=float),
                         fit_window=fit_window, predict_window=predict_window, run=os.path.basename(str(run.path)),
                         setting={"method": method, "min_fragment": min_fragment, **params}, run_path=str(run.path),
                         bins_per_decade=bins_per_decade, ratio=ratio)

