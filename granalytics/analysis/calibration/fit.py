"""The fit of the granule definition (C_agg and A_agg, or the rigid tolerance) to a measured size
distribution, :func:`calibrate_thresholds`, and its result, :class:`Calibration`
(docs/calibration.md).

The simulated distribution at every grid point comes from one pass per frame and co-motion
threshold (:func:`~granalytics.analysis.calibration.size_classes.size_class_grid`) over the frames of
the steady window, averaged over them. Its error is a moving-block bootstrap over the window's
frames (:mod:`~granalytics.analysis.calibration.bootstrap`). The distance between simulated and
measured distributions is

    χ²(C_agg, A_agg) = Σ_j (P_sim(a_j) − P_meas(a_j))² / (σ_sim,j² + σ_meas,j²)

over the class edges a_j (finite, > 0) of the cumulative mass fraction passing P, σ_sim the
bootstrap error of the simulated mean and σ_meas the measured one. The best pair is the grid point
of smallest χ². Its confidence region is a bootstrap: each replica resamples the frames (blocks of
``block_rev`` revolutions, every run of a replica set on its own) and the measured values (normal,
σ_meas), and finds its own best point; the region is the smallest set of grid points that holds
``level`` of the replicas' best points. A threshold whose axis the region spans from end to end is
unconstrained by the data.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field, replace
from numbers import Integral, Real

import numpy as np
import pandas as pd

from granalytics.analysis.calibration.bootstrap import SimulatedMean, bootstrap_region, check_block, simulated_mean
from granalytics.analysis.calibration.measured import MeasuredDistribution, read_sieve_csv
from granalytics.analysis.calibration.size_classes import MEASURE, SizeClassGrid, class_grid
from granalytics.analysis.sensitivity import SWEEP_CONSTRAINTS, threshold_grid
from granalytics.analysis.stats import DEFAULT_WINDOW_REV
from granalytics.base.errors import ParameterError
from granalytics.base.validation import FLAG, POSITIVE, WINDOW, Instance, Interval, Path, validate_params
from granalytics.core.snapshot import Snapshot
from granalytics.core.windows import window_mask
from granalytics.identification.cohesion import DEFAULT_COHESION
from granalytics.identification.contacts import DEFAULT_COMOTION, DEFAULT_RIGID_SCALE

__all__ = ["calibrate_thresholds", "Calibration", "POOR_FIT_P", "DEFAULT_MEASURED_ERROR"]

#: a best fit whose χ² has a p-value below this is a poor fit: no grid point reproduces the measurement
POOR_FIT_P = 0.01
#: the measured cumulative fraction's standard error when the file gives none (mass fraction)
DEFAULT_MEASURED_ERROR = 0.01


@dataclass
class Calibration:
    """The result of :func:`calibrate_thresholds`.

    Attributes
    ----------
    grid : DataFrame
        One row per grid point: ``c_agg``, ``a_agg_deg`` (or ``rigid_tol``), ``chi2``,
        ``delta_chi2`` (χ² − χ²_min), ``max_abs_dpassing`` (largest |P_sim − P_meas| over the
        edges), ``boot_frequency`` (share of bootstrap replicas whose best point it is),
        ``in_region`` (the bootstrap confidence region), ``in_chi2_region`` (Δχ² below the χ²
        quantile of two parameters at ``level``, for comparison).
    best : dict
        The best grid point: the thresholds and its ``chi2``.
    constraint : dict
        Per threshold: ``"constrained to [lo, hi]"``, ``"lower bound only (>= lo)"``, ``"upper bound
        only (<= hi)"``, ``"unconstrained"`` (the region spans its whole axis) or ``"fixed"`` (one
        value given).
    distributions : DataFrame
        One row per class: ``lower_m``, ``upper_m`` [m], ``measured_fraction``, ``measured_passing``
        (cumulative at the upper edge), ``measured_sigma``, ``simulated_fraction`` and
        ``simulated_fraction_error`` (block bootstrap), ``simulated_passing`` and
        ``simulated_passing_error`` at the best point.
    chi2_min, dof, p_value : float, int, float
        The best χ², its degrees of freedom (edges − fitted thresholds) and its p-value under the
        χ² law (approximate: the cumulative values are correlated).
    poor_fit : bool
        ``p_value < POOR_FIT_P``: no grid point reproduces the measured distribution.
    settings : dict
        What was fitted and how (runs, window, measure, co-motion test, bootstrap).
    """

    grid: pd.DataFrame
    best: dict
    constraint: dict
    distributions: pd.DataFrame
    chi2_min: float
    dof: int
    p_value: float
    poor_fit: bool
    settings: dict = field(default_factory=dict)

    @property
    def threshold_column(self) -> str:
        """``a_agg_deg`` or ``rigid_tol``."""
        return "rigid_tol" if "rigid_tol" in self.grid else "a_agg_deg"

    @property
    def region(self) -> pd.DataFrame:
        """The grid points of the confidence region (those the data cannot tell apart)."""
        return self.grid[self.grid["in_region"]].reset_index(drop=True)

    def summary(self) -> str:
        """A few lines: the best pair, its region, what is unconstrained, the fit's quality."""
        col = self.threshold_column
        unit = "°" if col == "a_agg_deg" else ""
        name = "A_agg" if col == "a_agg_deg" else "rigid_tol"
        region = self.region
        lines = [f"best: C_agg = {self.best['c_agg']:g}, {name} = {self.best[col]:g}{unit} (chi2 = {self.chi2_min:.3g}, "
                 f"{self.dof} degrees of freedom, p = {self.p_value:.3g})",
                 f"{100 * self.settings['level']:g} % confidence region ({self.settings['n_boot']} bootstrap replicas): "
                 f"{len(region)} grid point(s) the data cannot tell apart, C_agg in [{region.c_agg.min():g}, "
                 f"{region.c_agg.max():g}], {name} in [{region[col].min():g}, {region[col].max():g}]{unit}",
                 f"C_agg: {self.constraint['c_agg']}; {name}: {self.constraint[col]}"]
        if self.poor_fit:
            lines.append(f"POOR FIT: no grid point reproduces the measured distribution (chi2/dof = "
                         f"{self.chi2_min / self.dof:.3g}, p = {self.p_value:.2g} < {POOR_FIT_P:g}); the region "
                         "then only says which points are least bad")
        return "\n".join(lines)

    def to_json(self) -> dict:
        """The headline numbers and settings as plain JSON types."""
        def plain(v):
            if isinstance(v, (np.floating, float)):
                return None if not math.isfinite(v) else float(v)
            if isinstance(v, (np.integer,)):
                return int(v)
            if isinstance(v, (np.bool_,)):
                return bool(v)
            if isinstance(v, dict):
                return {k: plain(x) for k, x in v.items()}
            if isinstance(v, (list, tuple, np.ndarray)):
                return [plain(x) for x in v]
            return v

        col = self.threshold_column
        region = self.region
        return plain({"best": self.best, "chi2_min": self.chi2_min, "dof": self.dof, "p_value": self.p_value,
                      "poor_fit": self.poor_fit, "constraint": self.constraint,
                      "region": {"c_agg": sorted(set(region.c_agg)), col: sorted(set(region[col])),
                                 "points": len(region)},
                      "settings": self.settings})


