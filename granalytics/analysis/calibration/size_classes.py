"""Simulated granules sorted by size into the classes of a sieve analysis, at one threshold pair
(:func:`size_class_fractions`) or over a whole threshold grid in one pass per frame
(:func:`size_class_grid`, :class:`SizeClassGrid`), and a "measured" distribution made from such a
grid (:func:`grid_measurement`).

Sizes (docs/calibration.md):

- a granule's size is, by ``measure``, ``"volume"``: the diameter of the sphere of its solid
  volume, d_V = (6V/π)^(1/3); or ``"width"``: its second-largest principal extent (the width a
  square aperture sees; the measure of :class:`~granalytics.VirtualSieve`);
- a free particle (not in a granule) is classified on its own, as a grain of its own diameter; in a
  coarse-grained run, of its original-system diameter 2R/α;
- a granule of CG particles is classified at its own size: a CG particle stands for α³ original
  particles of the same total solid volume, so a granule of n CG particles stands for a granule
  of α³·n original particles with the same solid volume, d_V and (to the resolution of the CG
  particles) the same extents;
- mass = solid volume × the run's density, so mass fractions are solid-volume fractions for one
  material.

A grain passes an aperture when its size is smaller than the aperture; it is counted in the class
[lower, upper) that holds its size.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from numbers import Integral, Real

import numpy as np

from granalytics.analysis.calibration.measured import CLASS_EDGES, MeasuredDistribution
from granalytics.analysis.frames import map_frames
from granalytics.analysis.sensitivity import SWEEP_CONSTRAINTS, threshold_grid
from granalytics.base.errors import ParameterError
from granalytics.base.validation import FLAG, Array, Instance, Interval, Options, validate_params
from granalytics.core.snapshot import SNAPSHOT
from granalytics.identification import kernels as _kernels
from granalytics.identification.cohesion import DEFAULT_COHESION
from granalytics.identification.contacts import DEFAULT_COMOTION, DEFAULT_RIGID_SCALE, comotion_mask, contact_strength

__all__ = ["SIZE_MEASURES", "MEASURE", "size_class_fractions", "SizeClassGrid", "size_class_grid", "class_grid",
           "grid_measurement"]

#: the size measures: name -> the kernel's code
SIZE_MEASURES = {"volume": 0, "width": 1}
#: the constraint of a size measure
MEASURE = Options(tuple(SIZE_MEASURES))
#: the constraints of class edges [m]
_EDGES = [CLASS_EDGES, Instance(MeasuredDistribution)]


def _free_size(snapshot) -> np.ndarray:
    """A free particle's size [m]: its original-system diameter 2R/α."""
    return 2.0 * snapshot.radius / (snapshot.meta.alpha if snapshot.meta is not None else 1.0)


def _edge_array(edges_m) -> np.ndarray:
    """The class edges [m] of an array or a MeasuredDistribution, as floats."""
    return np.asarray(edges_m.edges_m if isinstance(edges_m, MeasuredDistribution) else edges_m, dtype=float)


@validate_params({"snapshot": [SNAPSHOT], "labels": [Array(ndim=1, dtype=Integral)], "edges_m": _EDGES,
                  "measure": [MEASURE]})
def size_class_fractions(snapshot, labels, edges_m, measure="volume") -> np.ndarray:
    """The size classes of one identification's granules and free particles: mass fraction per class.

    Parameters
    ----------
    snapshot : Snapshot
    labels : (N,) int array
        Granule of every particle (−1 free), as :attr:`IdentificationResult.labels`.
    edges_m : (K+1,) array [m] or MeasuredDistribution
        Class boundaries.
    measure : {"volume", "width"}
        The granule's size (module docstring).

    Returns
    -------
    (K+2,) float array
        Mass fraction below ``edges_m[0]``, in each class, and at or above ``edges_m[-1]``.
    """
    edges, code = _edge_array(edges_m), SIZE_MEASURES[measure]
    labels = np.asarray(labels, dtype=np.int64)
    n_groups = int(labels.max()) + 1 if labels.size else 0
    hist = _kernels.class_volumes(labels, n_groups, np.ones(n_groups, dtype=np.bool_), np.zeros(n_groups),
                                  snapshot.particle_volume, _free_size(snapshot), snapshot.position, snapshot.radius,
                                  edges, code)
    return hist / hist.sum()


