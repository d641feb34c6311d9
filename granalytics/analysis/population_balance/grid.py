"""The size grid of the population balance and distributions on it: integer pivots, every integer
up to where a geometric spacing exceeds one and geometric beyond (:func:`pbm_grid`); a DEM
frame's granules put on the grid by the fixed pivot technique (:func:`size_counts`,
:func:`project_counts`), which keeps both the number and the mass of every granule; the mean
size and yield of a distribution (:func:`distribution_summary`) and the Kolmogorov–Smirnov
distance of two (:func:`ks_distance`).

Sizes in primary particles; numbers of granules in the whole system.
"""

from __future__ import annotations

from numbers import Integral, Real

import numpy as np
import pandas as pd

from granalytics.base.errors import ParameterError
from granalytics.base.validation import Array, Interval, validate_params

#: the constraint of a ``grid`` of pivots (:func:`check_grid` checks the rest: increasing whole
#: numbers from 1)
GRID = Array(ndim=1, within=Interval(Real, 1, None))
#: the constraint of the ratio of successive pivots
RATIO = Interval(Real, 1, 10, closed="right")


@validate_params({"n_max": [Interval(Integral, 1, None)], "ratio": [RATIO]})
def pbm_grid(n_max, ratio=2 ** 0.25) -> np.ndarray:
    """Integer pivots from 1 to ``n_max``: every integer while the geometric spacing is below one
    particle, then successive pivots ``ratio`` apart (rounded to integers).

    Parameters
    ----------
    n_max : int
        Largest granule size [particles] (for a DEM: its number of particles).
    ratio : float, default 2**0.25
        Ratio of successive pivots in the geometric part, > 1.

    Returns
    -------
    (G,) int64 array
        Increasing pivots, starting at 1 (free particles) and ending at ``n_max``.
    """
    ratio = float(ratio)
    x = [1]
    while x[-1] < n_max:
        x.append(min(int(n_max), max(x[-1] + 1, int(round(x[-1] * ratio)))))
    return np.asarray(x, dtype=np.int64)


def check_grid(grid):
    """``grid`` (satisfying :data:`GRID`) as int64 pivots: at least two increasing whole numbers
    from 1 (free particles), else a :class:`ParameterError`."""
    x = np.asarray(grid)
    if x.size < 2 or (x != np.round(x)).any() or x[0] != 1 or (np.diff(x) <= 0).any():
        raise ParameterError(f"grid must be at least two increasing whole numbers starting at 1 (free particles), got "
                             f"{x.tolist()[:8]}{' …' if x.size > 8 else ''}")
    return x.astype(np.int64)


def pivot_weights(grid, v):
    """Fixed-pivot split of sizes ``v`` (1 <= v <= grid[-1]): lower pivot index, weight there, and
    the weight at the next pivot (number and mass kept)."""
    x = grid.astype(float)
    v = np.asarray(v, dtype=float)
    k = np.clip(np.searchsorted(x, v, side="right") - 1, 0, x.size - 1)
    upper = np.minimum(k + 1, x.size - 1)
    span = x[upper] - x[k]
    with np.errstate(divide="ignore", invalid="ignore"):
        a = np.where(span > 0, (x[upper] - v) / span, 1.0)
    a = np.where(v == x[k], 1.0, a)
    return k, a, upper


@validate_params({"counts": [Array(ndim=1, within=Interval(Real, 0, None))], "grid": [GRID]})
def project_counts(counts, grid) -> np.ndarray:
    """Numbers of granules by integer size, put on the pivots of ``grid`` (fixed pivot split).

    Parameters
    ----------
    counts : (S,) array
        ``counts[s - 1]`` is the number of granules of size s [particles], s = 1 (free particles)
        to S; non-negative and finite. Sizes above ``grid[-1]`` are refused.
    grid : (G,) int array
        Pivots (:func:`pbm_grid`).

    Returns
    -------
    (G,) float array
        Numbers at the pivots, with the same total number and total mass Σ s·counts.
    """
    grid = check_grid(grid)
    counts = np.asarray(counts, dtype=float)
    sizes = np.nonzero(counts)[0] + 1
    if sizes.size and sizes[-1] > grid[-1]:
        raise ParameterError(f"counts has granules of {sizes[-1]} particles, above the grid's largest pivot {grid[-1]}")
    k, a, upper = pivot_weights(grid, sizes)
    out = np.zeros(grid.size)
    np.add.at(out, k, a * counts[sizes - 1])
    np.add.at(out, upper, (1 - a) * counts[sizes - 1])
    return out