def _is_one_run(run) -> bool:
    if isinstance(run, (str, os.PathLike, SizeClassGrid)) or hasattr(run, "select"):
        return True
    return isinstance(run, (list, tuple)) and len(run) > 0 and isinstance(run[0], Snapshot)


def _window_frames(frames, window):
    """The frames of a Run, RunSlice or sequence of Snapshot in the window [revolutions], by the one
    rule of :mod:`granalytics.core.windows`: ``select`` where the frames have it, else the
    snapshots' own revolutions."""
    if hasattr(frames, "select"):
        return frames.select(revolutions=window)
    keep = window_mask([snapshot.revolutions for snapshot in frames], *window)
    return [frames[k] for k in np.flatnonzero(keep)]


def _grid_of(run, measured, window, sweep) -> SizeClassGrid:
    """The per-frame size classes of one run in the window; ``sweep``: :func:`class_grid`'s other
    arguments."""
    if isinstance(run, (str, os.PathLike)):
        from granalytics.core import open_run

        with open_run(run) as opened:
            return _grid_of(opened, measured, window, sweep)
    if isinstance(run, SizeClassGrid):
        if not np.array_equal(run.edges_m, measured.edges_m):
            raise ParameterError("the SizeClassGrid was computed on other classes than the measured distribution's")
        keep = window_mask(run.revolutions, *window)
        frames = run.frames[keep]
    else:
        frames = _window_frames(run, window)
    if len(frames) == 0:
        where = f"{getattr(run, 'path', 'run')}: " if hasattr(run, "select") else ""
        raise ParameterError(f"{where}no frame in the window [{window[0]:g}, {window[1]:g}] revolutions")
    if isinstance(run, SizeClassGrid):
        return replace(run, volumes=run.volumes[keep], frames=frames, revolutions=run.revolutions[keep],
                       time_s=run.time_s[keep])
    return class_grid(frames, measured.edges_m, **sweep)


