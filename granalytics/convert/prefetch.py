"""Read the next frame while the current one is written: a :class:`~granalytics.convert.registry.
FrameSource` whose reading runs in a second process (``convert`` on two or more cores).

Parsing a frame of text and writing it to HDF5 each take about half of a conversion; with the
reading in a forked worker that stays one frame ahead (a queue of one), they overlap. Memory is
then that of about three frames (the one being written, the one queued, the one being read).
The worker's errors and warnings reach the caller as its own; Ctrl-C is the caller's to handle
(the worker ignores it and is stopped with the caller).
"""

from __future__ import annotations

import multiprocessing
import os
import pickle
import signal
import warnings

from granalytics.base.errors import GranalyticsError, user_stacklevel

__all__ = ["prefetched"]


def prefetched(source):
    """``source`` read one frame ahead in a forked worker process, or ``source`` itself where
    processes cannot be forked (not Linux or macOS) or only one core may be used."""
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    if "fork" not in multiprocessing.get_all_start_methods() or cores < 2:
        return source
    return _Prefetched(source)


def _work(source, queue):
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the caller decides what a Ctrl-C does
    signal.signal(signal.SIGTERM, signal.SIG_DFL)  # and stops the worker with SIGTERM (not the caller's handler)
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            for snapshot in source:
                queue.put(("frame", snapshot, source.meta, source.bytes_read, [str(w.message) for w in caught]))
                caught.clear()
            queue.put(("end", None, source.meta, source.bytes_read, [str(w.message) for w in caught]))
    except BaseException as exc:  # noqa: BLE001 (every failure goes to the caller)
        try:
            pickled = pickle.dumps(exc)
        except Exception:  # an exception that does not pickle: its class and message only
            pickled = None
        queue.put(("error", (pickled, type(exc).__name__, str(exc)), None, 0, []))


class _Prefetched:
    def __init__(self, source):
        self._source = source
        self.total_bytes = source.total_bytes
        self.meta = None
        self.bytes_read = 0
        self._first = None
        self._process = None
        self._start()  # before any thread of the caller's (a progress bar's) exists: fork copies none

    def frame_bytes(self) -> int:
        return self._source.frame_bytes()

    def _start(self):
        context = multiprocessing.get_context("fork")
        self._queue = context.Queue(maxsize=1)
        self._process = context.Process(target=_work, args=(self._source, self._queue), daemon=True)
        self._process.start()

    def _next(self):
        kind, payload, meta, bytes_read, messages = self._queue.get()
        for message in messages:
            warnings.warn(message, stacklevel=user_stacklevel())
        self.bytes_read = bytes_read
        if meta is not None:
            self.meta = meta
        if kind == "error":
            self.close()
            pickled, name, text = payload
            try:
                exc = pickle.loads(pickled) if pickled is not None else None
            except Exception:  # an exception class whose constructor unpickling cannot call
                exc = None
            if isinstance(exc, BaseException):
                raise exc
            raise GranalyticsError(text if isinstance(text, str) and text else name)
        if kind == "end":
            self.close()
            return None
        return payload

    def first(self):
        if self._first is None:
            self._first = self._next()
            if self._first is None:
                self._source.first()  # nothing to read: the reader's own refusal
        return self._first

    def __iter__(self):
        try:
            yield self.first()
            while (snapshot := self._next()) is not None:
                yield snapshot
        finally:
            self.close()

    def close(self) -> None:
        """Stop the worker (idempotent)."""
        if self._process is not None and self._process.is_alive():
            self._process.terminate()
        if self._process is not None:
            self._process.join(timeout=10)
            if self._process.is_alive():  # stuck in a system call: no more patience
                self._process.kill()
                self._process.join()
