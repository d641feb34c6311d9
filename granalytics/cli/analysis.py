"""Analysis commands: info, identify, stats, sensitivity, compare-methods, compare-cg."""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import os
import warnings

import numpy as np

from granalytics.base.resources import check_memory
from granalytics.core.windows import clip_window, window_mask
from granalytics.analysis.metrics import HEADLINE, METRICS
from granalytics.analysis.system import check_replicas, run_identity
from granalytics.base.errors import GranalyticsError, ParameterError
from granalytics.base.files import WriterLock, write_atomically
from granalytics.outputs import output_folder, staged_outputs
from granalytics.identification import DEFAULT_METHODS, accepted_params
from granalytics.identification.common import PAPER_A_AGG_DEG, PAPER_C_AGG
from granalytics.core import open_run
from granalytics.analysis.stats import DEFAULT_WINDOW_REV, check_window, run_stats, size_distribution, steady_state
from granalytics.cli._common import (resolve_rigid_options, threshold_options, add_cohesion_option, add_continuation_option,
                                     add_criterion_options, add_frame_loop_options, add_gna_options, add_size_unit_option, criterion_params,
                                     check_outputs, frame_loop, gna_identifier, grid,
                                     interval, json_safe, plus_minus, progress, revolution_window, run_metas,
                                     save_figure, selected_frames, setting, add_window_options, add_frame_window_options,
                                     warn_if_c_agg_unreachable, warn_if_unfinished, window_axis, write_table)


def add_info_parser(sub):
    """Add the ``info`` command to ``sub`` (``ArgumentParser.add_subparsers``)."""
    p = sub.add_parser("info", help="what a run file holds", description="Print what a run file holds: frames, particles, time span, metadata.")
    p.add_argument("run", help="run file (.h5)")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=cmd_info)
    return p


def add_identify_parser(sub):
    """Add the ``identify`` command to ``sub`` (``ArgumentParser.add_subparsers``)."""
    p = sub.add_parser("identify", help="granule labels per frame to a file",
                       description="Identify granules in every frame and write the labels (−1 = free particle) to an HDF5 file.")
    p.add_argument("run", help="run file (.h5)")
    p.add_argument("--out", required=True, help="labels file to write (.h5): datasets labels, ids, granule_track, time, frame_index, n_granules")
    p.add_argument("--overwrite", action="store_true", help="replace an existing labels file")
    add_gna_options(p)
    add_continuation_option(p)
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_identify)
    return p


def add_stats_parser(sub):
    """Add the ``stats`` command to ``sub`` (``ArgumentParser.add_subparsers``)."""
    p = sub.add_parser("stats", help="granulation time series and steady-state table",
                       description="Granule number, mean volume and yield per frame; steady-state averages over a revolution window.")
    p.add_argument("run", help="run file (.h5)")
    add_window_options(p)
    p.add_argument("--out", help="time series table to write (.csv or .parquet)")
    p.add_argument("--steady-out", help="steady-state table (mean, std, block s.e.m. per metric; .csv or .parquet)")
    p.add_argument("--sizes-out", help="granule-size distribution over the window (.csv or .parquet; sizes in "
                                        "--size-unit)")
    p.add_argument("--plot", help="figure of the time series and size distribution (.png, .pdf, .svg)")
    p.add_argument("--replica", action="append", default=[], metavar="RUN",
                   help="a replica of RUN (the same system at another seed; repeatable): the steady state is then "
                        "the mean over the replicas with the replica s.e. beside the block s.e.m. (also in --steady-out)")
    p.add_argument("--overwrite", action="store_true", help="replace existing output files")
    add_size_unit_option(p)
    add_gna_options(p, time_twin=False)
    add_frame_loop_options(p)
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_stats)
    return p


def add_sensitivity_parser(sub):
    """Add the ``sensitivity`` command to ``sub`` (``ArgumentParser.add_subparsers``)."""
    p = sub.add_parser("sensitivity", help="GNA statistics over a C_agg × A_agg grid",
                       description="Yield, granule number and mean granule volume of every frame in a revolution window "
                                   "at every (C_agg, A_agg), the C_agg axis in one pass per frame; mean ± std over the window.")
    p.add_argument("run", help="run file (.h5)")
    p.add_argument("--c-agg", type=grid, default=grid("0.1:1.0:19"), metavar="GRID",
                   help="cohesion thresholds: START:STOP:NUM or a list (default 0.1:1.0:19)")
    p.add_argument("--a-agg-deg", type=grid, default=grid("5,10,20,45,90"), metavar="GRID",
                   help="angle thresholds in degrees (default 5,10,20,45,90)")
    add_window_options(p, what="window of the frames averaged")
    p.add_argument("--radius", choices=("pair", "mean"), default="pair", help="R in 2πγR (default pair)")
    add_cohesion_option(p)
    add_criterion_options(p, grid_tol=True)
    add_frame_loop_options(p)
    p.add_argument("--out", help="summary table over the window (.csv or .parquet)")
    p.add_argument("--frames-out", help="per-frame table (.csv or .parquet)")
    p.add_argument("--plot", help="heatmaps and line plots (.png, .pdf, .svg)")
    p.add_argument("--overwrite", action="store_true", help="replace existing output files")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_sensitivity)
    return p


