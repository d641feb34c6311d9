"""Granule size distributions in sieve classes: a measured sieve analysis read from a file, and the
virtual sieving of simulated granules into the same classes, at one threshold pair or over a whole
threshold grid in one pass.

Sizes (docs/calibration.md):

- a granule's sieve size is, by ``measure``, ``"volume"``: the diameter of the sphere of its solid
  volume, d_V = (6V/π)^(1/3); or ``"width"``: its second-largest principal extent (the width a
  square aperture sees; the measure of :class:`~granalytics.VirtualSieve`);
- a free particle (not in a granule) is sieved on its own, as a grain of its own diameter; in a
  coarse-grained run, of its original-system diameter 2R/α;
- a granule of CG particles is sieved at its own size: a CG particle stands for α³ original
  particles of the same total solid volume, so a granule of n CG particles stands for a granule
  of α³·n original particles with the same solid volume, d_V and (to the resolution of the CG
  particles) the same extents;
- mass = solid volume × the run's density, so mass fractions are solid-volume fractions for one
  material.

A grain passes an aperture when its size is smaller than the aperture; it is counted in the class
[lower, upper) that holds its size.
"""

from __future__ import annotations

import csv
import math
import os
from dataclasses import dataclass
from numbers import Integral, Real

import numpy as np
import pandas as pd

from granalytics.analysis.frames import map_frames
from granalytics.base.errors import ParameterError
from granalytics.base.files import regular_input
from granalytics.identification import kernels as _kernels
from granalytics.identification.cohesion import DEFAULT_COHESION
from granalytics.analysis.sensitivity import SWEEP_CONSTRAINTS, threshold_grid
from granalytics.identification.contacts import DEFAULT_COMOTION, DEFAULT_RIGID_SCALE, comotion_mask, contact_strength
from granalytics.base.validation import FLAG, PATH, Array, Instance, Interval, Options, validate_params
from granalytics.core.snapshot import SNAPSHOT

__all__ = ["MeasuredDistribution", "read_sieve_csv", "SIEVE_MEASURES", "SUM_TOLERANCE", "sieve_classes", "grid_measurement",
           "SieveGrid", "sieve_grid"]

#: the sieve-size measures: name -> the kernel's code
SIEVE_MEASURES = {"volume": 0, "width": 1}
#: how far from 1 the mass fractions of a measured distribution may sum (then they are rescaled to 1)
SUM_TOLERANCE = 0.01
#: the constraints of a sieve-size measure and of a sum tolerance
_MEASURE, _TOLERANCE = Options(tuple(SIEVE_MEASURES)), Interval(Real, 0, None)

_CLASS_FIELDS = ("lower_m", "upper_m", "mass_fraction")
_PASSING_FIELDS = ("aperture_m", "passing_fraction")


