"""Size histories of tracked granules: the sizes of the longest-lived tracks, frame by frame
(:func:`size_histories`).

Units: SI, time in seconds (``_s`` suffix); granule sizes in particles, or with
``size_unit="original"`` in original-particle equivalents α³·n.
"""

from __future__ import annotations

from numbers import Integral

import numpy as np
import pandas as pd

from granalytics.analysis.stats import SIZE_UNITS, size_unit_factor
from granalytics.analysis.tracking.tracks import TRACKS, GranuleTracks
from granalytics.base.validation import Interval, Options, validate_params


@validate_params({"tracks": [TRACKS], "n": [Interval(Integral, 0, None)], "size_unit": [Options(SIZE_UNITS)]})
def size_histories(tracks: GranuleTracks, n=8, *, size_unit="particles", alpha=None) -> pd.DataFrame:
    """The size histories of the ``n`` longest-lived tracks (ties: the largest granule first).

    Parameters
    ----------
    tracks : GranuleTracks
    n : int, default 8
        Tracks kept (all of them when there are fewer).
    size_unit : {"particles", "original"}, default "particles"
        Unit of ``size``: the run's particles, or original-particle equivalents α³·n.
    alpha : float, or a run or its metadata
        The CG factor (its ``alpha``), for ``size_unit="original"``.

    Returns
    -------
    DataFrame
        One row per track and frame of its life, the tracks in the order of their ids: ``track``,
        ``origin``, ``end`` (as :attr:`GranuleTracks.tracks`), ``time_s`` [s] and ``size``
        (in ``size_unit``). ``attrs["size_unit"]`` names the unit.
    """
    factor = size_unit_factor(size_unit, alpha, caller="size_histories")
    tr = tracks.tracks
    life = (tr["last_frame"] - tr["first_frame"]).to_numpy()
    biggest = np.fromiter((max(s) for s in tr["sizes"]), dtype=np.int64, count=len(tr))
    chosen = np.sort(np.lexsort((-biggest, -life))[:n])
    parts = [pd.DataFrame({"track": row.track, "origin": row.origin, "end": row.end,
                           "time_s": tracks.times_s[row.first_frame:row.last_frame + 1],
                           "size": np.asarray(row.sizes) * factor})
             for row in tr.iloc[chosen].itertuples()]
    table = pd.concat(parts, ignore_index=True) if parts else pd.DataFrame(
        {"track": pd.Series(dtype=np.int64), "origin": pd.Series(dtype=object), "end": pd.Series(dtype=object),
         "time_s": pd.Series(dtype=float), "size": pd.Series(dtype=float)})
    table.attrs["size_unit"] = size_unit
    return table
