"""Threshold sensitivity of graph network analysis over a grid of C_agg × A_agg (the paper's
angle test) or C_agg × rigid_tol (the rigid co-motion test, ``comotion="rigid"``).

For one frame and one co-motion threshold, the whole C_agg axis comes from a single pass: the contacts passing
the angle criterion are sorted by f = F_coh/(2πγR) and merged in decreasing order with union-find,
recording granule number, granulated particles and granulated volume at every requested
threshold (Newman & Ziff, Phys. Rev. Lett. 85, 4104 (2000)). The statistics are those of
:func:`granalytics.frame_stats` for GNA at each (C_agg, A_agg) — a test checks equality with
independent identifications. Frames are processed in parallel threads (the kernels release the
GIL); frames are read from the file in the calling thread.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from granalytics.identification import kernels as _kernels
from granalytics.analysis.metrics import HEADLINE, GranuleCounts, metric_values
from granalytics.core.windows import window_mask
from granalytics.identification.cohesion import COHESION, DEFAULT_COHESION
from granalytics.base.errors import ParameterError
from granalytics.analysis.frames import map_frames
from granalytics.identification.contacts import (COMOTION, DEFAULT_COMOTION, DEFAULT_RIGID_SCALE, RIGID_SCALE, comotion_mask,
                                                 contact_strength)
from granalytics.identification.common import A_AGG_DEG, C_AGG, MIN_SIZE, RADIUS_MODE
from granalytics.base.validation import POSITIVE, WINDOW, Array, Instance, validate_params

__all__ = ["sensitivity", "sensitivity_summary", "COMOTION_COLUMNS", "comotion_column", "SWEEP_CONSTRAINTS"]

_METRICS = HEADLINE
#: the column of the co-motion threshold in a sensitivity table, by co-motion test
COMOTION_COLUMNS = {"angle": "a_agg_deg", "rigid": "rigid_tol"}
#: the constraints (:mod:`granalytics.base.validation`) of a one-pass threshold sweep's parameters
#: (:func:`sensitivity`, :func:`~granalytics.size_class_grid`): thresholds one number or a list of them
SWEEP_CONSTRAINTS = {
    "c_agg": [C_AGG, Array(ndim=1, within=C_AGG)], "a_agg_deg": [A_AGG_DEG, Array(ndim=1, within=A_AGG_DEG), None],
    "rigid_tol": [POSITIVE, Array(ndim=1, within=POSITIVE), None], "radius": [RADIUS_MODE],
    "surface_tension": [POSITIVE, None], "cohesion": [COHESION], "comotion": [COMOTION], "rigid_scale": [RIGID_SCALE],
    "min_size": [MIN_SIZE],
}


def comotion_column(table) -> str:
    """The co-motion threshold's column of a :func:`sensitivity` table or its summary
    (``a_agg_deg`` or ``rigid_tol``)."""
    for column in COMOTION_COLUMNS.values():
        if column in table:
            return column
    raise ParameterError(f"the table has no co-motion threshold column ({' or '.join(COMOTION_COLUMNS.values())})")


def _frame_sweep(snapshot, c_desc, thresholds, radius, gamma, cohesion, comotion, rigid_scale, min_size):
    f = contact_strength(snapshot, radius, gamma, cohesion)
    volume = snapshot.particle_volume
    n = snapshot.n_particles
    n_initial = snapshot.meta.n_particles if snapshot.meta is not None else n
    v_mean = volume.mean()
    column = COMOTION_COLUMNS[comotion]
    rows = []
    for a in thresholds:
        passes = comotion_mask(snapshot, comotion, **({"a_agg_deg": a} if comotion == "angle"
                                                      else {"rigid_tol": a, "rigid_scale": rigid_scale}))
        n_gran, n_in, v_in = _kernels.threshold_sweep(
            snapshot.contact_i, snapshot.contact_j, f, passes, volume, c_desc, min_size)
        counts = GranuleCounts(n_granules=n_gran, n_in_granules=n_in, granule_volume_m3=v_in, n_particles=n,
                               n_initial=n_initial, mean_particle_volume_m3=v_mean)
        rows.append(pd.DataFrame({
            "time_s": snapshot.time, "step": snapshot.step, "revolutions": snapshot.revolutions,
            "cohesion": cohesion, "c_agg": c_desc, column: a, "n_granules": n_gran,
            **metric_values(counts, HEADLINE),  # every headline metric of the registry, at every threshold pair
        }))
    return pd.concat(rows, ignore_index=True)


def threshold_grid(c_agg, a_agg_deg, rigid_tol, comotion, caller):
    """The grid of a one-pass threshold sweep, its values checked by :data:`SWEEP_CONSTRAINTS`: the
    C_agg values, unique and descending (float array), and the co-motion thresholds, unique and
    ascending (a list: A_agg [deg] for ``comotion="angle"``, rigid tolerances for ``"rigid"``);
    ``caller`` names the function in the errors. Raises :class:`ParameterError` for an empty list,
    or for the other comotion's thresholds given."""
    name, other = ("a_agg_deg", "rigid_tol") if comotion == "angle" else ("rigid_tol", "a_agg_deg")
    given = {"a_agg_deg": a_agg_deg, "rigid_tol": rigid_tol}
    if given[other] is not None:
        raise ParameterError(f"{caller}: comotion={comotion!r} sweeps {name}; leave {other} out")
    if given[name] is None:
        raise ParameterError(f"{caller}: comotion={comotion!r} needs the thresholds {name}")
    c = np.atleast_1d(np.asarray(c_agg, dtype=float))
    a_list = sorted({float(a) for a in np.atleast_1d(given[name])})  # each threshold once, as each C_agg
    for what, values in (("c_agg", c), (name, a_list)):
        if len(values) == 0:
            raise ParameterError(f"{caller}: {what} must hold at least one threshold, got none")
    return np.unique(c)[::-1].copy(), a_list