@dataclass(frozen=True)
class MeasuredDistribution:
    """A measured size distribution in sieve classes.

    Attributes
    ----------
    edges_m : (K+1,) float array [m]
        Class boundaries, ascending: class k is [edges_m[k], edges_m[k+1]); the first may be 0
        (the pan) and the last ``inf`` (retained on the top sieve).
    fractions : (K,) float array
        Mass fraction per class, summing to 1.
    sigma : (K+1,) float array or None
        Standard error of the cumulative mass fraction passing at each edge (mass fraction), when
        the file gives one.
    source : str
        Where it came from (a file's path, or a description).
    """

    edges_m: np.ndarray
    fractions: np.ndarray
    sigma: np.ndarray | None = None
    source: str = "measured"

    @property
    def n_classes(self) -> int:
        """Number of classes K."""
        return int(self.fractions.size)

    @property
    def passing(self) -> np.ndarray:
        """Cumulative mass fraction passing (smaller than) each edge, (K+1,)."""
        return np.r_[0.0, np.cumsum(self.fractions)]

    def table(self) -> pd.DataFrame:
        """One row per class: ``lower_m``, ``upper_m`` [m], ``mass_fraction``, ``passing_upper``
        (cumulative fraction passing the upper edge)."""
        return pd.DataFrame({"lower_m": self.edges_m[:-1], "upper_m": self.edges_m[1:], "mass_fraction": self.fractions,
                             "passing_upper": self.passing[1:]})

    @classmethod
    @validate_params({"lower_m": [Array(ndim=1)], "upper_m": [Array(ndim=1)], "mass_fraction": [Array(ndim=1)],
                      "sigma": [Array(ndim=1), None], "tolerance": [_TOLERANCE]})
    def from_classes(cls, lower_m, upper_m, mass_fraction, sigma=None, source="measured",
                     tolerance=SUM_TOLERANCE) -> "MeasuredDistribution":
        """From class bounds [m] and mass fractions (validated as :func:`read_sieve_csv` does; rows
        are counted from 1)."""
        rows = [{"lower_m": lo, "upper_m": hi, "mass_fraction": m} for lo, hi, m in zip(lower_m, upper_m, mass_fraction)]
        return _from_class_rows(source, [(k + 1, row) for k, row in enumerate(rows)], tolerance,
                                None if sigma is None else np.asarray(sigma, float))


def _bad(path, row, field, value, why) -> ParameterError:
    where = f"{path}: row {row}" + (f", field {field}" if field else "")
    return ParameterError(f"{where}: {why}" + ("" if value is None else f" (got {value!r})"))


def _number(path, row, field, text, *, allow_inf=False) -> float:
    try:
        value = float(text)
    except (TypeError, ValueError):
        raise _bad(path, row, field, text, "not a number") from None
    if math.isnan(value) or (math.isinf(value) and not (allow_inf and value > 0)):
        raise _bad(path, row, field, text, "must be a finite number" + (" (or inf)" if allow_inf else ""))
    if value < 0:
        raise _bad(path, row, field, text, "must not be negative")
    return value


#: class edges [m] (:func:`_edges` checks the rest: two or more, ascending, >= 0)
_EDGES = [Array(ndim=1), Instance(MeasuredDistribution)]