def add_compare_methods_parser(sub):
    """Add the ``compare-methods`` command to ``sub`` (``ArgumentParser.add_subparsers``)."""
    p = sub.add_parser("compare-methods", help="compare identification methods frame by frame",
                       description="Run several identification methods on the same frames; adjusted Rand index and "
                                   "differences of granule number and yield for every pair.")
    p.add_argument("run", help="run file (.h5)")
    p.add_argument("--methods", type=lambda t: [m.strip() for m in t.split(",") if m.strip()],
                   default=list(DEFAULT_METHODS), help=f"comma-separated (default {','.join(DEFAULT_METHODS)})")
    p.add_argument("--set", action="append", type=setting, metavar="METHOD.PARAM=VALUE",
                   help="a method parameter, e.g. dbscan.eps_diameters=1.2 or gna.a_agg_deg=30 (repeatable); "
                        "custom.criterion takes comparisons of a contact-table column with a number joined by "
                        "and/or/not, e.g. 'custom.criterion=0.5 <= f_norm and (angle_v_deg < 30 or angle_w_deg < 30)' "
                        "(no arithmetic or function calls: docs/identification.md)")
    add_cohesion_option(p)
    add_frame_window_options(p, time_twin=False)
    add_window_options(p, what="steady-state window of the printed means")
    p.add_argument("--out", help="pairwise comparison per frame (.csv or .parquet)")
    p.add_argument("--stats-out", help="statistics per frame and method (.csv or .parquet)")
    p.add_argument("--plot", help="figure (.png, .pdf, .svg)")
    p.add_argument("--overwrite", action="store_true", help="replace existing output files")
    add_frame_loop_options(p)
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_compare)
    return p


def add_compare_cg_parser(sub):
    """Add the ``compare-cg`` command to ``sub`` (``ArgumentParser.add_subparsers``)."""
    p = sub.add_parser("compare-cg", help="compare runs at several CG factors (paper Figs 3–6)",
                       description="Granule volume, number, size distribution and yield of runs of one system at "
                                   "several CG factors α: the paper's Figs 3–6 (PNG and PDF), a table of steady-state "
                                   "mean ± block s.e.m. (± replica s.e., the block s.e.m. beside it, with --replicas) "
                                   "with the relative deviation from the finest run ± its s.e., the "
                                   "Kolmogorov–Smirnov distance of the size distributions, and the measured CG speed-up.")
    p.add_argument("runs", nargs="+", help="run files (.h5), at least two")
    p.add_argument("--out", required=True, help="output folder: cg_table.csv, cg_timeseries.csv, cg_sizes.csv, fig3–fig6 .png/.pdf")
    p.add_argument("--labels", help="comma-separated run names (default: CG<α> (<N> particles))")
    p.add_argument("--replicas", action="store_true",
                   help="runs with equal α and particle count are replicas (other seeds) of one system: compare "
                        "their mean, with the replica standard error beside the block s.e.m. (one label per group)")
    add_window_options(p)
    p.add_argument("--mixed-systems", action="store_true",
                   help="compare runs that are not coarse-grained from one original system (their original "
                        "parameters differ in more than seed, α and CG rule) with a warning instead of a refusal")
    p.add_argument("--method", choices=DEFAULT_METHODS, default="gna",
                   help="identification method (default gna, the paper's)")
    p.add_argument("--c-agg", type=grid, default=None, metavar="C",
                   help="cohesion threshold C_agg (default 0.6; only for methods that take it); a grid "
                        "(START:STOP:NUM or a list) compares the runs at every threshold pair instead")
    p.add_argument("--a-agg-deg", type=grid, default=None, metavar="A",
                   help="angle threshold A_agg in degrees (default 20); a grid (e.g. 10,20,45) as for --c-agg")
    p.add_argument("--set", action="append", type=lambda t: setting("method." + t)[1:], metavar="PARAM=VALUE",
                   help="another method parameter, e.g. radius=mean or eps_diameters=1.2 (repeatable)")
    add_cohesion_option(p)
    add_criterion_options(p)
    add_size_unit_option(p)
    p.add_argument("--overwrite", action="store_true", help="replace existing output files")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_compare_cg)
    return p