@dataclass
class SizeClassGrid:
    """Per-frame size distributions over a threshold grid (:func:`size_class_grid`).

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


@validate_params({**SWEEP_CONSTRAINTS, "edges_m": _EDGES, "measure": [MEASURE], "progress": [FLAG]})
def size_class_grid(frames, edges_m, c_agg, a_agg_deg=None, *, measure="volume", radius="pair", surface_tension=None,
                    cohesion=DEFAULT_COHESION, comotion=DEFAULT_COMOTION, rigid_tol=None,
                    rigid_scale=DEFAULT_RIGID_SCALE, min_size=2, jobs=1, scheduler=None,
                    progress=False) -> SizeClassGrid:
    """The size classes of GNA's granules in every frame at every threshold pair, the C_agg axis in
    one pass per frame and co-motion threshold (the merge of :func:`granalytics.sensitivity`).

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
        The granule's size (module docstring).
    rigid_tol : sequence of float
        Tolerances of the rigid test (``comotion="rigid"``).
    radius, surface_tension, cohesion, comotion, rigid_scale, min_size, jobs, scheduler, progress :
        As for :func:`granalytics.sensitivity`.

    Returns
    -------
    SizeClassGrid
        Equal, bin by bin, to :func:`size_class_fractions` of the GNA identification at each pair.
    """
    c_desc, a_list = threshold_grid(c_agg, a_agg_deg, rigid_tol, comotion, "size_class_grid")
    return class_grid(frames, _edge_array(edges_m), c_desc, a_list, measure=measure, radius=radius,
                      surface_tension=surface_tension, cohesion=cohesion, comotion=comotion, rigid_scale=rigid_scale,
                      min_size=min_size, jobs=jobs, scheduler=scheduler, progress=progress)


def class_grid(frames, edges, c_desc, a_list, *, measure, radius, surface_tension, cohesion, comotion, rigid_scale,
               min_size, jobs, scheduler, progress) -> SizeClassGrid:
    """:func:`size_class_grid` of arguments its caller has checked: ``edges`` a float array [m],
    ``c_desc`` and ``a_list`` the grid of :func:`~granalytics.analysis.sensitivity.threshold_grid`."""
    code = SIZE_MEASURES[measure]
    frame_ids, results = map_frames(
        frames, lambda s: _frame_grid(s, c_desc, a_list, edges, code, radius, surface_tension, cohesion, comotion,
                                      rigid_scale, int(min_size)),
        progress=progress, desc="size classes", jobs=jobs, scheduler=scheduler)
    return SizeClassGrid(volumes=np.stack([r[0] for r in results]), c_agg=c_desc[::-1].copy(),
                         comotion_values=np.array(a_list), comotion=comotion, edges_m=edges,
                         frames=np.asarray(frame_ids), revolutions=np.array([r[1] for r in results]),
                         time_s=np.array([r[2] for r in results]), density=float(results[0][3]), measure=measure)


@validate_params({"grid": [Instance(SizeClassGrid)], "c_agg": [Interval(Real)], "threshold": [Interval(Real)],
                  "noise": [Interval(Real, 0, None)], "seed": [Interval(Integral, 0, None)], "source": [Instance(str), None]})
def grid_measurement(grid: SizeClassGrid, c_agg, threshold, *, noise=0.0, seed=0, source=None) -> MeasuredDistribution:
    """A "measured" distribution made from a simulation: the mean over ``grid``'s frames at one of its
    grid points, with optional noise (for tests of a calibration and for synthetic examples).

    Parameters
    ----------
    grid : SizeClassGrid
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
        raise ParameterError(f"grid_measurement: ({c_agg:g}, {threshold:g}) is not a point of the grid")
    frac = grid.fractions[:, ai[0], ci[0]].mean(axis=0)
    if frac[0] > 0 or frac[-1] > 0:
        raise ParameterError("grid_measurement: the grid's classes do not hold all the mass (make the first edge 0 "
                             "and the last inf)")
    passing = np.cumsum(frac[1:-1])[:-1]
    if noise > 0:
        passing = passing + np.random.default_rng(seed).normal(0.0, noise, passing.size)
        passing = np.clip(np.maximum.accumulate(passing), 0.0, 1.0)
    edges = grid.edges_m
    fractions = np.diff(np.r_[0.0, passing, 1.0])
    sigma = np.r_[0.0, np.full(passing.size, noise), 0.0] if noise > 0 else None
    name = source or f"simulated at C_agg = {c_agg:g}, {threshold:g} (noise {noise:g})"
    return MeasuredDistribution(edges.copy(), fractions, sigma, name)
