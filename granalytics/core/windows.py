"""Which frames lie in a closed window of revolutions or seconds (private; one rule for every
analysis).

A simulator writes a frame every whole number of time steps, so the frame meant for revolution 6
carries the time of the nearest step: 5.9999 revolutions in one run, 6.00001 in a run of another
time step (the frame interval rounded to whole steps, accumulated over the run). Compared
exactly, the same window [3, 6] would then take 60 frames from one run and 61 from the other.
A frame counts as inside when it lies within ``WINDOW_TOLERANCE`` of the run's *smallest* frame
spacing of an edge: far more than that rounding in the runs we know (at most 0.2 % of a
spacing in the bundled ones, 1.6 % after 20 revolutions of lab-cg3 at Ω = 3 rad/s: the presets
take more than 10 000 steps per frame, so half a step per frame stays below a tenth of a spacing
for over 100 revolutions), and small enough never to take in a neighbouring frame, even in a run
thinned outside a dense window. Frames stamped further than that from their nominal times are
not at the times the window asks for.
"""

from __future__ import annotations

import numpy as np

__all__ = ["WINDOW_TOLERANCE", "window_tolerance", "window_mask", "clip_window"]

#: fraction of the smallest frame spacing by which a frame may lie outside a window's edge
WINDOW_TOLERANCE = 0.1


def window_tolerance(values) -> float:
    """``WINDOW_TOLERANCE`` × the smallest spacing of the distinct finite ``values`` (0 for
    fewer than two), in the unit of ``values``."""
    values = np.asarray(values, dtype=float)
    distinct = np.unique(values[np.isfinite(values)])
    return float(WINDOW_TOLERANCE * np.diff(distinct).min()) if distinct.size > 1 else 0.0


def window_mask(values, lo, hi, tolerance=None) -> np.ndarray:
    """Boolean mask of ``values`` (frame times or revolutions) inside the closed window
    [lo, hi], each edge widened by ``tolerance`` (default :func:`window_tolerance`); NaN is
    never inside."""
    values = np.asarray(values, dtype=float)
    tol = window_tolerance(values) if tolerance is None else tolerance
    return (values >= lo - tol) & (values <= hi + tol)


def clip_window(values, lo, hi, tolerance=None) -> tuple[float, float]:
    """The window [lo, hi] clipped to the span of the finite ``values``: an edge that lies
    beyond the first or last value by more than ``tolerance`` (default
    :func:`window_tolerance`) is moved onto that value; an edge within it stays as given.

    What depends on the window's width besides its frames (the blocks of a block s.e.m.) then
    depends on the frames only: [3, 9] on a run that ends at revolution 6 is [3, 6] (its last
    frame's stamp), the same blocks as the window [3, 6] itself."""
    values = np.asarray(values, dtype=float)
    finite = values[np.isfinite(values)]
    if not finite.size:
        return float(lo), float(hi)
    tol = window_tolerance(values) if tolerance is None else tolerance
    first, last = float(finite.min()), float(finite.max())
    return (first if lo < first - tol else float(lo)), (last if hi > last + tol else float(hi))