@validate_params({"path": [PATH], "tolerance": [_TOLERANCE]})
def read_sieve_csv(path, tolerance=SUM_TOLERANCE) -> MeasuredDistribution:
    """Read a measured sieve analysis from a CSV file.

    Two forms, told apart by the header (lines starting with ``#`` are comments):

    - classes: ``lower_m,upper_m,mass_fraction`` — one row per sieve class, apertures in metres
      (``upper_m`` of the last class may be ``inf``), mass fractions summing to 1;
    - cumulative: ``aperture_m,passing_fraction`` — the cumulative mass fraction passing each
      aperture, apertures ascending; the classes are [0, a₁), [a₁, a₂), …, and, when the last
      value is below 1, [a_K, ∞) holding the rest.

    An optional last column ``sigma`` gives the standard error of the cumulative fraction passing
    each class's upper edge (or each aperture).

    Parameters
    ----------
    path : str or path-like
    tolerance : float, default 0.01
        The fractions (classes form) or the last passing value (cumulative form, when it is the
        whole) may differ from 1 by this much; they are then rescaled to sum to 1.

    Raises
    ------
    ParameterError
        One line naming the file, the row (counted from 1, the header being row 0 of the data) and
        the field and value: a value that is not a number, negative or NaN; fractions that do not
        sum to 1 within ``tolerance``; classes that are not sorted, overlap or leave a gap; a
        decreasing cumulative fraction; fewer than two classes.
    """
    path = os.fspath(path)
    regular_input(path)  # a FIFO would block for ever
    if os.path.getsize(path) > MAX_SIEVE_BYTES:
        raise ParameterError(f"{path}: {os.path.getsize(path) / 1e6:.3g} MB is not a sieve analysis (a few dozen "
                             f"classes; at most {MAX_SIEVE_BYTES / 1e6:g} MB are read)")
    try:
        with open(path, newline="") as handle:
            lines = [line for line in handle if line.strip() and not line.lstrip().startswith("#")]
    except OSError as exc:
        raise ParameterError(f"{path}: cannot read the measured distribution ({exc.strerror or exc})") from None
    except UnicodeDecodeError:
        raise ParameterError(f"{path}: not a text (CSV) file") from None
    if not lines:
        raise ParameterError(f"{path}: empty (expected a header lower_m,upper_m,mass_fraction or "
                             "aperture_m,passing_fraction)")
    reader = csv.reader(lines)
    header = [h.strip() for h in next(reader)]
    if len(set(header)) != len(header):
        raise ParameterError(f"{path}: header {','.join(header)!r} names a column twice")
    base = [h for h in header if h != "sigma"]
    if tuple(base) not in (_CLASS_FIELDS, _PASSING_FIELDS) or header[: len(base)] != base:
        raise ParameterError(f"{path}: header {','.join(header)!r}: expected lower_m,upper_m,mass_fraction[,sigma] "
                             "or aperture_m,passing_fraction[,sigma]")
    rows = []
    for k, values in enumerate(reader, start=1):
        if len(values) != len(header):
            raise _bad(path, k, None, ",".join(values), f"expected {len(header)} fields ({','.join(header)})")
        rows.append((k, dict(zip(header, (v.strip() for v in values)))))
    sigma = None
    if "sigma" in header:
        sigma = np.array([_number(path, k, "sigma", row["sigma"]) for k, row in rows])
        small = np.flatnonzero(~(sigma >= MIN_SIGMA))
        if small.size:
            k = rows[small[0]][0]
            raise _bad(path, k, "sigma", rows[small[0]][1]["sigma"],
                       f"a standard error of a fraction must be >= {MIN_SIGMA:g} (typically 0.005-0.05); 0 would "
                       "weigh that class infinitely")
    measured = (_from_class_rows if tuple(base) == _CLASS_FIELDS else _from_passing_rows)(path, rows, tolerance, sigma)
    edges = measured.edges_m[np.isfinite(measured.edges_m)]
    if edges.size and edges.max() > MAX_APERTURE_M:
        column = "upper_m" if tuple(base) == _CLASS_FIELDS else "aperture_m"
        largest = float(edges.max())
        unit = "micrometres" if largest > 100 else "millimetres"
        raise ParameterError(f"{path}: column {column}: an aperture of {largest:g} m is larger than any granulator's "
                             f"granule (at most {MAX_APERTURE_M:g} m is read as metres): the file is likely in {unit}; "
                             "give apertures in metres")
    return measured


#: the largest sieve file read [bytes] (a sieve analysis has a few dozen classes)
MAX_SIEVE_BYTES = 1_000_000

#: the largest sieve aperture read as metres [m]: a larger one is in another unit
MAX_APERTURE_M = 0.1

#: the smallest standard error of a measured fraction accepted (0 weighs a class infinitely)
MIN_SIGMA = 1e-6


def _check_count(path, rows):
    if len(rows) < 2:
        raise ParameterError(f"{path}: {len(rows)} class(es); a size distribution needs at least two")


