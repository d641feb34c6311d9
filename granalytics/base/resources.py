"""Sizes checked before the work: a request whose memory or disk need is out of reach of this
machine is refused at once, with the size it would need, instead of swapping or filling the disk
for an hour first (a 450 kB file may declare 2·10⁸ particles; a grid or a run may ask for 10⁸
points)."""

from __future__ import annotations

import os
import shutil

from granalytics.base.errors import ParameterError

#: the largest share of this machine's physical memory one request may need
MEMORY_FRACTION = 0.5


def physical_memory() -> int:
    """This machine's physical memory [bytes] (0 when the system does not say)."""
    try:
        return os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (AttributeError, OSError, ValueError):
        return 0


def format_bytes(n) -> str:
    """``n`` bytes as text in the largest unit below it (``"19.2 GB"``)."""
    n = float(n)
    for unit in ("B", "kB", "MB", "GB", "TB", "PB"):
        if abs(n) < 1000 or unit == "PB":
            return f"{n:.3g} {unit}"
        n /= 1000


def check_memory(what, nbytes) -> None:
    """Refuse (``ParameterError``) ``what`` (a phrase: "reading one frame of file.h5 (2e8
    particles)") when it would need more than :data:`MEMORY_FRACTION` of the physical memory."""
    total = physical_memory()
    if total and nbytes > MEMORY_FRACTION * total:
        raise ParameterError(f"{what} would need {format_bytes(nbytes)} of memory, more than "
                             f"{MEMORY_FRACTION:.0%} of this machine's {format_bytes(total)}; refused before starting")


def check_disk(what, nbytes, path) -> None:
    """Refuse (``ParameterError``) writing ``what`` beside ``path`` when it would need more than
    the free space of that file system."""
    folder = os.path.dirname(os.path.abspath(os.fspath(path)))
    try:
        free = shutil.disk_usage(folder).free
    except OSError:
        return  # the folder check of the output reports a missing folder
    if nbytes > free:
        raise ParameterError(f"{what} would need about {format_bytes(nbytes)} of disk, {folder} has "
                             f"{format_bytes(free)} free; refused before starting")
