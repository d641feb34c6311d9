"""Compare identification methods on the same frames: adjusted Rand index and differences of
granule number and yield (scikit-learn metrics); which methods give the same statistics
(:func:`identical_methods`)."""

from __future__ import annotations

import itertools

import numpy as np
import pandas as pd

from granalytics.identification.cohesion import DEFAULT_COHESION
from granalytics.base.errors import ParameterError
from granalytics.analysis.frames import map_frames
from granalytics.analysis.metrics import HEADLINE
from granalytics.identification import make_identifier
from granalytics.analysis.stats import frame_stats
from granalytics.base.validation import FLAG, Array, Instance, validate_params

__all__ = ["compare_methods", "partition_labels", "identical_methods"]


def partition_labels(labels) -> np.ndarray:
    """Labels in which every free particle (−1) is its own cluster, for partition metrics."""
    out = np.asarray(labels, dtype=np.int64).copy()
    free = out < 0
    out[free] = (out.max() + 1 if out.size else 0) + np.arange(free.sum())
    return out


@validate_params({"methods": [Instance(dict, "a dict of display name -> (method, params)")], "progress": [FLAG]})
def compare_methods(frames, methods, *, cohesion=DEFAULT_COHESION, progress=False, jobs=1, scheduler=None):
    """Run several identification methods on every frame and compare them pairwise.

    Parameters
    ----------
    frames : Run, RunSlice or sequence of Snapshot
    methods : dict
        Display name -> ``(method, params)``, e.g.
        ``{"gna": ("gna", {}), "dbscan": ("dbscan", {"eps_diameters": 1.1})}``.
    cohesion : {"acting", "bridge"}, default "acting"
        Cohesion convention of every method whose params do not set their own
        (:mod:`granalytics.identification.cohesion`).
    progress : bool, default False
        Progress bar over frames.
    jobs, scheduler :
        Where the frames are analysed: ``jobs`` threads here, or a dask cluster (a scheduler's
        address or a ``distributed.Client``); see :func:`granalytics.analysis.frames.map_frames`.

    Returns
    -------
    stats : DataFrame
        One row per (frame, method): ``frame``, ``method``, ``cohesion`` and the
        :func:`~granalytics.frame_stats` columns.
    pairs : DataFrame
        One row per (frame, method_a, method_b): ``ari`` (adjusted Rand index of the partitions,
        every free particle its own cluster; 1 = identical) and ``d_<metric>`` (b − a) for every
        headline metric (:data:`granalytics.analysis.metrics.HEADLINE`).
    """
    from sklearn.metrics import adjusted_rand_score

    if len(methods) < 2 or not all(isinstance(v, (tuple, list)) and len(v) == 2 and isinstance(v[1], dict)
                                   for v in methods.values()):
        raise ParameterError("compare_methods: methods must map two or more display names to (method, params), e.g. "
                             "{'gna': ('gna', {}), 'dbscan': ('dbscan', {'eps_diameters': 1.1})}; got "
                             f"{str(methods)[:80]}")
    identifiers = {name: make_identifier(method, **{"cohesion": cohesion, **params})
                   for name, (method, params) in methods.items()}

    def one_frame(snapshot):
        labels, rows = {}, {}
        for name, identifier in identifiers.items():
            result = identifier.identify(snapshot)
            labels[name] = partition_labels(result.labels)
            row = frame_stats(snapshot, result)
            row.insert(0, "cohesion", identifier.cohesion)
            row.insert(0, "method", name)
            rows[name] = row
        pairs = [{"time_s": snapshot.time, "revolutions": snapshot.revolutions,
                  "method_a": a, "method_b": b, "ari": adjusted_rand_score(labels[a], labels[b]),
                  **{f"d_{name}": rows[b][name].iloc[0] - rows[a][name].iloc[0] for name in HEADLINE}}
                 for a, b in itertools.combinations(identifiers, 2)]
        return list(rows.values()), pairs

    frame_ids, results = map_frames(frames, one_frame, progress=progress, desc="compare", what="compare", jobs=jobs,
                                     scheduler=scheduler)
    stats, pairs = [], []
    for frame, (rows, frame_pairs) in zip(frame_ids, results):
        for row in rows:
            row.insert(0, "frame", int(frame))
            stats.append(row)
        pairs.extend({"frame": int(frame), **p} for p in frame_pairs)
    return pd.concat(stats, ignore_index=True), pd.DataFrame(pairs)


@validate_params({"stats": [Instance(pd.DataFrame, "compare_methods' statistics table (a DataFrame)")],
                  "columns": [Array(ndim=1, dtype=str)]})
def identical_methods(stats, columns=HEADLINE) -> dict:
    """The methods of a :func:`compare_methods` statistics table that give the same statistics as
    an earlier one: every column of ``columns`` equal frame by frame (``numpy.allclose``, NaN
    equal to NaN).

    Parameters
    ----------
    stats : DataFrame
        The first table of :func:`compare_methods` (``method`` and the statistics per frame).
    columns : sequence of str, default the headline metrics

    Returns
    -------
    dict
        Method -> the first earlier method (in the table's order) it equals that equals none
        before it; methods that equal no earlier one are left out.
    """
    series = {name: part for name, part in stats.groupby("method", sort=False)}
    methods = list(series)
    same_as = {}
    for k, name in enumerate(methods):
        for earlier in methods[:k]:
            if earlier not in same_as and all(
                    np.allclose(series[name][c].to_numpy(dtype=float), series[earlier][c].to_numpy(dtype=float),
                                equal_nan=True) for c in columns):
                same_as[name] = earlier
                break
    return same_as