def cmd_info(args):
    from granalytics.analysis.confinement import run_confinement
    from granalytics.analysis.bed import bed_structure
    from granalytics.analysis.confinement import confinement_warning
    from granalytics.analysis.cg import cg_rule_of, cg_rule_warning

    with open_run(args.run) as run:
        warn_if_unfinished(run)
        info = run.info()
        meta = run.meta.to_dict()
        bed = bed_structure(run[len(run) - 1]) if len(run) else None
        drum = run_confinement(run.meta)
        rule = cg_rule_of(run.meta)
    if bed is not None and bed.planar and meta.get("drum_omega"):
        warnings.warn(f"{args.run}: planar drum run, its granules and statistics are those of stacked 2-D monolayers: "
                      f"{bed.describe()} (last frame)")
    if drum is not None and (warning := confinement_warning(drum.drum_ratio)):
        warnings.warn(f"{args.run}: {warning}")
    if warning := cg_rule_warning(rule, meta.get("alpha")):
        warnings.warn(f"{args.run}: {warning}")
    if args.json:
        print(json.dumps(json_safe({"file": info, "meta": meta, "bed_last_frame": bed.to_dict() if bed else None,
                                    "confinement": drum.to_dict() if drum else None}), indent=2, default=str))
        return 0
    width = max(len(k) for k in list(info) + list(meta))
    print("file")
    for key, value in info.items():
        print(f"  {key:<{width}}  {_shown(value)}")
    if bed is not None:
        print(f"  {'bed (last frame)':<{width}}  {bed.describe()}")
    if drum is not None:
        print(f"  {'drum':<{width}}  {drum.describe()}")
    sim_params = (meta.get("sim_config") or {}).get("params")
    if isinstance(sim_params, dict) and sim_params:  # a run of our simulator; runs before laws had names: the linear one
        law = sim_params.get("contact_law", "linear_coulomb")
        print(f"  {'contact law':<{width}}  {law} (the simulator's; its parameters in sim_config.params)")
        print(f"  {'CG rule':<{width}}  {rule} (α = {meta.get('alpha', 1):g}; {_RULE_SAYS.get(rule, '')})")
        print(f"  {'time step':<{width}}  {_time_step_line(sim_params, meta['sim_config'].get('steps_per_contact'))}")
    print("run metadata (SI units; contact_angle in rad)")
    for key, value in meta.items():
        if key in ("sim_config", "provenance"):
            value = json.dumps(value) if value else "{}"
            if len(value) > 100:
                value = value[:97] + "..."
        print(f"  {key:<{width}}  {_shown(value)}")
    return 0


def _time_step_line(sim_params: dict, steps_per_contact) -> str:
    """``info``'s line on the simulator's step: Δt, the factor applied after the CG rule and t_c/Δt."""
    dt, factor = sim_params.get("dt"), sim_params.get("dt_factor", 1.0)
    if not isinstance(dt, (int, float)):
        return "not recorded"
    said = f"Δt = {dt:.4g} s, {factor:g} × the CG rule's step"
    if isinstance(steps_per_contact, (int, float)):
        said += f", t_c/Δt = {steps_per_contact:.4g} (mean pair)"
    return said


#: what ``info`` says of a CG rule
_RULE_SAYS = {"weber": "forces × α²: the Weber number kept, the Bond number × 1/α",
              "bond": "forces × α³: the Bond and Froude numbers kept, the Weber number × 1/α"}


def _shown(value):
    """A value of ``info`` as text: floats to 6 significant digits (``--json`` keeps every digit)."""
    if isinstance(value, float):
        return f"{value:.6g}"
    if isinstance(value, (list, tuple)) and value and all(isinstance(v, float) for v in value):
        return "[" + ", ".join(f"{v:.6g}" for v in value) + "]"
    return value


def cmd_identify(args):
    import h5py

    identifier = gna_identifier(args)
    check_outputs(args, others=(args.out,))
    # one writer at a time on the labels file (OUT.lock), the output checked again under the lock
    with WriterLock(args.out), open_run(args.run) as run:
        check_outputs(args, others=(args.out,))
        frames = selected_frames(run, args)
        n_frames, n = len(frames), run.n_particles

        def write(tmp):  # renamed into place only when every frame is written
            try:
                out = h5py.File(tmp, "w")
            except OSError as exc:
                raise GranalyticsError(f"{args.out}: cannot create labels file ({exc})") from None
            with out:
                _write_labels(out, args, frames, identifier, n_frames, n)
                return out["n_granules"][:]

        counts = write_atomically(args.out, write)
    print(f"wrote {args.out}: labels of {n} particles in {n_frames} frames "
          f"(granules per frame: min {counts.min()}, mean {counts.mean():.1f}, max {counts.max()})")
    return 0


