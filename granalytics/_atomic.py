"""Writing an output file atomically (private)."""

from __future__ import annotations

import contextlib
import os

__all__ = ["write_atomically"]


def write_atomically(path, write) -> None:
    """``write(tmp)`` into a temporary file beside ``path``, renamed over ``path`` only when it
    is complete: a failure (a full disk, an interrupt) leaves an earlier ``path`` as it was and no
    temporary file behind."""
    path = os.fspath(path)
    tmp = f"{path}.{os.getpid()}.tmp"
    try:
        write(tmp)
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
