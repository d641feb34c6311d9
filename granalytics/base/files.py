"""Output files: written whole or not at all, one writer at a time, never over a source.

- :func:`replaced_atomically` / :func:`write_atomically`: write into a temporary file beside the
  target and rename it into place only when the writing succeeded;
- :func:`check_output_folder`, :func:`check_replaceable`, :func:`check_apart`,
  :func:`check_not_open_elsewhere`: refuse an output that cannot or must not be written, before
  the work that makes it; :func:`regular_input`: refuse an input that cannot be read as a file;
- :class:`WriterLock`: one writer at a time on an output (the lock file ``OUTPUT.lock``).
"""

from __future__ import annotations

import contextlib
import json
import os
import socket
import time as _time

from granalytics.base.errors import ParameterError, RunFileError, RunLockedError, one_line
from granalytics.base.interrupts import raise_dropped_interrupt
from granalytics.base.validation import PATH, validate_params

__all__ = ["replaced_atomically", "write_atomically", "check_output_folder", "check_replaceable", "check_apart",
           "check_not_open_elsewhere", "regular_input", "WriterLock"]


@contextlib.contextmanager
def replaced_atomically(path, tmp=None):
    """Yield a temporary path beside ``path`` (default ``PATH.<pid>.tmp``) to write into; it is
    renamed over ``path`` when the block succeeds, and removed when it fails (a full disk, an
    interrupt), leaving an earlier ``path`` as it was. Temporary files ``PATH.<pid>.tmp`` that a
    killed writer on this host left behind (its pid is gone) are removed first."""
    path = os.fspath(path)
    check_replaceable(path)
    _remove_stale_temporaries(path)
    tmp = f"{path}.{os.getpid()}.tmp" if tmp is None else os.fspath(tmp)
    try:
        yield tmp
        raise_dropped_interrupt()  # a Ctrl-C that Python dropped meanwhile replaces nothing
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def _remove_stale_temporaries(path) -> None:
    """Remove ``PATH.<pid>.tmp`` files whose writer process no longer runs on this host (SIGKILL
    leaves them; nothing else can)."""
    import glob

    for tmp in glob.glob(glob.escape(path) + ".*.tmp"):
        pid = tmp[len(path) + 1:-len(".tmp")]
        if pid.isdigit() and _process_is_gone(int(pid)):
            with contextlib.suppress(OSError):
                os.unlink(tmp)


def check_replaceable(path) -> None:
    """Refuse (``ParameterError``) an output path that exists and is not a regular file (or a
    link to one): a folder, or a device, FIFO or socket such as ``/dev/null``, which renaming a
    file over it would replace (as root) or which cannot hold the output."""
    import stat

    path = os.fspath(path)
    try:
        mode = os.stat(path).st_mode  # through links: what a link points to
    except FileNotFoundError:
        return  # nothing there (or a dangling link, which the rename replaces)
    except OSError as exc:
        raise ParameterError(f"{path}: cannot inspect the output ({exc.strerror or one_line(exc)})") from None
    if stat.S_ISDIR(mode):
        raise ParameterError(f"{path}: is a folder, expected a file name")
    if not stat.S_ISREG(mode):
        raise ParameterError(f"{path}: exists and is not a regular file (a device, FIFO or socket); "
                             "an output is written as a new regular file, give another name")


def write_atomically(path, write):
    """``write(tmp)`` under :func:`replaced_atomically`; returns what ``write`` returns."""
    with replaced_atomically(path) as tmp:
        return write(tmp)


def check_apart(output, inputs, what="output") -> None:
    """Refuse (``ParameterError``) an ``output`` path that is, contains or lies inside one of
    ``inputs`` (after resolving links): ``--overwrite`` must never replace or delete a source."""
    out = os.path.realpath(os.fspath(output))
    for source in inputs:
        src = os.path.realpath(os.fspath(source))
        if out == src:
            raise ParameterError(f"{output}: the {what} is the input {source}")
        if os.path.commonpath([out, src]) == src:
            raise ParameterError(f"{output}: the {what} lies inside the input {source}")
        if os.path.commonpath([out, src]) == out:
            raise ParameterError(f"{output}: the {what} contains the input {source}")


def regular_input(path):
    """``path`` if it names a regular file (or a folder), else ``ParameterError``: reading a FIFO,
    a socket or a device would block for ever or read garbage."""
    import stat

    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        raise ParameterError(f"{path}: cannot read (no such file)") from None
    except OSError as exc:
        raise ParameterError(f"{path}: cannot read ({exc.strerror or one_line(exc)})") from None
    if not (stat.S_ISREG(mode) or stat.S_ISDIR(mode)):
        raise ParameterError(f"{path}: not a regular file (a FIFO, socket or device cannot be read as a run or dump)")
    return path