def _write_labels(out, args, frames, identifier, n_frames, n):
    """Fill an open labels file: attributes, frame index and time, labels, ids and granule track
    ids per frame."""
    from granalytics.analysis.frames import map_frames

    out.attrs["format"] = "granalytics-labels"
    out.attrs["run"] = os.path.abspath(args.run)
    out.attrs["method"] = identifier.method
    out.attrs["params"] = json.dumps(identifier.params())
    out.attrs["continuation"] = args.continuation
    out["frame_index"] = frames.frame_indices
    out["time"] = frames.times
    out["time"].attrs["unit"] = "s"
    chunked = dict(chunks=(1, n), compression="gzip", shuffle=True)
    labels = out.create_dataset("labels", (n_frames, n), dtype=np.int32, **chunked)
    ids = out.create_dataset("ids", (n_frames, n), dtype=np.int64, **chunked)
    n_granules = out.create_dataset("n_granules", (n_frames,), dtype=np.int64)
    written = iter(range(n_frames))  # one thread: the frames come in order

    def write_frame(snapshot):
        k, result = next(written), identifier.identify(snapshot)
        labels[k], ids[k], n_granules[k] = result.labels, snapshot.ids, result.n_granules

    map_frames(frames, write_frame, progress=progress(args), desc="identify", what="identify")
    # the granule track of every particle (-1 free): the id that a granule keeps while it lives
    from granalytics.analysis.tracking import track_granules

    tracks = track_granules([labels[k] for k in range(n_frames)], [ids[k] for k in range(n_frames)], frames.times,
                            continuation=args.continuation)
    granule_track = out.create_dataset("granule_track", (n_frames, n), dtype=np.int64, **chunked)
    for k in range(n_frames):
        lab, mapping = labels[k], tracks.labels_to_tracks[k]
        granule_track[k] = np.where(lab >= 0, mapping[np.maximum(lab, 0)] if mapping.size else -1, -1)


def cmd_stats(args):
    check_outputs(args, tables=(args.out, args.steady_out, args.sizes_out), plots=(args.plot,))  # before the locks
    with contextlib.ExitStack() as locks:  # one writer at a time on each output (OUT.lock), checked again under it
        for path in (args.out, args.steady_out, args.sizes_out, args.plot):
            if path:
                locks.enter_context(WriterLock(path))
        return _stats(args)


def _stats(args):
    import pandas as pd

    check_outputs(args, tables=(args.out, args.steady_out, args.sizes_out), plots=(args.plot,))
    by, window = (("time_s", args.window_time) if args.window_time is not None
                  else ("revolutions", args.window if args.window is not None else DEFAULT_WINDOW_REV))
    params = dict(c_agg=args.c_agg, a_agg_deg=args.a_agg_deg, radius=args.radius, backend=args.backend,
                  cohesion=args.cohesion, **criterion_params(args))
    with open_run(args.run) as run:
        frames = selected_frames(run, args)
        # the window is checked on the frame times before the analysis (its warnings come with the table)
        axis = window_axis(frames, by)
        in_window, tol = check_window(axis, window, by=by, source=args.run, warn=False)
        used = clip_window(axis, *window, tol)  # the window over the run's frames (steady_state's)
        ts, sizes = run_stats(frames, "gna", progress=progress(args), return_sizes=True, **frame_loop(args), **params)
        meta = run.meta
    series = [ts]
    if args.replica:  # one system at other seeds, and no copy of a run (before the replicas' analysis)
        identities = []
        for path in [args.run, *args.replica]:
            with open_run(path) as replica:
                identities.append(run_identity(replica))
        check_replicas(identities)
    for path in args.replica:  # replicas: the steady state is over all of them (steady_state of a list)
        with open_run(path) as replica:
            series.append(run_stats(selected_frames(replica, args), "gna", progress=progress(args), **frame_loop(args),
                                    **params))
    steady = steady_state(series if args.replica else ts, window=window, by=by, source=args.run)
    dist = size_distribution([s for s, keep in zip(sizes, in_window) if keep], size_unit=args.size_unit, alpha=meta,
                             min_size=args.min_size or 2)  # the bins start at the smallest size that can occur
    with staged_outputs() as stage:  # every output, or none (a failing figure replaces no table)
        if args.out:
            write_table(ts, args.out, stage)
        if args.steady_out:
            write_table(steady.reset_index(), args.steady_out, stage)
        if args.sizes_out:
            write_table(dist, args.sizes_out, stage)
        if args.plot:
            import matplotlib.pyplot as plt

            from granalytics.plot import stats_figure

            test = (f"rigid_tol={args.rigid_tol:g}" if args.comotion == "rigid" else f"A_agg={args.a_agg_deg:g}°")
            fig = stats_figure(ts, dist, window=used, x=by,  # the window the mean is over, clipped to the run
                               title=f"{os.path.basename(args.run)}: GNA C_agg={args.c_agg:g}, {test}, "
                                     f"min_size={args.min_size}, cohesion={args.cohesion}"
                                     + (f" (window {window[0]:g}:{window[1]:g} clipped to the run)"
                                        if used != tuple(window) else ""))
            try:
                save_figure(fig, args.plot, stage)
            finally:
                plt.close(fig)
    if args.out:
        print(f"wrote time series ({len(ts)} frames) to {args.out}")
    if args.steady_out:
        print(f"wrote the steady-state table to {args.steady_out}")
    if args.sizes_out:
        print(f"wrote size distribution to {args.sizes_out}")
    lo, hi = used
    clipped = f" (the window {window[0]:g}:{window[1]:g} clipped to the run's frames)" if used != tuple(window) else ""
    print(f"steady state over {'revolutions' if by == 'revolutions' else 'time [s]'} [{lo:.4g}, {hi:.4g}]{clipped} "
          f"(C_agg={args.c_agg:g}, A_agg={args.a_agg_deg:g}°, cohesion={args.cohesion})"
          + (f", mean over {args.run} and {len(args.replica)} replica(s):" if args.replica else ":"))
    shown = steady if args.replica else steady.rename(columns={"sem": "block_sem"})
    with pd.option_context("display.float_format", "{:.5g}".format, "display.width", 120):
        print(shown.to_string(na_rep="n/a"))
    if args.replica:
        print("replica_sem: standard error of the mean over the replicas (std of the replica means / √n); "
              "replica_std: standard deviation of the replica means; block_sem: what the replicas' block s.e.m. "
              "say of the same mean, √(Σ sem_i²)/n")
    else:
        print("std: over the frames of the window; block_sem: standard error of the mean from the means of its "
              "blocks (the sem column of --steady-out)")
    for note in _steady_error_notes(steady, by, replicas=bool(args.replica)):
        print(note)
    return 0