def _from_class_rows(path, rows, tolerance, sigma):
    _check_count(path, rows)
    lower, upper, frac = [], [], []
    for k, row in rows:
        lo = _number(path, k, "lower_m", row["lower_m"])
        hi = _number(path, k, "upper_m", row["upper_m"], allow_inf=k == rows[-1][0])
        m = _number(path, k, "mass_fraction", row["mass_fraction"])
        if hi <= lo:
            raise _bad(path, k, "upper_m", row["upper_m"], f"must be above lower_m {lo:g}")
        if lower:
            if lo < lower[-1]:
                raise _bad(path, k, "lower_m", row["lower_m"], f"classes not sorted: below the previous class's "
                                                               f"lower_m {lower[-1]:g}")
            if lo < upper[-1]:
                raise _bad(path, k, "lower_m", row["lower_m"], f"overlaps the previous class [{lower[-1]:g}, "
                                                               f"{upper[-1]:g})")
            if lo > upper[-1]:
                raise _bad(path, k, "lower_m", row["lower_m"], f"a gap after the previous class's upper_m "
                                                               f"{upper[-1]:g} (sieve classes are contiguous)")
        lower.append(lo)
        upper.append(hi)
        frac.append(m)
    frac = np.array(frac)
    total = frac.sum()
    if abs(total - 1) > tolerance:
        raise ParameterError(f"{path}: field mass_fraction: the fractions sum to {total:.6g}, not 1 within "
                             f"{tolerance:g}")
    if sigma is not None:
        sigma = np.r_[0.0, sigma]  # nothing passes the first class's lower edge... by definition
    return MeasuredDistribution(np.array([lower[0], *upper]), frac / total, sigma, str(path))


def _from_passing_rows(path, rows, tolerance, sigma):
    _check_count(path, rows)
    apertures, passing = [], []
    for k, row in rows:
        a = _number(path, k, "aperture_m", row["aperture_m"])
        p = _number(path, k, "passing_fraction", row["passing_fraction"])
        if a == 0:
            raise _bad(path, k, "aperture_m", row["aperture_m"], "must be above 0")
        if apertures and a <= apertures[-1]:
            raise _bad(path, k, "aperture_m", row["aperture_m"], f"apertures not sorted ascending (previous "
                                                                 f"{apertures[-1]:g})")
        if apertures and p < passing[-1]:
            raise _bad(path, k, "passing_fraction", row["passing_fraction"], f"decreases (previous {passing[-1]:g}); "
                                                                             "the mass passing is cumulative")
        if p > 1 + tolerance:
            raise _bad(path, k, "passing_fraction", row["passing_fraction"], f"above 1 (by more than {tolerance:g})")
        apertures.append(a)
        passing.append(p)
    passing = np.array(passing)
    edges = [0.0, *apertures]
    if passing[-1] >= 1 - tolerance:  # the last aperture passes everything
        passing = passing / passing[-1]
    else:
        edges.append(math.inf)
        passing = np.r_[passing, 1.0]
        if sigma is not None:
            sigma = np.r_[sigma, 0.0]
    if sigma is not None:
        sigma = np.r_[0.0, sigma]
    return MeasuredDistribution(np.array(edges), np.diff(np.r_[0.0, passing]), sigma, str(path))


def _alpha(snapshot) -> float:
    alpha = getattr(snapshot.meta, "alpha", 1.0) if snapshot.meta is not None else 1.0
    return float(alpha) if alpha and alpha > 0 else 1.0


def _free_size(snapshot) -> np.ndarray:
    """A free particle's sieve size [m]: its original-system diameter 2R/α."""
    return 2.0 * snapshot.radius / _alpha(snapshot)


def _edges(edges_m) -> np.ndarray:
    edges = np.asarray(getattr(edges_m, "edges_m", edges_m), dtype=float)
    if edges.size < 2 or np.isnan(edges).any() or (np.diff(edges) <= 0).any() or (edges < 0).any():
        raise ParameterError(f"edges_m must be at least two ascending sizes >= 0 in metres, got {edges.tolist()[:8]}")
    return edges


@validate_params({"snapshot": [SNAPSHOT], "labels": [Array(ndim=1, dtype=Integral)], "edges_m": _EDGES,
                  "measure": [_MEASURE]})
