"""Output files (private): written atomically, and checked before the work that makes them."""

from __future__ import annotations

import contextlib
import os

from .errors import ParameterError

__all__ = ["replaced_atomically", "write_atomically", "check_output_folder"]


@contextlib.contextmanager
def replaced_atomically(path, tmp=None):
    """Yield a temporary path beside ``path`` (default ``PATH.<pid>.tmp``) to write into; it is
    renamed over ``path`` when the block succeeds, and removed when it fails (a full disk, an
    interrupt), leaving an earlier ``path`` as it was."""
    path = os.fspath(path)
    tmp = f"{path}.{os.getpid()}.tmp" if tmp is None else os.fspath(tmp)
    try:
        yield tmp
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def write_atomically(path, write):
    """``write(tmp)`` under :func:`replaced_atomically`; returns what ``write`` returns."""
    with replaced_atomically(path) as tmp:
        return write(tmp)


def check_output_folder(path) -> None:
    """Refuse (``ParameterError``) an output file whose folder does not exist or is not writable,
    before the work that would write it."""
    folder = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(folder):
        raise ParameterError(f"{path}: the folder {folder} does not exist")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise ParameterError(f"{path}: the folder {folder} is not writable")