def _check_sizes(points, n_edges, n_boot) -> None:
    """Refuse, before any frame is read, a grid or bootstrap whose arrays cannot fit in memory
    (the bootstrap's passing fractions: n_boot × grid points × class edges, float64, a few copies)."""
    from granalytics.base.resources import check_memory

    check_memory(f"calibrating over a grid of {points} threshold pairs with {n_boot} bootstrap replicas",
                 8 * points * (n_edges + 2) * (n_boot + 8) * 3)


def _describe(values, inside) -> str:
    if values.size == 1:
        return "fixed"
    lo, hi = values[inside].min(), values[inside].max()
    at_lo, at_hi = lo == values[0], hi == values[-1]
    if at_lo and at_hi:
        return "unconstrained"
    if at_lo:
        return f"upper bound only (<= {hi:g})"
    if at_hi:
        return f"lower bound only (>= {lo:g})"
    return f"constrained to [{lo:g}, {hi:g}]"


#: the fraction of a level or an error, in (0, 1)
_FRACTION = Interval(Real, 0, 1, closed="neither")


@validate_params({**{name: allowed for name, allowed in SWEEP_CONSTRAINTS.items() if name != "surface_tension"},
                  "measured": [Instance(MeasuredDistribution), Path("the path of a sieve CSV")],
                  "measure": [MEASURE], "window": [WINDOW], "measured_error": [_FRACTION],
                  "n_boot": [Interval(Integral, 10, None)], "block_rev": [POSITIVE], "level": [_FRACTION],
                  "seed": [Interval(Integral, 0, None), None], "progress": [FLAG]})
