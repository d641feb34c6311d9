"""The one loop over a run's frames that every analysis uses (after MDAnalysis' ``AnalysisBase.run``):
the frames' indices, the progress bar (named after the run, reaching 100 %), the error of an empty
selection, ``jobs`` worker threads or a dask cluster (``scheduler``), with the per-frame work
plugged in as a function.

The numba kernels of identification release the GIL, so threads overlap the frames' analysis
while one thread reads the next frames. On a dask cluster each worker opens the run file itself
(it must be reachable at the same path, e.g. on a shared file system) and reads only its frames;
only the per-frame results travel. Results come back in frame order whatever runs them.
"""

from __future__ import annotations

import functools
import os
import uuid
from concurrent.futures import ThreadPoolExecutor
from numbers import Integral

import numpy as np
from tqdm.auto import tqdm

from granalytics.base.cluster import dask_client
from granalytics.base.errors import ParameterError
from granalytics.base.interrupts import raise_dropped_interrupt
from granalytics.base.validation import Interval, validate

__all__ = ["frame_indices", "map_frames"]


def frame_indices(frames) -> np.ndarray:
    """The frames' indices in their run file (positions in the list for a plain sequence)."""
    return np.asarray(frames.frame_indices) if hasattr(frames, "frame_indices") else np.arange(len(frames))


def _advance(bar) -> None:
    """One more frame done. The first frame carries numba's compilation of the kernels (seconds,
    against milliseconds per frame after it): the bar's clock and rate restart after it, so that
    the rate and the time left are those of the frames (the elapsed time shown then counts from
    the end of the first frame). A Ctrl-C that Python dropped during the frame (in a ``__del__`` or
    GC callback, :func:`~granalytics.base.interrupts.interrupts_not_lost`) is raised here."""
    raise_dropped_interrupt()
    if bar.n == 0 and not bar.disable and bar.total and bar.total > 1:
        # the clock restarted and the rate estimates emptied without an update that would print
        # the compilation's rate and time left, and without reset()'s print of 0 frames
        bar.refresh = lambda *args, **kwargs: None  # on the instance: the class's is back after del
        try:
            bar.reset()
        finally:
            del bar.refresh
        bar.initial = bar.n = bar.last_print_n = 1
        bar.refresh()
    else:
        bar.update(1)


def _label(frames, desc):
    path = getattr(frames, "path", None)
    return f"{desc} {os.path.basename(path)}" if path else desc


@functools.lru_cache(maxsize=8)
def _worker_run(path, mtime_ns, size):
    """The run file, opened once per worker process (and per version of the file)."""
    from granalytics.core.reader import open_run

    return open_run(path)


def _work_on_frame(work, path, index):
    """A dask task: ``work`` on frame ``index`` of the run file at ``path``."""
    stat = os.stat(path)
    return work(_worker_run(path, stat.st_mtime_ns, stat.st_size).frame(int(index)))


def _on_cluster(frames, work, indices, scheduler, bar):
    """``work`` on every frame as dask tasks (the frames read by the workers when they come from a
    run file, sent to them otherwise); results gathered in frame order."""
    path = getattr(frames, "path", None)
    with dask_client(scheduler, what="a frame loop on a cluster") as client:
        token = uuid.uuid4().hex[:8]
        if path is not None:
            path = os.path.realpath(path)
            futures = [client.submit(_work_on_frame, work, path, int(i), key=f"frame-{token}-{int(i)}", pure=False)
                       for i in indices]
        else:
            futures = [client.submit(work, snapshot, key=f"frame-{token}-{k}", pure=False)
                       for k, snapshot in enumerate(frames)]
        results = []
        try:
            for future in futures:
                results.append(future.result())
                _advance(bar)
        finally:
            client.cancel([f for f in futures if not f.done()])
    return results


def map_frames(frames, work, *, progress=False, desc="frames", jobs=1, what="analyse",
               scheduler=None) -> tuple[np.ndarray, list]:
    """``work(snapshot)`` on every frame, in frame order.

    Parameters
    ----------
    frames : Run, RunSlice or sequence of Snapshot
    work : callable
        Snapshot -> anything; called once per frame (from ``jobs`` threads when ``jobs > 1``).
    progress : bool, default False
        A progress bar over the frames, labelled ``desc`` and the run file's name.
    jobs : int, default 1
        Worker threads; at most ``2·jobs`` frames are held in memory at a time.
    scheduler : str or distributed.Client, optional
        Run the frames as tasks on a dask cluster instead: a scheduler's address
        (``tcp://host:8786``) or a client. ``work`` must be picklable (cloudpickle: closures are);
        a run file must be readable by the workers at the same path. Exclusive with ``jobs > 1``.
    what : str
        The verb of the empty-selection error ("no frames to {what}").

    Returns
    -------
    indices : (F,) int array
        :func:`frame_indices` of ``frames``.
    results : list
        ``work``'s results, one per frame, in frame order.

    Raises
    ------
    ParameterError
        ``frames`` not a sequence, no frames (an empty run or selection), ``jobs`` below 1, ``jobs`` with ``scheduler``, or a
        scheduler that cannot be reached.
    """
    if isinstance(frames, (str, bytes)) or not (hasattr(frames, "__len__") and hasattr(frames, "__iter__")):
        raise ParameterError(f"frames must be a Run, a RunSlice or a sequence of Snapshot, got "
                             f"{type(frames).__name__} {str(frames)[:40]!r}")
    indices = frame_indices(frames)
    if len(indices) == 0:
        raise ParameterError(f"no frames to {what} (empty run or selection)")
    validate(None, {"jobs": [Interval(Integral, 1, None)]}, {"jobs": jobs})
    if scheduler is not None and jobs != 1:
        raise ParameterError("jobs (threads on this machine) and scheduler (a dask cluster) exclude each other")
    results = []
    with tqdm(total=len(indices), disable=not progress, unit="frame", desc=_label(frames, desc)) as bar:
        if scheduler is not None:
            results = _on_cluster(frames, work, indices, scheduler, bar)
        elif jobs == 1:
            for snapshot in frames:
                results.append(work(snapshot))
                _advance(bar)
        else:
            with ThreadPoolExecutor(max_workers=int(jobs)) as pool:
                pending = []
                for snapshot in frames:
                    pending.append(pool.submit(work, snapshot))
                    if len(pending) >= 2 * int(jobs):  # bound the frames held in memory
                        results.append(pending.pop(0).result())
                        _advance(bar)
                for job in pending:
                    results.append(job.result())
                    _advance(bar)
    return indices, results