def sieve_classes(snapshot, labels, edges_m, measure="volume") -> np.ndarray:
    """Virtual sieve analysis of one identification: mass fraction per class.

    Parameters
    ----------
    snapshot : Snapshot
    labels : (N,) int array
        Granule of every particle (−1 free), as :attr:`IdentificationResult.labels`.
    edges_m : (K+1,) array [m] or MeasuredDistribution
        Class boundaries.
    measure : {"volume", "width"}
        The granule's sieve size (module docstring).

    Returns
    -------
    (K+2,) float array
        Mass fraction below ``edges_m[0]``, in each class, and at or above ``edges_m[-1]``.
    """
    edges, code = _edges(edges_m), SIEVE_MEASURES[measure]
    labels = np.asarray(labels, dtype=np.int64)
    n_groups = int(labels.max()) + 1 if labels.size else 0
    hist = _kernels.class_volumes(labels, n_groups, np.ones(n_groups, dtype=np.bool_), np.zeros(n_groups),
                                  snapshot.particle_volume, _free_size(snapshot), snapshot.position, snapshot.radius,
                                  edges, code)
    return hist / hist.sum()


@dataclass
class SieveGrid:
    """Per-frame size distributions over a threshold grid (:func:`sieve_grid`).

    Attributes
    ----------
    volumes : (F, A, C, K+2) float array [m³]
        Solid volume per bin (below the first edge, each class, above the last) in every frame, at
        every co-motion threshold and C_agg (ascending).
    c_agg, comotion_values : (C,), (A,) float arrays, ascending
    comotion : {"angle", "rigid"}
        ``comotion_values`` are A_agg [deg] or rigid tolerances.
    edges_m : (K+1,) [m]
    frames, revolutions, time_s : (F,) arrays
    density : float [kg/m³]
    measure : str
    """

    volumes: np.ndarray
    c_agg: np.ndarray
    comotion_values: np.ndarray
    comotion: str
    edges_m: np.ndarray
    frames: np.ndarray
    revolutions: np.ndarray
    time_s: np.ndarray
    density: float
    measure: str

    @property
    def fractions(self) -> np.ndarray:
        """Mass fraction per bin, (F, A, C, K+2)."""
        return self.volumes / self.volumes.sum(axis=-1, keepdims=True)

    @property
    def passing(self) -> np.ndarray:
        """Cumulative mass fraction passing each edge, (F, A, C, K+1)."""
        return np.cumsum(self.fractions, axis=-1)[..., :-1]


def _frame_grid(snapshot, c_desc, thresholds, edges, code, radius, gamma, cohesion, comotion, rigid_scale, min_size):
    f = contact_strength(snapshot, radius, gamma, cohesion)
    volume = snapshot.particle_volume
    free = _free_size(snapshot)
    out = np.empty((len(thresholds), c_desc.size, edges.size + 1))
    for k, a in enumerate(thresholds):
        passes = comotion_mask(snapshot, comotion, **({"a_agg_deg": a} if comotion == "angle"
                                                      else {"rigid_tol": a, "rigid_scale": rigid_scale}))
        out[k] = _kernels.threshold_sweep_classes(snapshot.contact_i, snapshot.contact_j, f, passes, volume, free,
                                                  snapshot.position, snapshot.radius, c_desc, edges, min_size, code)[::-1]
    return out, snapshot.revolutions, snapshot.time, (snapshot.meta.density if snapshot.meta is not None else math.nan)