def calibrate_thresholds(run, measured, c_agg, a_agg_deg=None, *, window=DEFAULT_WINDOW_REV, comotion=DEFAULT_COMOTION,
                         rigid_tol=None, rigid_scale=DEFAULT_RIGID_SCALE, measure="volume",
                         measured_error=DEFAULT_MEASURED_ERROR, n_boot=200, block_rev=0.5, level=0.95, seed=0,
                         radius="pair", cohesion=DEFAULT_COHESION, min_size=2, jobs=1, progress=False) -> Calibration:
    """Fit GNA's thresholds to a measured size distribution over a threshold grid.

    Parameters
    ----------
    run : path, Run, RunSlice, sequence of Snapshot or SizeClassGrid, or a list of these
        The run; a list of runs is a replica set (one system at several seeds): the simulated
        distribution is the mean over the runs, each bootstrapped on its own.
    measured : MeasuredDistribution or path
        The measured sieve analysis (:func:`~granalytics.analysis.calibration.measured.read_sieve_csv`);
        the simulated granules are sorted into its classes by their original-system sizes.
    c_agg : sequence of float
        Cohesion thresholds (≥ 0).
    a_agg_deg : sequence of float
        Angle thresholds [deg] (``comotion="angle"``).
    window : (float, float), default (3, 6)
        Steady-state window [revolutions]: the distribution is the mean over its frames.
    comotion, rigid_tol, rigid_scale :
        The co-motion test; with ``"rigid"`` the grid's second axis is ``rigid_tol``.
    measure : {"volume", "width"}, default "volume"
        A granule's size: its volume-equivalent diameter, or its second principal extent.
    measured_error : float, default 0.01
        Standard error of the measured cumulative fraction passing each edge (mass fraction),
        used when the measured distribution carries none (its ``sigma``).
    n_boot : int, default 200
        Bootstrap replicas (errors and confidence region).
    block_rev : float, default 0.5
        Length of the bootstrap's blocks of frames [revolutions] (frames closer than this are
        correlated: a granule lives for a fraction of a revolution or more).
    level : float, default 0.95
        Confidence level of the region.
    seed : int or None, default 0
        Seed of the bootstrap (None: fresh randomness, different at every call).
    radius, cohesion, min_size, jobs, progress :
        As for :func:`granalytics.sensitivity`.

    Returns
    -------
    Calibration
    """
    from scipy.stats import chi2 as chi2_law

    measured = measured if isinstance(measured, MeasuredDistribution) else read_sieve_csv(measured)
    window = (float(window[0]), float(window[1]))
    runs = [run] if _is_one_run(run) else list(run)
    if not runs:
        raise ParameterError("calibrate_thresholds: no run given")
    c_desc, a_list = threshold_grid(c_agg, a_agg_deg, rigid_tol, comotion, "calibrate_thresholds")
    _check_sizes(c_desc.size * len(a_list), np.size(measured.edges_m), int(n_boot))
    sweep = dict(c_desc=c_desc, a_list=a_list, measure=measure, radius=radius, surface_tension=None, cohesion=cohesion,
                 comotion=comotion, rigid_scale=rigid_scale, min_size=min_size, jobs=jobs, scheduler=None,
                 progress=progress)
    grids = [_grid_of(r, measured, window, sweep) for r in runs]
    first = grids[0]
    for g in grids[1:]:
        if not (np.array_equal(g.c_agg, first.c_agg) and np.array_equal(g.comotion_values, first.comotion_values)
                and g.comotion == first.comotion and g.measure == first.measure):
            raise ParameterError("calibrate_thresholds: the replicas' SizeClassGrids have different grids")
    used = np.isfinite(measured.edges_m) & (measured.edges_m > 0)
    n_fit = int(first.comotion_values.size > 1) + int(first.c_agg.size > 1)  # the thresholds fitted
    dof = int(used.sum()) - n_fit
    if dof < 1:
        raise ParameterError(f"the measured distribution gives {int(used.sum())} class edge(s) to compare at and the fit "
                             f"has {n_fit} free threshold(s): no degree of freedom is left to test it (p undefined); "
                             "measure more classes, or fix a threshold (a grid of one value)")
    p_meas = measured.passing[used]
    s_meas = (measured.sigma if measured.sigma is not None else np.full(measured.edges_m.size, measured_error))[used]
    for g in grids:
        check_block(g.revolutions, block_rev)
    rng = np.random.default_rng(seed)
    sim = simulated_mean(grids, used, rng, int(n_boot), block_rev)
    var = sim.err_p**2 + s_meas**2
    chi2 = _chi2(sim.p, p_meas, var)  # (A, C)
    noise = rng.standard_normal((int(n_boot), sim.p.shape[-1])) * s_meas
    boot_chi2 = _chi2(sim.boot_p, (p_meas + noise)[:, None, None, :], var).reshape(int(n_boot), -1)
    best = int(np.argmin(chi2.ravel()))
    freq, region = bootstrap_region(boot_chi2, best, level)

    n_a, n_c = chi2.shape
    col = "a_agg_deg" if first.comotion == "angle" else "rigid_tol"
    grid = _grid_table(first, col, chi2, best, np.abs(sim.p - p_meas).max(axis=-1), freq, region,
                       chi2_law.ppf(level, n_fit) if n_fit else 0.0)
    a_best, c_best = np.unravel_index(best, (n_a, n_c))
    inside = grid["in_region"].to_numpy()
    constraint = {"c_agg": _describe(first.c_agg, np.isin(first.c_agg, grid.c_agg[inside])),
                  col: _describe(first.comotion_values, np.isin(first.comotion_values, grid[col][inside]))}
    chi2_min = float(chi2.ravel()[best])
    p_value = float(chi2_law.sf(chi2_min, dof))
    at_best = SimulatedMean(*(x[a_best, c_best] for x in (sim.p, sim.err_p, sim.f, sim.err_f)), boot_p=None)
    settings = {
        "runs": [str(getattr(r, "path", r)) if not isinstance(r, (list, tuple, SizeClassGrid)) else type(r).__name__
                 for r in runs],
        "n_frames": [int(g.volumes.shape[0]) for g in grids], "window_rev": list(window), "measure": first.measure,
        "comotion": first.comotion, "cohesion": cohesion, "n_boot": int(n_boot), "block_rev": float(block_rev),
        "level": float(level), "seed": seed, "measured": measured.source, "measured_error": measured_error,
        "edges_compared": int(used.sum()), "below_first_class": float(at_best.f[0]),
        "above_last_class": float(at_best.f[-1]),
    }
    return Calibration(grid=grid, best={"c_agg": float(first.c_agg[c_best]), col: float(first.comotion_values[a_best]),
                                        "chi2": chi2_min},
                       constraint=constraint, distributions=_distributions(measured, used, at_best, measured_error),
                       chi2_min=chi2_min, dof=dof, p_value=p_value, poor_fit=p_value < POOR_FIT_P,
                       settings=settings)


