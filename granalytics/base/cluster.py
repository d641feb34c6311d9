"""A dask cluster to run work on: a scheduler's address, a ``distributed.Client`` already made,
or a local cluster of worker processes, behind one context manager (:func:`dask_client`). Used
by parameter sweeps (``sim sweep``) and by the frame loop of the analyses
(:func:`granalytics.analysis.frames.map_frames`). dask is imported only when a cluster is asked for."""

from __future__ import annotations

import contextlib
import logging
import os

from granalytics.base.errors import ParameterError, one_line

__all__ = ["dask_client"]


@contextlib.contextmanager
def dask_client(scheduler=None, workers=None, *, what="this", timeout_s=20.0):
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
    timeout_s : float, default 20
        How long a scheduler's address may take to answer dask's handshake, and then to have a
        worker [s].

    Raises
    ------
    ParameterError
        dask.distributed missing, ``workers`` given with a scheduler or not a positive integer,
        a scheduler that cannot be reached, an address where something else answers (a silent
        socket, an HTTP server) or a scheduler without workers (naming its address).
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
        client = _connect(Client, scheduler, timeout_s)
        try:
            try:
                client.wait_for_workers(1, timeout=timeout_s)
            except (OSError, TimeoutError) as exc:
                raise ParameterError(f"the dask scheduler {scheduler} has no workers (none joined within "
                                     f"{timeout_s:g} s)") from exc
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


def _connect(client_class, address, timeout_s):
    """A client of the scheduler at ``address``, made in a thread that is given up after
    ``timeout_s`` (dask's own timeout does not cover a handshake that never comes: a silent
    socket would hang forever, and an HTTP server's reply is read as a gigantic message)."""
    import threading

    result = {}

    def connect():
        try:
            result["client"] = client_class(address, timeout=f"{timeout_s:g}s")
        except BaseException as exc:  # noqa: BLE001 - handed to the caller below
            result["error"] = exc

    thread = threading.Thread(target=connect, daemon=True)  # a daemon: a hung handshake does not block the exit
    thread.start()
    thread.join(timeout_s + 5)
    if thread.is_alive():
        raise ParameterError(f"no dask scheduler answered at {address} within {timeout_s:g} s (something listens "
                             "there, but it does not speak dask's protocol)")
    error = result.get("error")
    if isinstance(error, MemoryError):
        raise ParameterError(f"{address} is not a dask scheduler (its reply is not dask's protocol)")
    if isinstance(error, (OSError, TimeoutError, ValueError)):
        raise ParameterError(f"cannot connect to the dask scheduler {address} ({one_line(error)})")
    if error is not None:
        raise error
    return result["client"]