def _steady_error_notes(steady, by, *, replicas=False) -> list:
    """Why an error of a printed steady-state table is n/a, one line per reason (none when every
    error is there)."""
    error = "block_sem" if replicas else "sem"
    missing = steady[steady[error].isna()]
    if not len(missing):
        return []
    empty = missing["mean"].isna()
    notes = []
    if empty.any():
        notes.append(f"n/a: {', '.join(missing.index[empty])}: no frame of the window has a value (no granules)")
    if (~empty).any():
        blocks = "quarter revolutions" if by == "revolutions" else "blocks"
        what = "a replica's window holds" if replicas else "the window holds"
        notes.append(f"n/a: {', '.join(missing.index[~empty])}: no block s.e.m.: {what} a single block "
                     f"(fewer than two {blocks} of frames), too short to estimate it; widen the window")
    return notes


def cmd_sensitivity(args):
    from granalytics.analysis.sensitivity import sensitivity, sensitivity_summary

    check_outputs(args, tables=(args.out, args.frames_out), plots=(args.plot,))
    if (args.c_agg < 0).any():
        raise ParameterError(f"--c-agg values must be >= 0, got min {args.c_agg.min():g}")
    bad = [a for a in args.a_agg_deg if not 0 < a <= 180]
    if bad:
        raise ParameterError(f"--a-agg-deg values must be in (0, 180] degrees, got {bad[0]:g}")
    resolve_rigid_options(args, grid_tol=True)
    if (args.rigid_tol <= 0).any():
        raise ParameterError(f"--rigid-tol values must be > 0, got min {args.rigid_tol.min():g}")
    rigid = args.comotion == "rigid"
    thresholds = dict(a_agg_deg=None if rigid else args.a_agg_deg, rigid_tol=args.rigid_tol if rigid else None,
                      comotion=args.comotion, rigid_scale=args.rigid_scale, min_size=args.min_size)
    with open_run(args.run) as run:
        warn_if_unfinished(run)
        args.window = revolution_window(args, [run.meta])
        check_window(window_axis(run), args.window, source=args.run)  # refuses an empty window, warns for an uncovered one
        frames = run.select(revolutions=args.window)
        # the per-frame table: one row of about 120 bytes per frame and grid point, built in memory
        points = len(args.c_agg) * (len(args.rigid_tol) if rigid else len(args.a_agg_deg))
        check_memory(f"sensitivity over {len(frames)} frames × {points} grid points", 120 * 2 * len(frames) * points)
        if len(frames):
            warn_if_c_agg_unreachable(frames, args.c_agg, args.cohesion, args.radius)
        table = sensitivity(frames, args.c_agg, radius=args.radius, cohesion=args.cohesion, progress=not args.quiet,
                            **frame_loop(args), **thresholds)
    summary = sensitivity_summary(table)
    if args.frames_out:
        write_table(table, args.frames_out)
        print(f"wrote per-frame table ({len(table)} rows) to {args.frames_out}")
    if args.out:
        write_table(summary, args.out)
        print(f"wrote summary over {len(frames)} frames ({len(summary)} grid points) to {args.out}")
    if args.plot:
        from granalytics.plot import sensitivity_figure

        save_figure(sensitivity_figure(summary, title=f"{os.path.basename(args.run)}, revolutions "
                                 f"[{args.window[0]:g}, {args.window[1]:g}], cohesion={args.cohesion}"), args.plot)
    import pandas as pd

    shown = summary[["rigid_tol" if rigid else "a_agg_deg", "c_agg", *(f"{name}_mean" for name in HEADLINE)]]
    print(f"mean over the frames of revolutions [{args.window[0]:g}, {args.window[1]:g}] at each threshold pair "
          f"(cohesion={args.cohesion}; F_coh >= C_agg·2πγR keeps a contact, so above the largest F_coh/(2πγR) of "
          "the run nothing is kept)")
    with pd.option_context("display.float_format", "{:.4g}".format, "display.width", 120, "display.max_rows", 40):
        print(shown.to_string(index=False))
    return 0