@validate_params({"granule_sizes": [Array(dtype=Integral)], "n_particles": [Interval(Integral, 1, None)]})
def size_counts(granule_sizes, n_particles) -> np.ndarray:
    """Numbers of granules by size of one frame, free particles counted as size 1.

    Parameters
    ----------
    granule_sizes : int array
        Particles in each granule of the frame (zeros, e.g. unused labels, are ignored).
    n_particles : int
        Particles in the frame; those in no granule are free.

    Returns
    -------
    (n_particles,) float array
        ``counts[s - 1]`` = number of granules of size s; ``counts[0]`` the free particles.
    """
    sizes = np.asarray(granule_sizes, dtype=np.int64).ravel()
    sizes = sizes[sizes > 0]
    n = int(n_particles)
    if sizes.sum() > n:
        raise ParameterError(f"size_counts: n_particles={n_particles!r} is smaller than the {int(sizes.sum())} particles "
                             "in granules")
    counts = np.bincount(sizes, minlength=n + 1)[1:].astype(float)
    counts[0] += n - sizes.sum()
    return counts


@validate_params({"numbers": [Array()], "grid": [Array(ndim=1)], "t_s": [Array(ndim=1), None],
                  "min_size": [Interval(Integral, 1, None)]})
def distribution_summary(numbers, grid, t_s=None, min_size=2) -> pd.DataFrame:
    """Number, mean size and yield of the granules of >= ``min_size`` particles of distributions on
    ``grid`` (rows of ``numbers``); see :meth:`PopulationBalance.summary`."""
    numbers = np.atleast_2d(np.asarray(numbers, dtype=float))
    x = np.asarray(grid, dtype=float)
    big = x >= min_size
    n = numbers[:, big].sum(axis=1)
    mass_g = numbers[:, big] @ x[big]
    mass = numbers @ x
    with np.errstate(divide="ignore", invalid="ignore"):
        mean = np.where(n > 0, mass_g / n, np.nan)
        yld = np.where(mass > 0, mass_g / mass, np.nan)
    out = pd.DataFrame({"n_granules": n, "mean_size": mean, "yield_fraction": yld,
                        "free": numbers[:, x == 1].sum(axis=1), "mass": mass})
    if t_s is not None:
        out.insert(0, "t_s", np.asarray(t_s, dtype=float))
    return out


@validate_params({"a": [Array(ndim=1)], "b": [Array(ndim=1)], "grid": [Array(ndim=1), None],
                  "min_size": [Interval(Integral, 1, None)]})
def ks_distance(a, b, grid=None, min_size=2) -> float:
    """Kolmogorov–Smirnov distance between two number distributions of granules on one grid.

    Parameters
    ----------
    a, b : (G,) arrays
        Numbers of granules at the pivots (e.g. a row of :attr:`PopulationBalance.numbers` and
        :func:`project_counts` of a DEM frame).
    grid : (G,) int array, optional
        The pivots; needed with ``min_size`` > 1.
    min_size : int, default 2
        Only pivots of at least this size (granules; free particles excluded).

    Returns
    -------
    float
        max |F_a − F_b| over the pivots, F the cumulative number fraction of granules; NaN when
        either has no granule. Exact for sizes up to the last pivot of the grid's all-integer part;
        above it both distributions are the fixed-pivot projections.
    """
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    if a.shape != b.shape:
        raise ParameterError(f"ks_distance: a and b must be of one length, got {a.size} and {b.size}")
    if grid is not None:
        keep = np.asarray(grid) >= min_size
        a, b = a[keep], b[keep]
    a = np.clip(a, 0, None)
    b = np.clip(b, 0, None)
    if a.sum() <= 0 or b.sum() <= 0:
        return float("nan")
    return float(np.max(np.abs(np.cumsum(a) / a.sum() - np.cumsum(b) / b.sum())))

