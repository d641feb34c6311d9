"""The per-frame granulation statistics: one registry read by stats, sensitivity, cg, study,
confinement, the figures and the command line.

Each :class:`Metric` is a column of :func:`granalytics.frame_stats` with its label (for axes and
tables), the paper's figure that shows it, the format of its printed values, whether it is a
*headline* metric (compared across CG levels, threshold grids, methods and parameter studies) and
how it is computed from a frame's granule counts (:class:`GranuleCounts`): the same function
serves one identification (:func:`~granalytics.frame_stats`) and a whole threshold grid at once
(:func:`~granalytics.sensitivity`, whose kernel counts granules at every threshold pair).

Adding a statistic is one :func:`register` call (or one line in :data:`METRICS`): every consumer
reads the registry when it runs, through the live name lists :data:`HEADLINE`, :data:`STEADY` and
:data:`BY_FIGURE`. ``tests/test_metrics.py`` registers a fourth headline metric and checks that
every table, figure and printed column carries it.
"""

from __future__ import annotations

import contextlib
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Callable

import numpy as np

from granalytics.base.validation import Instance, validate_params

__all__ = ["Metric", "GranuleCounts", "METRICS", "HEADLINE", "STEADY", "BY_FIGURE", "register", "unregister",
           "registered", "metric_values"]


@dataclass(frozen=True)
class GranuleCounts:
    """What a frame's granules amount to, for one identification or (as arrays) for every
    threshold pair of a grid.

    Attributes
    ----------
    n_granules : int or array
        Granules G.
    n_in_granules : int or array
        Particles in granules.
    granule_volume_m3 : float or array
        Total volume of the particles in granules [m³].
    n_particles : int
        Particles in the frame.
    n_initial : int
        The run's initial particle count (``meta.n_particles``; the frame's count without metadata).
    mean_particle_volume_m3 : float
        Mean particle volume of the frame [m³].
    """

    n_granules: object
    n_in_granules: object
    granule_volume_m3: object
    n_particles: int
    n_initial: int
    mean_particle_volume_m3: float


def _per_granule(total, counts):
    """``total / G``, NaN where there is no granule (scalars and arrays alike)."""
    g = np.asarray(counts.n_granules, dtype=float)
    with np.errstate(invalid="ignore", divide="ignore"):
        value = np.where(g > 0, np.asarray(total, dtype=float) / np.maximum(g, 1), np.nan)
    return value[()] if value.ndim == 0 else value


@dataclass(frozen=True)
class Metric:
    """One per-frame statistic.

    Attributes
    ----------
    name : str
        Column of :func:`granalytics.frame_stats`.
    label : str
        Axis / table label.
    figure : str
        The paper's figure that shows it ("" if none).
    fmt : str
        Format of a printed value (``format(value, fmt)``).
    headline : bool
        Compared across CG levels, threshold grids, methods and parameter studies.
    value : callable
        ``value(counts: GranuleCounts) -> float or array``: the metric from a frame's granule
        counts, element-wise on arrays.
    title : str
        What a figure of it is about ("mean granule volume"); default the label.
    order : int
        Position among the headline metrics (yield first, as the paper reports them).
    figure_key : str
        The key of its figure among a CG comparison's figures (file name stem); default the name.
    log_scale : bool
        Drawn on a logarithmic axis where it spans decades (the mean granule volume over a
        threshold grid).
    """

    name: str
    label: str
    figure: str = ""
    fmt: str = ".4g"
    headline: bool = False
    value: Callable = None
    title: str = ""
    order: int = 100
    figure_key: str = ""
    log_scale: bool = False

    def __post_init__(self):
        if not callable(self.value):
            raise TypeError(f"metric {self.name!r}: value must be a function of GranuleCounts")
        if not self.figure_key:
            object.__setattr__(self, "figure_key", self.name)

    @property
    def what(self) -> str:
        """The title, or the label where there is none."""
        return self.title or self.label


#: the registry, in the order of steady-state tables
METRICS: dict = {m.name: m for m in (
    Metric("n_granules_norm", "N_g / N", "Fig 4", ".4f", headline=True, order=2, title="number of granules",
           figure_key="fig4_granule_number",
           value=lambda c: np.asarray(c.n_granules) / c.n_initial),
    Metric("mean_volume_norm", "⟨V_g⟩ / V_p", "Fig 3", ".3g", headline=True, order=1, title="mean granule volume",
           figure_key="fig3_mean_volume", log_scale=True,
           value=lambda c: _per_granule(c.granule_volume_m3, c) / c.mean_particle_volume_m3),
    Metric("yield_fraction", "yield", "Fig 6", ".3f", headline=True, order=0, title="granulation yield",
           figure_key="fig6_yield",
           value=lambda c: np.asarray(c.n_in_granules) / c.n_particles),
    Metric("mean_granule_size", "particles per granule", "", ".3g",
           value=lambda c: _per_granule(c.n_in_granules, c)),
)}


class _Names(Sequence):
    """A live, read-only list of metric names, recomputed from :data:`METRICS` at every use (so a
    metric registered later is carried by every consumer that holds the list)."""

    def __init__(self, select, doc):
        self._select = select
        self.__doc__ = doc

    def _names(self) -> tuple:
        return tuple(self._select(METRICS))

    def __getitem__(self, index):
        return self._names()[index]

    def __len__(self):
        return len(self._names())

    def __iter__(self):
        return iter(self._names())

    def __contains__(self, name):
        return name in self._names()

    def __eq__(self, other):
        return self._names() == (tuple(other) if isinstance(other, (Sequence, _Names)) else other)

    def __hash__(self):
        return hash(self._names())

    def __repr__(self):
        return repr(self._names())


#: the headline metrics, yield first (as the paper reports them)
HEADLINE = _Names(lambda ms: sorted((n for n, m in ms.items() if m.headline), key=lambda n: ms[n].order),
                  "the headline metrics, yield first")
#: the metrics of a steady-state table (:func:`granalytics.steady_state`'s default)
STEADY = _Names(lambda ms: list(ms), "the metrics of a steady-state table")
#: the headline metrics in the order of the paper's figures (Figs 3, 4, 6; others after)
BY_FIGURE = _Names(lambda ms: sorted((n for n, m in ms.items() if m.headline),
                                     key=lambda n: (ms[n].figure == "", ms[n].figure, ms[n].order)),
                   "the headline metrics in the order of the paper's figures")


def metric_values(counts: GranuleCounts, names=STEADY) -> dict:
    """``{name: value}`` of the registered metrics ``names`` for ``counts``."""
    return {name: METRICS[name].value(counts) for name in names}


@validate_params({"metric": [Instance(Metric)]})
def register(metric: Metric) -> None:
    """Add ``metric`` to the registry (its name must be new)."""
    if metric.name in METRICS:
        raise ValueError(f"register: a metric named {metric.name!r} exists")
    METRICS[metric.name] = metric


def unregister(name: str) -> None:
    """Remove the metric ``name`` from the registry."""
    del METRICS[name]


@contextlib.contextmanager
def registered(metric: Metric):
    """``metric`` registered for the duration of the block (a scratch registry, for tests and
    one-off studies)."""
    register(metric)
    try:
        yield metric
    finally:
        unregister(metric.name)