@validate_params(SWEEP_CONSTRAINTS)
def sensitivity(frames, c_agg, a_agg_deg=None, *, radius="pair", surface_tension=None, cohesion=DEFAULT_COHESION,
                comotion=DEFAULT_COMOTION, rigid_tol=None, rigid_scale=DEFAULT_RIGID_SCALE, min_size=2,
                jobs=1, scheduler=None, progress=False):
    """GNA statistics of every frame at every (C_agg, A_agg), or every (C_agg, rigid_tol) with
    the rigid co-motion test.

    Parameters
    ----------
    frames : Run, RunSlice or sequence of Snapshot
    c_agg : sequence of float
        Cohesion thresholds (≥ 0).
    a_agg_deg : sequence of float
        Angle thresholds [deg], each in (0, 180]; with ``comotion="angle"`` (required there).
    radius, surface_tension, cohesion, rigid_scale, min_size :
        As for :class:`~granalytics.GraphNetworkAnalysis` (``cohesion``: which force is F_coh,
        ``"acting"`` or ``"bridge"``; see :mod:`granalytics.identification.cohesion`).
    comotion : {"angle", "rigid"}, default "angle"
        The co-motion test; its thresholds are ``a_agg_deg`` or ``rigid_tol``.
    rigid_tol : sequence of float
        Tolerances of the rigid test (each > 0); with ``comotion="rigid"`` (required there).
    jobs, scheduler :
        Where the frames are analysed: ``jobs`` threads here, or a dask cluster (a scheduler's
        address or a ``distributed.Client``); see :func:`granalytics.analysis.frames.map_frames`.
    progress : bool
        Progress bar over frames.

    Returns
    -------
    DataFrame
        One row per (frame, c_agg, co-motion threshold), sorted by frame, threshold, then C_agg
        ascending, with ``frame`` (index in the run file, or in the list), ``time_s`` [s], ``step``,
        ``revolutions``, ``cohesion``, ``c_agg``, ``a_agg_deg`` (or ``rigid_tol``), ``n_granules``,
        ``n_granules_norm``, ``yield_fraction``, ``mean_volume_norm`` (definitions of
        :func:`~granalytics.frame_stats`).
    """
    c_desc, a_list = threshold_grid(c_agg, a_agg_deg, rigid_tol, comotion, "sensitivity")
    frame_ids, tables = map_frames(
        frames, lambda snapshot: _frame_sweep(snapshot, c_desc, a_list, radius, surface_tension, cohesion, comotion,
                                              rigid_scale, int(min_size)),
        progress=progress, desc="sensitivity", jobs=jobs, scheduler=scheduler)
    for frame, table in zip(frame_ids, tables):
        table.insert(0, "frame", int(frame))
    out = pd.concat(tables, ignore_index=True)
    return out.sort_values(["frame", COMOTION_COLUMNS[comotion], "c_agg"], kind="stable", ignore_index=True)


@validate_params({"table": [Instance(pd.DataFrame, "the DataFrame of sensitivity()")],
                  "window": [WINDOW, None]})
def sensitivity_summary(table: pd.DataFrame, window=None) -> pd.DataFrame:
    """Mean and standard deviation over frames of each metric at each (C_agg, co-motion threshold).

    Parameters
    ----------
    table : output of :func:`sensitivity`
    window : (float, float), optional
        Revolution window; all frames when None.
    """
    threshold = next((c for c in COMOTION_COLUMNS.values() if c in table), "a_agg_deg")
    need = [threshold, "c_agg", *(["revolutions"] if window is not None else []), *_METRICS]
    missing = [c for c in need if c not in table]
    if missing:
        raise ParameterError(f"sensitivity_summary: table must be the DataFrame of sensitivity() (columns "
                             f"{', '.join(need)}), got a DataFrame without {missing[0]!r}")
    if table.empty:
        raise ParameterError("sensitivity_summary: the table has no rows (no frame was analysed)")
    if window is not None:
        lo, hi = (float(w) for w in window)
        table = table[window_mask(table["revolutions"], lo, hi)]
        if table.empty:
            raise ParameterError(f"no frame in the window [{lo:g}, {hi:g}] revolutions")
    keys = ["cohesion", threshold, "c_agg"] if "cohesion" in table else [threshold, "c_agg"]
    grouped = table.groupby(keys)[list(_METRICS)]
    out = grouped.agg(["mean", "std"])
    out.columns = [f"{m}_{stat}" for m, stat in out.columns]
    out["n_frames"] = grouped.size()
    return out.reset_index()


