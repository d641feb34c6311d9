"""Pieces shared by the identification methods: the :class:`Identifier` base class (parameters
from the constructor, ``params()``, ``repr``), one validation of the thresholds C_agg and A_agg,
and canonical labels. Per-contact quantities (γ, R, f = F_coh/(2πγR), co-motion) live in
:mod:`granalytics.identification.contacts`, below this package."""

from __future__ import annotations

import functools
import inspect
import math

import numpy as np

from granalytics.identification import kernels as _kernels
from granalytics.identification.contacts import as_number, check_angle, check_radius_mode, co_moving, contact_strength, mean_radius, surface_tension
from granalytics.core import checks
from granalytics.core.errors import ParameterError

#: the paper's thresholds, the defaults of every method that filters contacts by them (GNA, the
#: sieve over GNA granules, community detection): C_agg (F_coh ≥ C_agg·2πγR) and A_agg [deg]
PAPER_C_AGG = 0.6
PAPER_A_AGG_DEG = 20.0

__all__ = ["PAPER_C_AGG", "PAPER_A_AGG_DEG", "Identifier", "check_c_agg", "check_min_size", "check_angle", "check_radius_mode", "co_moving", "contact_strength",
           "mean_radius", "surface_tension", "labels_from_clusters"]


class Identifier:
    """Base of every identification method (scikit-learn style).

    The contract of a method (checked for every registered method by ``tests/test_conformance.py``):

    - a class attribute ``method``, its name in :data:`granalytics.identification.METHODS`;
    - every constructor argument stored under the same attribute name, validated when
      :meth:`identify` runs (not in the constructor);
    - a keyword argument ``cohesion`` (one of :data:`granalytics.COHESION_CONVENTIONS`), also for
      methods that do not use it: commands and :func:`granalytics.compare_methods` hand it to any method;
    - :meth:`identify` ``(snapshot)`` returning an :class:`~granalytics.IdentificationResult`.

    :meth:`params` reads the constructor's signature, so a new parameter needs no second list.
    """

    method = ""

    def __init_subclass__(cls, **kwargs):
        """Every method's :meth:`identify` refuses anything but a Snapshot (one ParameterError,
        not an AttributeError from deep inside the method)."""
        super().__init_subclass__(**kwargs)
        if "identify" in cls.__dict__:
            cls.identify = _snapshot_checked(cls.__dict__["identify"])

    def params(self) -> dict:
        """The constructor parameters, by name."""
        names = [p for p in inspect.signature(type(self).__init__).parameters if p != "self"]
        return {name: self._param_value(name) for name in names}

    def _param_value(self, name):
        return getattr(self, name)

    def identify(self, snapshot):  # pragma: no cover - every subclass implements it
        raise NotImplementedError

    def __repr__(self):
        args = ", ".join(f"{k}={v!r}" for k, v in self.params().items())
        return f"{type(self).__name__}({args})"


def check_snapshot(snapshot, where) -> None:
    """Refuse (``ParameterError`` naming ``where``) anything but a :class:`Snapshot`; a path gets
    the hint to open the run first (:func:`granalytics.core.checks.check_snapshot`)."""
    checks.check_snapshot(where, snapshot)


def _snapshot_checked(identify):
    @functools.wraps(identify)
    def checked(self, snapshot, *args, **kwargs):
        check_snapshot(snapshot, f"{type(self).__name__}.identify")
        return identify(self, snapshot, *args, **kwargs)

    return checked


def check_c_agg(c_agg) -> float:
    """C_agg as a float, finite and ≥ 0."""
    value = as_number("c_agg", c_agg, "a number >= 0")
    if not (math.isfinite(value) and value >= 0):
        raise ParameterError(f"c_agg must be finite and >= 0, got {c_agg!r}")
    return value


def check_flag(name, value) -> bool:
    """``value`` if it is a bool; text such as ``'no'`` or ``'false'`` and numbers are refused
    (``ParameterError`` naming ``name``), never read by their truth value."""
    if not isinstance(value, (bool, np.bool_)):
        raise ParameterError(f"{name} must be True or False, got {type(value).__name__} {value!r}")
    return bool(value)


def check_min_size(min_size) -> int:
    """The fewest particles of a granule, a whole number >= 2."""
    if isinstance(min_size, (bool, np.bool_)) or not isinstance(min_size, (int, np.integer)) or min_size < 2:
        raise ParameterError(f"min_size must be a whole number of particles >= 2, got {min_size!r}")
    return int(min_size)


def labels_from_clusters(cluster) -> tuple[np.ndarray, np.ndarray]:
    """Canonical labels and sizes from cluster ids in which −1 marks unclustered points."""
    cluster = np.asarray(cluster, dtype=np.int64)
    membership = cluster.copy()
    noise = np.flatnonzero(cluster < 0)
    membership[noise] = (cluster.max() + 1 if cluster.size else 0) + np.arange(noise.size)
    if membership.size and membership.max() >= membership.size:  # compact ids into [0, N)
        membership = np.unique(membership, return_inverse=True)[1].astype(np.int64)
    return _kernels.canonical_labels(membership)