def cmd_compare(args):
    from granalytics.analysis.method_comparison import compare_methods

    check_outputs(args, tables=(args.out, args.stats_out), plots=(args.plot,))
    methods = {name: (name, {}) for name in args.methods}
    for method, param, value in args.set or []:
        if method not in methods:
            raise ParameterError(f"--set {method}.{param}: {method!r} is not among --methods {','.join(methods)}")
        methods[method][1][param] = value
    with open_run(args.run) as run:
        args.window = revolution_window(args, [run.meta])
        frames = selected_frames(run, args)
        stats, pairs = compare_methods(frames, methods, cohesion=args.cohesion, progress=not args.quiet,
                                       **frame_loop(args))
    if args.out:
        write_table(pairs, args.out)
        print(f"wrote pairwise comparison to {args.out}")
    if args.stats_out:
        write_table(stats, args.stats_out)
        print(f"wrote per-method statistics to {args.stats_out}")
    if args.plot:
        from granalytics.plot import comparison_figure

        uses = [m for m in methods if m != "dbscan" or methods[m][1].get("bridged_only")]  # DBSCAN on positions has no F_coh
        save_figure(comparison_figure(stats, pairs, title=f"{os.path.basename(args.run)}, cohesion={args.cohesion} "
                                                          f"(for {', '.join(uses) or 'no method'})"), args.plot)
    import pandas as pd

    # the printed means are steady-state means over --window, as in stats (the tables hold every frame)
    lo, hi = args.window
    inside = window_mask(stats["revolutions"].to_numpy(dtype=float), lo, hi)
    if not inside.any():
        warnings.warn(f"{args.run}: no compared frame in the window [{lo:g}, {hi:g}] revolutions: the means below "
                      "are over every compared frame")
        inside[:] = True
    frames_in = set(stats["frame"][inside])
    mean_stats = stats[inside].groupby("method", sort=False)[list(HEADLINE)].mean()
    mean_pairs = pairs[pairs["frame"].isin(frames_in)].groupby(["method_a", "method_b"], sort=False)[
        ["ari", *(f"d_{name}" for name in HEADLINE)]].mean()
    with pd.option_context("display.float_format", "{:.4g}".format, "display.width", 120):
        print(f"means over the {len(frames_in)} frames in the window [{lo:g}, {hi:g}] revolutions")
        print(mean_stats.to_string())
        print(mean_pairs.to_string())
    return 0


def _paper_criterion(args) -> bool:
    """Whether the co-motion and size-floor options are the paper's (angle test, pairs count)."""
    return criterion_params(args) == {"comotion": "angle", "min_size": 2}


#: the formats of compare-cg's figures
_CG_FORMATS = ("png", "pdf")