def _chi2(p_sim, p_ref, var):
    """χ² over the last axis; an edge without any error counts 0 where the two agree, else inf."""
    d2 = (p_sim - p_ref) ** 2
    with np.errstate(divide="ignore", invalid="ignore"):
        terms = np.where(var > 0, d2 / var, np.where(d2 > 0, np.inf, 0.0))
    return terms.sum(axis=-1)


def _grid_table(first, col, chi2, best, max_dpassing, freq, region, delta_limit) -> pd.DataFrame:
    """One row per grid point: thresholds, χ² and Δχ², the largest |ΔP|, the bootstrap's votes,
    the bootstrap region and the Δχ² region."""
    n_a, n_c = chi2.shape
    a_idx, c_idx = np.unravel_index(np.arange(n_a * n_c), (n_a, n_c))
    chi2_flat = chi2.ravel()
    delta = chi2_flat - chi2_flat[best]
    return pd.DataFrame({
        "c_agg": first.c_agg[c_idx], col: first.comotion_values[a_idx], "chi2": chi2_flat, "delta_chi2": delta,
        "max_abs_dpassing": max_dpassing.ravel(), "boot_frequency": freq, "in_region": region,
        "in_chi2_region": delta <= delta_limit,
    })


def _distributions(measured, used, at_best, measured_error) -> pd.DataFrame:
    """The measured distribution beside the best point's, per class and cumulative, with errors."""
    k = measured.n_classes
    dist = measured.table().rename(columns={"mass_fraction": "measured_fraction", "passing_upper": "measured_passing"})
    sigma_all = measured.sigma if measured.sigma is not None else np.full(k + 1, measured_error)
    dist["measured_sigma"] = sigma_all[1:]
    dist["simulated_fraction"] = at_best.f[1:k + 1]
    dist["simulated_fraction_error"] = at_best.err_f[1:k + 1]
    full_p = np.full(k + 1, np.nan)
    full_e = np.full(k + 1, np.nan)
    full_p[used] = at_best.p
    full_e[used] = at_best.err_p
    cum = np.cumsum(at_best.f)[:-1]  # passing every edge, the unused ones included
    full_p[~used] = cum[~used]
    dist["simulated_passing"] = full_p[1:]
    dist["simulated_passing_error"] = full_e[1:]
    return dist
