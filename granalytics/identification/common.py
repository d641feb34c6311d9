"""Pieces shared by the identification methods: the :class:`Identifier` base class (parameters
from the constructor, checked against their declared constraints when
:meth:`~Identifier.identify` runs, ``params()``, ``repr``), the constraints of C_agg and of the
granule size, and canonical labels. Per-contact quantities (γ, R, f = F_coh/(2πγR), co-motion)
and their constraints live in :mod:`granalytics.identification.contacts`, below this package."""

from __future__ import annotations

import functools
import inspect
from numbers import Integral, Real

import numpy as np

from granalytics.identification import kernels as _kernels
from granalytics.identification.contacts import A_AGG_DEG, RADIUS_MODE, co_moving, contact_strength, mean_radius, surface_tension
from granalytics.base.validation import Interval, validate, validate_params
from granalytics.core.snapshot import SNAPSHOT

#: the paper's thresholds, the defaults of every method that filters contacts by them (GNA, the
#: sieve over GNA granules, community detection): C_agg (F_coh ≥ C_agg·2πγR) and A_agg [deg]
PAPER_C_AGG = 0.6
PAPER_A_AGG_DEG = 20.0
#: the constraints (:mod:`granalytics.base.validation`) of C_agg, ≥ 0, and of the fewest particles of a granule, ≥ 2
C_AGG = Interval(Real, 0, None)
MIN_SIZE = Interval(Integral, 2, None)

__all__ = ["PAPER_C_AGG", "PAPER_A_AGG_DEG", "C_AGG", "MIN_SIZE", "A_AGG_DEG", "RADIUS_MODE", "Identifier", "co_moving",
           "contact_strength", "mean_radius", "surface_tension", "labels_from_clusters"]


class Identifier:
    """Base of every identification method (scikit-learn style).

    The contract of a method (checked for every registered method by ``tests/test_conformance.py``):

    - a class attribute ``method``, its name in :data:`granalytics.identification.METHODS`;
    - every constructor argument stored under the same attribute name, its constraints declared in
      the class attribute ``_parameter_constraints`` (name -> list of constraints,
      :mod:`granalytics.base.validation`) and checked when :meth:`identify` runs (``"custom"`` also
      parses its criterion string in the constructor);
    - a keyword argument ``cohesion`` (one of :data:`granalytics.COHESION_CONVENTIONS`), also for
      methods that do not use it: commands and :func:`granalytics.compare_methods` hand it to any method;
    - :meth:`identify` ``(snapshot)`` returning an :class:`~granalytics.IdentificationResult`.

    :meth:`params` reads the constructor's signature, so a new parameter needs no second list.
    """

    method = ""
    _parameter_constraints: dict = {}

    def __init_subclass__(cls, **kwargs):
        """Every method's :meth:`identify` refuses anything but a Snapshot, and parameters outside
        their constraints (one ParameterError, not an AttributeError from deep inside the method)."""
        super().__init_subclass__(**kwargs)
        if "identify" in cls.__dict__:
            cls.identify = _validated(cls.__dict__["identify"])

    def _validate_params(self) -> None:
        """Refuse a parameter outside its ``_parameter_constraints`` (ParameterError naming the class).
        Checked again only when a parameter was assigned another object since the last check: this
        runs for every frame (and more than once per frame through the methods' helpers)."""
        values = {name: getattr(self, name) for name in self._parameter_constraints}
        checked = self.__dict__.get("_checked_params")
        if checked is not None and checked.keys() == values.keys() and all(
                checked[name] is value for name, value in values.items()):
            return
        validate(type(self).__name__, self._parameter_constraints, values)
        self._checked_params = values

    def params(self) -> dict:
        """The constructor parameters, by name."""
        return {name: self._param_value(name) for name in _constructor_parameters(type(self))}

    def _param_value(self, name):
        return getattr(self, name)

    def identify(self, snapshot):  # pragma: no cover - every subclass implements it
        raise NotImplementedError

    def __repr__(self):
        args = ", ".join(f"{k}={v!r}" for k, v in self.params().items())
        return f"{type(self).__name__}({args})"


@functools.cache
def _constructor_parameters(cls) -> tuple:
    """The names of ``cls.__init__``'s parameters (read once per class: :meth:`Identifier.params`
    runs for every frame)."""
    return tuple(p for p in inspect.signature(cls.__init__).parameters if p != "self")


def _validated(identify):
    @validate_params({"snapshot": [SNAPSHOT]})
    @functools.wraps(identify)
    def validated(self, snapshot, *args, **kwargs):
        self._validate_params()
        return identify(self, snapshot, *args, **kwargs)

    return validated


def labels_from_clusters(cluster) -> tuple[np.ndarray, np.ndarray]:
    """Canonical labels and sizes from cluster ids in which −1 marks unclustered points."""
    cluster = np.asarray(cluster, dtype=np.int64)
    membership = cluster.copy()
    noise = np.flatnonzero(cluster < 0)
    membership[noise] = (cluster.max() + 1 if cluster.size else 0) + np.arange(noise.size)
    if membership.size and membership.max() >= membership.size:  # compact ids into [0, N)
        membership = np.unique(membership, return_inverse=True)[1].astype(np.int64)
    return _kernels.canonical_labels(membership)