def cmd_compare_cg(args):
    from granalytics.analysis.cg import CGComparison, compare_cg, group_replicas
    from granalytics.plot import cg_figure_names

    labels = [x.strip() for x in args.labels.split(",")] if args.labels else None
    grids = [g for g in (args.c_agg, args.a_agg_deg) if g is not None]
    if any(len(g) > 1 for g in grids):
        if args.replicas:
            raise ParameterError("--replicas: a threshold grid compares single runs; leave --replicas out")
        return _compare_cg_thresholds(args, labels)
    # one value each: the standard comparison at that pair (args keep their grids)
    single = argparse.Namespace(**{name: None if getattr(args, name) is None else float(getattr(args, name)[0])
                                   for name in ("c_agg", "a_agg_deg")})
    params = threshold_options(single, args.method)
    criterion = criterion_params(args)
    if args.method != "gna" and not _paper_criterion(args):
        raise ParameterError(f"--comotion / --min-size: method {args.method!r} has no such parameters (GNA's)")
    params.update(accepted_params(args.method, **criterion))
    for param, value in args.set or []:
        params[param] = value
    figure_files = [f"{name}.{ext}" for name in cg_figure_names() for ext in _CG_FORMATS]
    CGComparison.check_outputs(args.out, overwrite=args.overwrite, others=figure_files)  # before minutes of analysis
    runs = group_replicas(args.runs) if args.replicas else args.runs
    args.window = revolution_window(args, run_metas(args.runs), args.runs)
    comparison = compare_cg(runs, labels, window=args.window, method=args.method, cohesion=args.cohesion,
                            progress=not args.quiet, mixed_systems=args.mixed_systems, **params)
    written = _write_cg(comparison, args.out, args.size_unit)
    print(f"wrote {len(written)} files to {args.out}: " + ", ".join(os.path.basename(p) for p in written))
    print(format_cg_table(comparison))
    return 0


def _write_cg(comparison, out, size_unit) -> list:
    """The comparison's tables and its Figs 3–6 (Fig 5's sizes in ``size_unit``), one file per
    format, written into ``out`` as one (a failure leaves every earlier output as it was). Returns
    the written paths."""
    import matplotlib.pyplot as plt

    from granalytics.plot import cg_figures

    figures = cg_figures(comparison, size_unit=size_unit)
    try:
        with output_folder(out), staged_outputs(out) as stage:
            written = comparison.save(out, stage=stage)
            for name, fig in figures.items():
                for ext in _CG_FORMATS:
                    path = os.path.join(out, f"{name}.{ext}")
                    fig.savefig(stage(path), dpi=150, format=ext)
                    written.append(path)
    except OSError as exc:
        raise ParameterError(f"{out}: cannot write the comparison ({exc})") from None
    finally:
        for fig in figures.values():
            plt.close(fig)
    return written


def _compare_cg_thresholds(args, labels) -> int:
    """compare-cg with a grid of thresholds: the deviation table and one heatmap per statistic."""
    import matplotlib.pyplot as plt

    from granalytics.analysis.cg import compare_cg_thresholds
    from granalytics.plot import cg_threshold_figures

    if args.method != "gna":
        raise ParameterError(f"--method {args.method}: a threshold grid is GNA's C_agg x A_agg (give --method gna)")
    if args.set:
        raise ParameterError("--set: a threshold grid runs GNA at its defaults otherwise; leave --set out")
    if not _paper_criterion(args):
        raise ParameterError("--comotion rigid / --min-size: a threshold grid is the paper's C_agg x A_agg at "
                             "min_size 2; compare with one threshold pair, or use granalytics sensitivity")
    c_agg = args.c_agg if args.c_agg is not None else np.array([PAPER_C_AGG])
    a_agg = args.a_agg_deg if args.a_agg_deg is not None else np.array([PAPER_A_AGG_DEG])
    if (c_agg < 0).any() or ((a_agg <= 0) | (a_agg > 180)).any():
        raise ParameterError("--c-agg values must be >= 0 and --a-agg-deg values in (0, 180] degrees")
    paths = {"table": os.path.join(args.out, "cg_thresholds.csv")}
    from granalytics.analysis.metrics import BY_FIGURE

    paths.update({m: os.path.join(args.out, f"cg_thresholds_{m}.png") for m in BY_FIGURE})
    existing = [p for p in paths.values() if os.path.exists(p)]
    if existing and not args.overwrite:
        raise ParameterError(f"{existing[0]}: exists (pass --overwrite to replace the outputs in {args.out})")
    args.window = revolution_window(args, run_metas(args.runs), args.runs)
    table = compare_cg_thresholds(args.runs, c_agg, a_agg, labels, window=args.window, cohesion=args.cohesion,
                                  progress=not args.quiet)
    figures = cg_threshold_figures(table)
    try:
        with output_folder(args.out), staged_outputs(args.out) as stage:
            write_table(table, paths["table"], stage)
            for name, fig in figures.items():
                fig.savefig(stage(paths[name.removeprefix("cg_thresholds_")]), dpi=120)
    finally:
        for fig in figures.values():
            plt.close(fig)
    finest = table.loc[table["alpha"].idxmin(), "run"]
    worst = table[table["run"] != finest]
    print(f"wrote {len(paths)} files to {args.out}: the deviation from {finest} at {len(c_agg) * len(a_agg)} threshold "
          f"pairs (window [{args.window[0]:g}, {args.window[1]:g}] revolutions, cohesion={args.cohesion})")
    for metric in BY_FIGURE:
        dev = worst[f"{metric}_rel_dev"].abs()
        if dev.notna().any():
            row = worst.loc[dev.idxmax()]
            print(f"  {METRICS[metric].label}: largest |deviation| {100 * dev.max():.0f} % ({row['run']}, C_agg = "
                  f"{row['c_agg']:g}, A_agg = {row['a_agg_deg']:g}°), median {100 * dev.median():.0f} %")
    return 0


