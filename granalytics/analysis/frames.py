"""The one loop over a run's frames that every analysis uses (after MDAnalysis' ``AnalysisBase.run``):
the frames' indices, the progress bar (named after the run, reaching 100 %), the error of an empty
selection and ``jobs`` worker threads, with the per-frame work plugged in as a function.

The numba kernels of identification release the GIL, so threads overlap the frames' analysis
while one thread reads the next frames; results come back in frame order whatever ``jobs`` is.
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor

import numpy as np
from tqdm.auto import tqdm

from granalytics.core.errors import ParameterError

__all__ = ["frame_indices", "map_frames"]


def frame_indices(frames) -> np.ndarray:
    """The frames' indices in their run file (positions in the list for a plain sequence)."""
    return np.asarray(frames.frame_indices) if hasattr(frames, "frame_indices") else np.arange(len(frames))


def _label(frames, desc):
    path = getattr(frames, "path", None)
    return f"{desc} {os.path.basename(path)}" if path else desc


def map_frames(frames, work, *, progress=False, desc="frames", jobs=1, what="analyse") -> tuple[np.ndarray, list]:
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
        No frames (an empty run or selection), or ``jobs`` below 1.
    """
    indices = frame_indices(frames)
    if len(indices) == 0:
        raise ParameterError(f"no frames to {what} (empty run or selection)")
    if isinstance(jobs, bool) or not isinstance(jobs, (int, np.integer)) or jobs < 1:
        raise ParameterError(f"jobs must be an integer >= 1, got {jobs!r}")
    results = []
    with tqdm(total=len(indices), disable=not progress, unit="frame", desc=_label(frames, desc)) as bar:
        if jobs == 1:
            for snapshot in frames:
                results.append(work(snapshot))
                bar.update(1)
        else:
            with ThreadPoolExecutor(max_workers=int(jobs)) as pool:
                pending = []
                for snapshot in frames:
                    pending.append(pool.submit(work, snapshot))
                    if len(pending) >= 2 * int(jobs):  # bound the frames held in memory
                        results.append(pending.pop(0).result())
                        bar.update(1)
                for job in pending:
                    results.append(job.result())
                    bar.update(1)
    return indices, results
