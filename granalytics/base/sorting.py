"""A stable counting sort of small non-negative integer keys, compiled with numba: the simulator's
cell sort at every neighbour-list rebuild (:func:`sim.neighbours.rebuild`) and the ranking of
granules by size (:mod:`granalytics.identification.kernels`)."""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["counting_sort"]


@njit(cache=True)
def counting_sort(keys, n_keys):
    """Stable order of integer keys in [0, ``n_keys``), in O(len(keys) + n_keys).

    Parameters
    ----------
    keys : (N,) integer array
        The keys, each in [0, ``n_keys``) (not checked: a key outside writes out of bounds).
    n_keys : int
        The number of possible keys.

    Returns
    -------
    order : (N,) int64 array
        The indices of ``keys`` by ascending key, equal keys in index order: the same as
        ``np.argsort(keys, kind="stable")``.
    start : (n_keys + 1,) int64 array
        Where each key's run begins in ``order``: key k at ``order[start[k]:start[k + 1]]``.
    """
    start = np.zeros(n_keys + 1, dtype=np.int64)
    for k in keys:
        start[k + 1] += 1
    for c in range(n_keys):
        start[c + 1] += start[c]
    fill = start[:-1].copy()
    order = np.empty(keys.shape[0], dtype=np.int64)
    for i in range(keys.shape[0]):
        order[fill[keys[i]]] = i
        fill[keys[i]] += 1
    return order, start
