"""Run subsets: fewer frames (:func:`thinned_frames`), float32 storage, written whole or not at all."""

from __future__ import annotations

import contextlib
import os
from numbers import Integral

import numpy as np

from granalytics.core.windows import window_mask
from granalytics.base.files import WriterLock, check_apart, check_replaceable, replaced_atomically
from granalytics.core.reader import open_run
from granalytics.core.writer import RunWriter
from granalytics.base.errors import RunFileError, ValidationError
from granalytics.core.snapshot import RunMeta
from granalytics.base.validation import FLAG, PATH, WINDOW, Array, Interval, Options, validate_params


@validate_params({"revolutions": [Array(ndim=1)], "every": [Interval(Integral, 1, None)],
                  "full_window": [WINDOW, None], "window_every": [Interval(Integral, 1, None)]})
def thinned_frames(revolutions, every=1, full_window=None, window_every=1) -> np.ndarray:
    """Indices of the frames to keep when thinning a run: every ``every``-th frame (the first
    included), and every ``window_every``-th frame whose time in revolutions lies in
    ``full_window`` = (r0, r1) (all of them by default).

    Parameters
    ----------
    revolutions : array of float
        The run's frame times in drum revolutions (:attr:`Run.revolutions`); only their number
        matters without ``full_window`` (any per-frame array will do, e.g. the times of a run
        whose drum does not turn).
    every : int
        Keep one frame in ``every`` outside the window (>= 1; 1 keeps all).
    full_window : (float, float), optional
        Revolutions [r0, r1] in which every frame (every ``window_every``-th) is kept; a frame
        within a tenth of a frame spacing of an edge counts as inside, as in every analysis
        (:func:`granalytics.steady_state`).
    window_every : int
        Keep the frames of the window whose index is a multiple of ``window_every`` (>= 1; 1 keeps
        all; counted from the run's first frame, as ``every`` is, so that thinning a thinned copy
        by the same rule keeps the same frames). Only with ``full_window``.

    Raises
    ------
    ParameterError
        ``every`` or ``window_every`` not a whole number >= 1, or ``full_window`` not two
        increasing numbers.
    ValidationError
        ``window_every`` other than 1 without a window.
    """
    if window_every != 1 and full_window is None:
        raise ValidationError("window_every", f"thins the full window; got {window_every!r} without one")
    revs = np.asarray(revolutions, dtype=float)
    index = np.arange(revs.size)
    keep = index % every == 0
    if full_window is not None:
        r0, r1 = map(float, full_window)
        # the analyses' window rule (edges widened by a tenth of a frame spacing), so that a frame
        # stamped at 2.99997 revolutions belongs to [3, 6] here as in every steady state
        keep |= window_mask(revs, r0, r1) & (index % window_every == 0)
    return index[keep]


@contextlib.contextmanager
def replacing_run(dst, overwrite=False):
    """Write a whole new run for ``dst`` into a temporary file beside it and rename it over
    ``dst`` only when the block inside succeeds; on any error (a bad input frame, a full disk,
    an interrupt) the temporary file is removed and an existing ``dst`` is left as it was. The
    lock of ``dst`` is held throughout. Yields the path to give :class:`RunWriter`.

    Raises
    ------
    RunFileError
        ``dst`` exists and not ``overwrite``; :class:`~granalytics.base.errors.RunLockedError` if
        another writer holds its lock.
    """
    dst = os.fspath(dst)
    check_replaceable(dst)  # before the lock file beside it
    with WriterLock(dst):
        if os.path.exists(dst) and not overwrite:
            raise RunFileError(f"{dst}: file exists (pass overwrite=True, or --overwrite, to replace it)")
        with replaced_atomically(dst, f"{dst}.partial") as tmp:
            yield tmp


@validate_params({"src": [PATH], "dst": [PATH], "frames": [Array(ndim=1)],
                  "float_dtype": [Options(("float64", "float32"))], "overwrite": [FLAG], "progress": [FLAG]})
def subset_run(src, dst, frames, *, float_dtype="float64", overwrite=False, progress=False) -> str:
    """Copy some frames of a run into a new run file, optionally stored as float32.

    For bundling and archiving long runs: e.g. every frame of the steady-state window and every
    fifth frame before it. The metadata is copied; ``provenance["subset_of"]`` records the source
    file name, its frame count, the frames kept and the storage type.

    Parameters
    ----------
    src, dst : path
        Source run and file to write (refused if it exists, unless ``overwrite``; written
        atomically, see :func:`replacing_run`).
    frames : sequence of int
        Frame indices of ``src`` to keep, increasing.
    float_dtype : {"float64", "float32"}
    progress : bool
        Progress bar over frames.

    Returns
    -------
    str : ``dst``
    """
    from tqdm.auto import tqdm

    src, dst = os.fspath(src), os.fspath(dst)
    check_apart(dst, [src], "subset")  # overwrite=True must never replace its own source
    raw = np.asarray(frames)
    if raw.dtype.kind == "f" and not np.array_equal(raw, np.round(raw)):
        bad = raw[raw != np.round(raw)][0]
        raise ValidationError("frames", f"must be whole frame indices, got {float(bad)!r}")
    frames = raw.astype(np.int64)
    with open_run(src) as run:
        if frames.size == 0 or (np.diff(frames) <= 0).any() or frames[0] < 0 or frames[-1] >= len(run):
            raise ValidationError("frames", f"must be increasing indices in [0, {len(run)}) of {src}")
        meta = RunMeta.from_dict(run.meta.to_dict())
        meta.provenance = {**meta.provenance, "subset_of": {
            "file": os.path.basename(src), "frames_in_source": len(run),
            "frames_kept": frames.tolist(), "float_dtype": float_dtype}}
        # the subset plans the frames it keeps; a subset of an unfinished run stays unfinished
        # through the source's missing wall time, not through a frame count that no longer applies
        meta.provenance.pop("planned_frames", None)
        if run.unfinished is None:
            meta.provenance["planned_frames"] = int(frames.size)
        with replacing_run(dst, overwrite) as tmp, \
                RunWriter(tmp, meta, overwrite=True, float_dtype=float_dtype) as writer:
            for k in tqdm(frames, disable=not progress, unit="frame", desc=f"subset {os.path.basename(src)}"):
                writer.append(run[int(k)])
    return dst