@validate_params({**SWEEP_CONSTRAINTS, "edges_m": _EDGES, "measure": [_MEASURE], "progress": [FLAG]})
def sieve_grid(frames, edges_m, c_agg, a_agg_deg=None, *, measure="volume", radius="pair", surface_tension=None,
               cohesion=DEFAULT_COHESION, comotion=DEFAULT_COMOTION, rigid_tol=None, rigid_scale=DEFAULT_RIGID_SCALE,
               min_size=2, jobs=1, scheduler=None, progress=False) -> SieveGrid:
    """The virtual sieve analysis of GNA's granules in every frame at every threshold pair, the C_agg
    axis in one pass per frame and co-motion threshold (the merge of :func:`granalytics.sensitivity`).

    Parameters
    ----------
    frames : Run, RunSlice or sequence of Snapshot
    edges_m : (K+1,) array [m] or MeasuredDistribution
        Class boundaries (original-system sizes).
    c_agg : sequence of float
        Cohesion thresholds (≥ 0).
    a_agg_deg : sequence of float
        Angle thresholds [deg] (``comotion="angle"``).
    measure : {"volume", "width"}
        The granule's sieve size (module docstring).
    rigid_tol : sequence of float
        Tolerances of the rigid test (``comotion="rigid"``).
    radius, surface_tension, cohesion, comotion, rigid_scale, min_size, jobs, scheduler, progress :
        As for :func:`granalytics.sensitivity`.

    Returns
    -------
    SieveGrid
        Equal, bin by bin, to :func:`sieve_classes` of the GNA identification at each pair.
    """
    edges, code = _edges(edges_m), SIEVE_MEASURES[measure]
    c_desc, a_list = threshold_grid(c_agg, a_agg_deg, rigid_tol, comotion, "sieve_grid")
    c_asc = c_desc[::-1].copy()
    frame_ids, results = map_frames(
        frames, lambda s: _frame_grid(s, c_desc, a_list, edges, code, radius, surface_tension, cohesion, comotion,
                                      rigid_scale, int(min_size)),
        progress=progress, desc="size classes", jobs=jobs, scheduler=scheduler)
    return SieveGrid(volumes=np.stack([r[0] for r in results]), c_agg=c_asc, comotion_values=np.array(a_list),
                     comotion=comotion, edges_m=edges, frames=np.asarray(frame_ids),
                     revolutions=np.array([r[1] for r in results]), time_s=np.array([r[2] for r in results]),
                     density=float(results[0][3]), measure=measure)


@validate_params({"grid": [Instance(SieveGrid)], "c_agg": [Interval(Real)], "threshold": [Interval(Real)],
                  "noise": [Interval(Real, 0, None)], "seed": [Interval(Integral, 0, None)], "source": [Instance(str), None]})
def grid_measurement(grid: SieveGrid, c_agg, threshold, *, noise=0.0, seed=0, source=None) -> MeasuredDistribution:
    """A "measured" distribution made from a simulation: the mean over ``grid``'s frames at one of its
    grid points, with optional noise (for tests of a calibration and for synthetic examples).

    Parameters
    ----------
    grid : SieveGrid
        Its classes must hold all the mass (first edge 0, last edge ``inf``).
    c_agg, threshold : float
        A grid point: C_agg and A_agg [deg] (or the rigid tolerance).
    noise : float, default 0
        Standard deviation of a normal error added to the cumulative mass fraction passing each
        inner edge (mass fraction); the result is made non-decreasing and kept in [0, 1]. It is
        also the distribution's ``sigma`` when > 0.
    seed : int
    """
    ci = np.flatnonzero(np.isclose(grid.c_agg, c_agg, rtol=0, atol=1e-12))
    ai = np.flatnonzero(np.isclose(grid.comotion_values, threshold, rtol=0, atol=1e-12))
    if ci.size != 1 or ai.size != 1:
        raise ParameterError(f"({c_agg:g}, {threshold:g}) is not a point of the grid")
    frac = grid.fractions[:, ai[0], ci[0]].mean(axis=0)
    if frac[0] > 0 or frac[-1] > 0:
        raise ParameterError("the grid's classes do not hold all the mass (make the first edge 0 and the last inf)")
    passing = np.cumsum(frac[1:-1])[:-1]
    if noise > 0:
        passing = passing + np.random.default_rng(seed).normal(0.0, noise, passing.size)
        passing = np.clip(np.maximum.accumulate(passing), 0.0, 1.0)
    edges = grid.edges_m
    fractions = np.diff(np.r_[0.0, passing, 1.0])
    sigma = np.r_[0.0, np.full(passing.size, noise), 0.0] if noise > 0 else None
    name = source or f"simulated at C_agg = {c_agg:g}, {threshold:g} (noise {noise:g})"
    return MeasuredDistribution(edges.copy(), fractions, sigma, name)