def check_output_folder(path) -> None:
    """Refuse (``ParameterError``) an output file whose folder does not exist or is not writable,
    before the work that would write it."""
    folder = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(folder):
        raise ParameterError(f"{path}: the folder {folder} does not exist")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise ParameterError(f"{path}: the folder {folder} is not writable")
    try:
        longest = os.pathconf(folder, "PC_NAME_MAX")
    except (OSError, ValueError):
        longest = 255
    # the longest name written beside it: the writer's lock, staging and checkpoint files
    if len(os.path.basename(os.fspath(path)).encode()) + 16 > longest:
        raise ParameterError(f"{path}: the file name is too long for its file system ({longest} bytes at most, with "
                             "room for the .ckpt.npz and .lock files beside it)")


def check_not_open_elsewhere(path) -> None:
    """Refuse (:class:`RunFileError`) to replace an HDF5 file ``path`` that another process holds
    open (HDF5's file lock); anything else, including a file that is not HDF5, passes."""
    import h5py

    if not os.path.isfile(path):
        return
    try:
        h5py.File(path, "r+").close()
    except OSError as exc:
        if "lock" in str(exc).lower():
            raise RunFileError(f"{path}: another process has the file open; close it there first (it was not "
                               "replaced)") from None


_LOCK_SUFFIX = ".lock"


class WriterLock:
    """Exclusive lock of an output: the lock file ``target + ".lock"``, held with the operating
    system's file lock (:mod:`filelock`), so that a writer that is killed releases it; while held,
    the file names its holder (pid, host, since) as one JSON line, for the message of the next.

    :class:`RunWriter` holds one on its run file while it is open; anything else that writes
    (e.g. a sweep folder's manifest) can hold one the same way, as a context manager::

        with WriterLock("study/manifest.csv"):
            ...

    A lock that another writer holds raises :class:`~granalytics.base.errors.RunLockedError`,
    naming the lock file and its holder. The lock file is removed on release.
    """

    @validate_params({"target": [PATH]})
    def __init__(self, target):
        import filelock

        self.target = os.fspath(target)
        self.path = self.target + _LOCK_SUFFIX
        # a short timeout, not 0: a writer that opened the file just as its holder released and
        # removed it finds a removed file locked and tries the new one (filelock retries it)
        self._lock = filelock.FileLock(self.path, timeout=0.2, poll_interval=0.02, thread_local=False,
                                       fallback_to_soft=False, on_acquired=self._name_holder)

    def __enter__(self) -> "WriterLock":
        return self.acquire()

    def __exit__(self, *exc_info) -> None:
        self.release()

    @staticmethod
    def _name_holder(fd) -> None:
        os.ftruncate(fd, 0)
        os.write(fd, (json.dumps({"pid": os.getpid(), "host": socket.gethostname(),
                                  "since": _time.strftime("%Y-%m-%dT%H:%M:%S%z")}) + "\n").encode())

    def acquire(self) -> "WriterLock":
        import filelock

        folder = os.path.dirname(os.path.abspath(self.path))
        if not os.path.isdir(folder):  # filelock would make it
            raise RunFileError(f"{self.target}: cannot create the lock file {self.path} (no folder {folder})")
        try:
            self._lock.acquire()
        except filelock.Timeout:
            raise RunLockedError(f"{self.target}: another writer holds the lock file {self.path} "
                                 f"({_describe_holder(self.path)})") from None
        except OSError as exc:
            raise RunFileError(f"{self.target}: cannot create the lock file {self.path} "
                               f"({exc.strerror or one_line(exc)})") from None
        return self

    def release(self) -> None:
        """Remove the lock file and release the lock (idempotent)."""
        if self._lock.is_locked:
            with contextlib.suppress(OSError):
                os.unlink(self.path)  # while still held: a writer waiting on this file retries on the new one
            self._lock.release(force=True)


def _describe_holder(path) -> str:
    try:
        with open(path, encoding="utf-8", errors="replace") as f:
            holder = json.loads(f.read())
        since = f", since {holder['since']}" if holder.get("since") else ""
        return f"pid {holder['pid']} on host {holder['host']}{since}"
    except (OSError, ValueError, TypeError, KeyError):
        return "its holder did not say who it is"


def _process_is_gone(pid) -> bool:
    """True when no process ``pid`` runs on this host."""
    if pid <= 0 or pid == os.getpid():
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return True
    except OSError:  # exists, owned by another user
        return False
    return False
