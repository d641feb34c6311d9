"""Progress bars in a log: when the programs' standard error is not a terminal (``make demo >
log``, ``nohup``), tqdm's bars are written as a line per update; :func:`throttle_bars_off_terminal`
makes them update at most every few seconds there, so that a log holds a readable trail instead
of thousands of carriage returns."""

from __future__ import annotations

import os
import sys

#: the shortest interval between two updates of a bar written to a file or pipe [s]
LOG_INTERVAL_S = 10


def throttle_bars_off_terminal(interval_s=LOG_INTERVAL_S) -> None:
    """Set tqdm's minimum update interval to ``interval_s`` [s] when standard error is not a
    terminal, unless the user set ``TQDM_MININTERVAL``. tqdm reads it when it is imported: call
    this first thing in a program."""
    try:
        terminal = sys.stderr.isatty()
    except (AttributeError, ValueError):
        terminal = False
    if not terminal:
        os.environ.setdefault("TQDM_MININTERVAL", str(interval_s))
