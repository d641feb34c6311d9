"""The result type shared by every identification method."""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
import pandas as pd

from granalytics.identification.granules import granule_table
from granalytics.core.snapshot import Snapshot
from granalytics.base.validation import Instance

__all__ = ["IdentificationResult", "RESULT"]


@dataclass(eq=False)
class IdentificationResult:
    """Which particles form granules in one snapshot.

    Attributes
    ----------
    labels : (N,) int64 array
        Granule label of each particle (row order of the snapshot); −1 for free particles
        (scikit-learn's noise label). Granules are numbered 0, 1, … by decreasing size, ties by
        smallest particle index.
    sizes : (G,) int64 array
        Number of particles in granule g at ``sizes[g]`` (non-increasing).
    method : str
        Identification method (e.g. ``"gna"``).
    params : dict
        Parameters the method ran with (angles in degrees, as given).
    snapshot : Snapshot
        The snapshot that was analysed.
    kept : (M,) bool array or None
        For contact-based methods, the contacts that passed the criteria.
    extra : dict
        Method-specific outputs (e.g. ``"sieve"``: the sieve analysis of virtual sieving).
    """

    labels: np.ndarray
    sizes: np.ndarray
    method: str
    params: dict
    snapshot: Snapshot = field(repr=False)
    kept: np.ndarray | None = field(default=None, repr=False)
    extra: dict = field(default_factory=dict, repr=False)

    @property
    def n_granules(self) -> int:
        """Number of granules G."""
        return int(self.sizes.shape[0])

    @property
    def n_granulated(self) -> int:
        """Number of particles that belong to a granule."""
        return int(self.sizes.sum())

    @cached_property
    def granules(self) -> pd.DataFrame:
        """Per-granule table (see :func:`granalytics.granule_table`), computed on first access."""
        return granule_table(self.snapshot, self.labels)

    def partition(self) -> set:
        """The granules as a set of frozensets of particle *ids* (order-free, for comparisons)."""
        ids = self.snapshot.ids
        order = np.argsort(self.labels, kind="stable")
        bounds = np.searchsorted(self.labels[order], np.arange(self.n_granules + 1))
        return {frozenset(ids[order[a:b]].tolist()) for a, b in zip(bounds[:-1], bounds[1:])}


#: the constraint of an argument that takes an identification's result (:mod:`granalytics.base.validation`)
RESULT = Instance(IdentificationResult, "an IdentificationResult (of granalytics.identify)")
