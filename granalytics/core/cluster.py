"""A dask cluster to run work on: a scheduler's address, a ``distributed.Client`` already made,
or a local cluster of worker processes, behind one context manager (:func:`dask_client`). Used
by parameter sweeps (``sim sweep``) and by the frame loop of the analyses
(:func:`granalytics.analysis.frames.map_frames`). dask is imported only when a cluster is asked for."""

from __future__ import annotations

import contextlib
import logging
import os

from granalytics.core.errors import ParameterError
from granalytics.core.files import one_line

__all__ = ["dask_client"]


@contextlib.contextmanager
def dask_client(scheduler=None, workers=None, *, what="this"):
    """A ``distributed.Client`` for the duration of the block.

    Parameters
    ----------
    scheduler : str or distributed.Client, optional
        A scheduler's address (``tcp://host:port``; connected to with a 20 s timeout and closed
        after the block) or a client the caller made (used as it is, left open). ``None``: a local
        cluster of ``workers`` single-threaded worker processes, closed after the block.
    workers : int, optional
        Worker processes of the local cluster (default: the CPU count); only without ``scheduler``.
    what : str
        What needs dask, for the error when dask.distributed is missing.

    Raises
    ------
    ParameterError
        dask.distributed missing, ``workers`` given with a scheduler or not a positive integer,
        or a scheduler that cannot be reached (naming its address).
    """
    try:
        from distributed import Client, LocalCluster
    except ImportError:  # pragma: no cover - a declared dependency
        raise ParameterError(f"{what} needs dask.distributed: pip install 'dask[distributed]'") from None
    if scheduler is not None and workers is not None:
        raise ParameterError("--workers applies to the local cluster only; the scheduler's cluster has its own "
                             "workers")
    if scheduler is not None and not isinstance(scheduler, str):
        if not (hasattr(scheduler, "submit") and hasattr(scheduler, "gather")):
            raise ParameterError(f"scheduler must be an address such as tcp://host:8786 or a distributed.Client, "
                                 f"got {scheduler!r}")
        yield scheduler  # the caller's client: used as it is, left open
        return
    if scheduler is not None:
        try:
            client = Client(scheduler, timeout="20s")
        except (OSError, TimeoutError, ValueError) as exc:
            raise ParameterError(f"cannot connect to the dask scheduler {scheduler} ({one_line(exc)})") from None
        try:
            yield client
        finally:
            client.close()
        return
    if workers is None:
        workers = os.cpu_count() or 1
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise ParameterError(f"workers must be an integer >= 1, got {workers!r}")
    with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=":0",
                      silence_logs=logging.ERROR) as cluster, Client(cluster) as client:
        yield client