def format_cg_table(comparison) -> str:
    """The CG table as text: the runs' size-distribution distance and speed-ups, then one block
    per headline metric with each run's steady-state mean ± its error, the block s.e.m. (in its
    own column where the ± is the replica s.e.) and the deviation from the reference run ± its
    standard error. Every error column names its error; an error that cannot be estimated is
    ``n/a`` with a note saying why."""
    table = comparison.table
    replicas = bool((table["n_replicas"] > 1).any())
    width = max(26, table["run"].str.len().max())
    lines = [f"CG comparison, {comparison.description}; deviations from {comparison.reference}",
             f"{'run':<{width}} {'replicas':>8} {'KS D':>6} {'speed-up*':>9} {'paper':>6}"]
    for row in table.itertuples():
        lines.append(f"{row.run:<{width}} {row.n_replicas:>8d} {row.ks_distance:>6.3f} {row.speedup:>8.1f}× "
                     f"{row.paper_speedup:>5.1f}×")
    error = "replica s.e." if replicas else "block s.e.m."
    notes = {}  # why an error is n/a -> the runs it is n/a for
    for metric in HEADLINE:
        label = METRICS[metric].label
        header = f"{label:<{width}} {'mean ± ' + error:>21}"
        if replicas:
            header += f" {'block s.e.m.':>12}"
        lines.append(header + f" {'deviation ± s.e.':>17}")
        for row in table.itertuples():
            mean, sem, rsem, dev, dev_se = (getattr(row, f"{metric}_{x}")
                                            for x in ("mean", "sem", "replica_sem", "rel_dev", "rel_dev_se"))
            shown_error = rsem if replicas else sem
            if not math.isfinite(shown_error):
                notes.setdefault(_cg_error_note(row, metric, mean, replicas), []).append(row.run)
            shown = plus_minus(mean, shown_error)
            if replicas and row.n_replicas == 1:  # the mean to its block s.e.m.'s figures
                shown = plus_minus(mean, sem).split(" ± ")[0] + " ± n/a"
            cells = f"{row.run:<{width}} {shown:>21}"
            if replicas:
                if not math.isfinite(sem):
                    notes.setdefault(_cg_error_note(row, metric, mean, False), []).append(row.run)
                cells += f" {format(sem, '#.2g') if math.isfinite(sem) else 'n/a':>12}"
            if row.run == comparison.reference:
                deviation = "reference"
            else:
                deviation = f"{dev:+.0%} ± " + (f"{dev_se:.0%}" if math.isfinite(dev_se) else "n/a")
            lines.append(f"{cells} {deviation:>17}")
    lines.append("* speed-up: the reference's wall time per simulated second over this run's, as the simulator "
                 "recorded them (a group: the mean over its replicas). Each run's wall time depends on what else ran "
                 "on the machine then, so a single run, a replica group and another machine give other ratios; the "
                 "load-free ratio is measured side by side by benchmarks/cg_speedup.py (docs/results.md, 'Speed-up')")
    if replicas:
        lines.append("± replica s.e.: standard deviation of a group's replica means / √n (the run-to-run error); "
                     "block s.e.m.: standard error of the mean from the means of blocks of the window, combined "
                     "over the replicas as √(Σ sem²)/n; deviation ± s.e.: from each side's replica s.e., or its "
                     "block s.e.m. for a single run")
    else:
        lines.append("± block s.e.m.: standard error of the mean from the means of blocks of the window; "
                     "deviation ± s.e.: from the two runs' block s.e.m.")
    for note, runs in notes.items():
        lines.append(f"n/a: {', '.join(dict.fromkeys(runs))}: {note}")
    return "\n".join(lines)


def _cg_error_note(row, metric, mean, replica) -> str:
    """Why an error of the CG table is n/a (the note's text, without the run)."""
    if replica and row.n_replicas == 1:
        return "a single run has no replica s.e. (its block s.e.m. is beside it, and its deviations use it)"
    if not math.isfinite(mean):
        return f"no granules in the window, no {METRICS[metric].label} to average"
    return ("no block s.e.m.: the window holds fewer than two blocks (quarter revolutions) of frames, too short "
            "to estimate it; widen --window")
