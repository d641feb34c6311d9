"""Exceptions raised by granalytics, and errors and warnings as a user sees them.

Every problem with user input (a file, a frame, a parameter) raises a subclass of
:class:`GranalyticsError`. The command-line interface turns these into one line on stderr
(:func:`one_line`) and exit status 2; the Python API lets them propagate. A warning points at the
user's call (:func:`user_stacklevel`); a command line prints it as one line
(:func:`warnings_as_lines`).
"""

from __future__ import annotations

import contextlib
import os
import sys
import warnings

__all__ = ["GranalyticsError", "ValidationError", "RunFileError", "RunWriteError", "RunLockedError", "ParameterError",
           "FrameKeyError", "exit_after_write_failure", "user_stacklevel", "one_line", "warnings_as_lines"]

_PACKAGE = os.path.dirname(os.path.dirname(os.path.abspath(__file__))) + os.sep


def user_stacklevel() -> int:
    """The ``stacklevel`` of :func:`warnings.warn` that names the first caller outside granalytics
    (the user's line), however deep the warning is raised (pandas' ``find_stack_level``)."""
    frame, level = sys._getframe(1), 1
    while frame.f_back is not None and os.path.abspath(frame.f_code.co_filename).startswith(_PACKAGE):
        frame, level = frame.f_back, level + 1
    return level


class GranalyticsError(Exception):
    """Base class of every error granalytics raises about its input."""


class ValidationError(GranalyticsError, ValueError):
    """Snapshot data violates the data model.

    Parameters
    ----------
    field : str
        Name of the offending field (e.g. ``"position"``, ``"contact_i"``), or the path of the
        offending dataset in a run file (e.g. ``"/contacts/count"``: the message then says
        "dataset" instead of "field").
    message : str
        What is wrong, including the first offending value.
    index : int, optional
        First offending index along the field's first axis.
    frame : int, optional
        Frame index in the run, when the snapshot came from a file.
    path : str, optional
        File the snapshot was read from.
    """

    def __init__(self, field, message, index=None, frame=None, path=None):
        self.field = field
        self.detail = message
        self.index = index
        self.frame = frame
        self.path = None if path is None else str(path)
        super().__init__(self._format())

    def located(self, path=None, frame=None):
        """Return a copy of this error that also names ``path`` and ``frame``."""
        return ValidationError(
            self.field,
            self.detail,
            index=self.index,
            frame=self.frame if frame is None else frame,
            path=self.path if path is None else path,
        )

    def _format(self):
        where = []
        if self.path is not None:
            where.append(f"file {self.path}")
        if self.frame is not None:
            where.append(f"frame {self.frame}")
        kind = "dataset" if str(self.field).startswith("/") else "field"
        where.append(f"{kind} '{self.field}'")
        if self.index is not None:
            where.append(f"index {self.index}")
        return ", ".join(where) + ": " + self.detail


class RunFileError(GranalyticsError, OSError):
    """A run file cannot be opened, is not a granalytics run, or is structurally broken."""


class RunWriteError(RunFileError):
    """HDF5 could not write a run file (a full disk, a file-size limit). The HDF5 library cannot
    close such a file cleanly: a command line reports it and ends the process at once
    (:func:`exit_after_write_failure`) instead of letting the interpreter's exit crash in it."""


def exit_after_write_failure(status: int) -> None:
    """End the process with ``status`` without the interpreter's shutdown (streams flushed), after
    a :class:`RunWriteError`: closing the broken HDF5 file at exit would be a segmentation fault."""
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except Exception:  # noqa: BLE001 - nothing more to do at this point
            pass
    os._exit(status)


class RunLockedError(RunFileError, ValueError):
    """Another writer holds the lock file of a run file (``PATH.lock``).

    Also a :class:`ValueError`, so that command-line tools that report bad input (``ValueError``)
    as one line with exit status 2 treat a busy output file the same way.
    """


class ParameterError(GranalyticsError, ValueError):
    """A parameter passed to an analysis is outside its valid range."""


class FrameKeyError(ParameterError, TypeError):
    """A run indexed by something other than an int or a slice: granalytics' error, and a
    TypeError as Python's sequences raise for such a key."""


def one_line(exc) -> str:
    """An exception's message on one line."""
    return " ".join(str(exc).split()) or type(exc).__name__


@contextlib.contextmanager
def warnings_as_lines(prog):
    """Inside: every warning that Python's filters let through is printed as one line
    ``PROG: warning: message`` on stderr, instead of Python's file, line and source."""
    def show(message, category, filename, lineno, file=None, line=None):
        print(f"{prog}: warning: {one_line(message)}", file=sys.stderr)

    with warnings.catch_warnings():
        warnings.showwarning = show
        yield
