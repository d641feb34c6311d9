"""Checks of an argument's type, shared by the public API (private).

A function handed None, a string, a dict or a ragged list where it takes a path, a snapshot,
run metadata or numbers raises one of granalytics' own errors naming itself and the argument
(``ParameterError``: one line on the command line, exit status 2), never the AttributeError,
TypeError or numpy ValueError that the first use of the value would raise somewhere inside.
"""

from __future__ import annotations

import os

import numpy as np

from granalytics.core.errors import ParameterError

__all__ = ["FrameKeyError", "check_path", "check_snapshot", "check_meta", "check_numbers", "check_indices", "shown"]


class FrameKeyError(ParameterError, TypeError):
    """A run indexed by something other than an int or a slice: granalytics' error, and a
    TypeError as Python's sequences raise for such a key."""


def shown(value, limit=60) -> str:
    """``type value`` for a message: the value's repr cut at ``limit`` characters."""
    text = repr(value)
    return f"{type(value).__name__} {text if len(text) <= limit else text[:limit - 3] + '...'}"


def _prefix(where) -> str:
    return f"{where}: " if where else ""


def check_path(where, name, value) -> str:
    """``value`` as a path (``os.fspath``): a str or a path-like object; anything else (None,
    bytes, a number, a list) is a ``ParameterError`` naming ``where`` and ``name``."""
    if not isinstance(value, (str, os.PathLike)):
        raise ParameterError(f"{_prefix(where)}{name} must be a file name (str or path-like), got {shown(value)}")
    path = os.fspath(value)
    if not isinstance(path, str):  # a path-like object of bytes
        raise ParameterError(f"{_prefix(where)}{name} must be a file name (str or path-like), got {shown(value)}")
    return path


def check_snapshot(where, value, name="snapshot") -> None:
    """Refuse anything but a :class:`~granalytics.core.snapshot.Snapshot`; a path gets the hint
    to open the run first."""
    from granalytics.core.snapshot import Snapshot

    if not isinstance(value, Snapshot):
        hint = " (open the run with granalytics.open_run and pass one frame, e.g. run[0])" if isinstance(
            value, (str, bytes)) or hasattr(value, "__fspath__") else ""
        raise ParameterError(f"{_prefix(where)}{name} must be a granalytics Snapshot, got {type(value).__name__}{hint}")


def check_meta(where, value, name="meta") -> None:
    """Refuse anything but a :class:`~granalytics.core.snapshot.RunMeta` (a run's ``run.meta``)."""
    from granalytics.core.snapshot import RunMeta

    if not isinstance(value, RunMeta):
        raise ParameterError(f"{_prefix(where)}{name} must be a RunMeta (a run's run.meta), got {shown(value)}")


def check_numbers(where, name, value, *, ndim=1) -> np.ndarray:
    """``value`` as a float array of ``ndim`` dimensions (a scalar counts as one number when
    ``ndim`` is 1; any shape for ``ndim=None``); None, text, a dict, bools or a ragged list are a
    ``ParameterError``."""
    what = "a list of numbers" if ndim in (1, None) else f"a {ndim}-D array of numbers"
    if value is None or isinstance(value, (str, bytes, dict, set)):
        raise ParameterError(f"{_prefix(where)}{name} must be {what}, got {shown(value)}")
    try:
        array = np.asarray(value)
        if array.dtype == object or array.dtype.kind not in "iuf":
            raise ValueError
        array = array.astype(float)
    except (TypeError, ValueError):
        raise ParameterError(f"{_prefix(where)}{name} must be {what}, got {shown(value)}") from None
    if ndim == 1 and array.ndim == 0:
        array = array.reshape(1)
    if ndim is not None and array.ndim != ndim:
        raise ParameterError(f"{_prefix(where)}{name} must be {what}, got an array of shape {array.shape}")
    return array


def check_indices(where, name, value) -> np.ndarray:
    """``value`` as a 1-D int64 array of whole numbers (frame or particle indices)."""
    if value is None or isinstance(value, (str, bytes, dict, set)):
        raise ParameterError(f"{_prefix(where)}{name} must be a sequence of whole numbers, got {shown(value)}")
    try:
        array = np.asarray(value)
    except (TypeError, ValueError):
        array = np.asarray([None])
    if array.size == 0:
        return np.zeros(0, np.int64)
    if array.dtype.kind not in "iu" or array.ndim > 1:
        raise ParameterError(f"{_prefix(where)}{name} must be a sequence of whole numbers, got {shown(value)}")
    return array.reshape(-1).astype(np.int64)
