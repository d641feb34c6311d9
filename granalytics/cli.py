"""Command-line interface: ``granalytics info|identify|stats``.

Errors about the input (files, frames, parameters) are printed as one line on stderr with exit
status 2, never as a traceback.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import os
import sys
import warnings

import numpy as np

from . import __version__
from ._atomic import check_output_folder, write_atomically
from .cohesion import COHESION_CONVENTIONS, DEFAULT_COHESION
from .errors import GranalyticsError, ParameterError, ValidationError
from .identify import BACKENDS, make_identifier
from .io import open_run
from .stats import DEFAULT_WINDOW_REV, check_window, run_stats, size_distribution, steady_state


def _interval(text):
    """Parse ``A:B`` into a pair of floats."""
    try:
        lo, hi = (float(x) for x in text.split(":"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected START:STOP (two numbers), got {text!r}") from None
    if not (math.isfinite(lo) and math.isfinite(hi) and lo <= hi):
        raise argparse.ArgumentTypeError(f"expected START <= STOP, got {text!r}")
    return lo, hi


#: most values a START:STOP:NUM grid may have (a sensitivity table has frames × C × A rows)
_MAX_GRID = 10_000


def _grid(text):
    """Parse ``START:STOP:NUM`` (NUM evenly spaced values, both ends included) or ``A,B,C``."""
    try:
        if ":" in text:
            start, stop, num = text.split(":")
            num = int(num)
            if not 1 <= num <= _MAX_GRID:
                raise argparse.ArgumentTypeError(f"NUM must be in [1, {_MAX_GRID}], got {num} in {text!r}")
            values = np.linspace(float(start), float(stop), num)
        else:
            values = np.array([float(x) for x in text.split(",") if x.strip()])
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected START:STOP:NUM or a comma-separated list, got {text!r}") from None
    if values.size == 0 or not np.isfinite(values).all():
        raise argparse.ArgumentTypeError(f"no valid values in {text!r}")
    return values


def _setting(text):
    """Parse ``METHOD.PARAM=VALUE`` (VALUE as number, true/false/none, or text)."""
    try:
        key, value = text.split("=", 1)
        method, param = key.split(".", 1)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected METHOD.PARAM=VALUE, got {text!r}") from None
    lowered = value.strip().lower()
    if lowered in ("true", "false"):
        parsed = lowered == "true"
    elif lowered == "none":
        parsed = None
    else:
        try:
            parsed = int(value)
        except ValueError:
            try:
                parsed = float(value)
            except ValueError:
                parsed = value
    return method.strip(), param.strip(), parsed


def _add_cohesion_option(parser):
    parser.add_argument("--cohesion", choices=COHESION_CONVENTIONS, default=DEFAULT_COHESION,
                        help="which force is F_coh: 'acting' = the cohesion the DEM code applied (a separated "
                             "bridge's force; 0 for touching pairs unless the run applied capillary force in contact), "
                             "'bridge' = the bridge force of every wet pair, touching or not (default acting)")


def _add_gna_options(parser):
    group = parser.add_argument_group("granule identification (graph network analysis, paper §2.2)")
    _add_cohesion_option(group)
    group.add_argument("--c-agg", type=float, default=0.6, help="cohesion threshold: keep F_coh >= C_agg·2πγR (default 0.6)")
    group.add_argument("--a-agg-deg", type=float, default=20.0, help="co-motion threshold angle A_agg in degrees (default 20)")
    group.add_argument("--radius", choices=("pair", "mean"), default="pair",
                       help="R in 2πγR: pair effective radius 2RiRj/(Ri+Rj) or the run's mean radius (default pair)")
    group.add_argument("--backend", choices=sorted(BACKENDS), default="fast", help="connected-components backend (default fast)")
    group.add_argument("--window-rev", type=_interval, default=None, metavar="R0:R1",
                       help="only frames within this revolution window (default: all frames)")


def _identifier(args):
    return make_identifier(
        "gna", c_agg=args.c_agg, a_agg_deg=args.a_agg_deg, radius=args.radius, backend=args.backend,
        cohesion=args.cohesion,
    )


def _frames(run, args):
    frames = run if args.window_rev is None else run.select(revolutions=args.window_rev)
    if not len(frames):
        raise ParameterError(f"{run.path}: no frame in the selection (the run has {len(run)} frames)")
    return frames


def _window_axis(frames, by="revolutions"):
    """The frames' times [s] or revolutions for :func:`~granalytics.stats.check_window`; NaN
    revolutions for a run whose drum does not turn (which check_window then reports)."""
    try:
        return frames.times if by == "time_s" else frames.revolutions
    except ValidationError:
        return np.full(len(frames), np.nan)


def _progress(args):
    return not args.quiet


def cmd_info(args):
    from .bed import bed_structure

    with open_run(args.run) as run:
        info = run.info()
        meta = run.meta.to_dict()
        bed = bed_structure(run[len(run) - 1]) if len(run) else None
    if bed is not None and bed.planar and meta.get("drum_omega"):
        warnings.warn(f"{args.run}: planar drum run, its granules and statistics are those of stacked 2-D monolayers: "
                      f"{bed.describe()} (last frame)")
    if args.json:
        print(json.dumps(_json_safe({"file": info, "meta": meta, "bed_last_frame": bed.to_dict() if bed else None}),
                         indent=2, default=str))
        return 0
    width = max(len(k) for k in list(info) + list(meta))
    print("file")
    for key, value in info.items():
        print(f"  {key:<{width}}  {value}")
    if bed is not None:
        print(f"  {'bed (last frame)':<{width}}  {bed.describe()}")
    print("run metadata (SI units; contact_angle in rad)")
    for key, value in meta.items():
        if key in ("sim_config", "provenance"):
            value = json.dumps(value) if value else "{}"
            if len(value) > 100:
                value = value[:97] + "..."
        print(f"  {key:<{width}}  {value}")
    return 0


def _json_safe(value):
    """``value`` with NaN and infinities as None: JSON has no such numbers (``json.dumps``
    would write the invalid tokens NaN and Infinity)."""
    if isinstance(value, dict):
        return {k: _json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json_safe(v) for v in value]
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def cmd_identify(args):
    import h5py

    identifier = _identifier(args)
    _check_outputs(args, others=(args.out,))
    with open_run(args.run) as run:
        frames = _frames(run, args)
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
    """Fill an open labels file: attributes, frame index and time, labels and ids per frame."""
    from tqdm.auto import tqdm

    out.attrs["format"] = "granalytics-labels"
    out.attrs["run"] = os.path.abspath(args.run)
    out.attrs["method"] = identifier.method
    out.attrs["params"] = json.dumps(identifier.params())
    out["frame_index"] = frames.frame_indices
    out["time"] = frames.times
    out["time"].attrs["unit"] = "s"
    chunked = dict(chunks=(1, n), compression="gzip", shuffle=True)
    labels = out.create_dataset("labels", (n_frames, n), dtype=np.int32, **chunked)
    ids = out.create_dataset("ids", (n_frames, n), dtype=np.int64, **chunked)
    n_granules = out.create_dataset("n_granules", (n_frames,), dtype=np.int64)
    for k, snapshot in enumerate(tqdm(frames, disable=not _progress(args), unit="frame", desc="identify")):
        result = identifier.identify(snapshot)
        labels[k] = result.labels
        ids[k] = snapshot.ids
        n_granules[k] = result.n_granules


def cmd_stats(args):
    import pandas as pd

    _check_outputs(args, tables=(args.out, args.sizes_out), plots=(args.plot,))
    by, window = ("time_s", args.window_time) if args.window_time is not None else ("revolutions", args.window)
    with open_run(args.run) as run:
        frames = _frames(run, args)
        # the window is checked on the frame times before the analysis (its warnings come with the table)
        in_window, _ = check_window(_window_axis(frames, by), window, by=by, source=args.run, warn=False)
        ts, sizes = run_stats(
            frames, "gna", progress=_progress(args), return_sizes=True,
            c_agg=args.c_agg, a_agg_deg=args.a_agg_deg, radius=args.radius, backend=args.backend,
            cohesion=args.cohesion,
        )
    steady = steady_state(ts, window=window, by=by, source=args.run)
    dist = size_distribution([s for s, keep in zip(sizes, in_window) if keep])
    if args.out:
        _write_table(ts, args.out)
        print(f"wrote time series ({len(ts)} frames) to {args.out}")
    if args.sizes_out:
        _write_table(dist, args.sizes_out)
        print(f"wrote size distribution to {args.sizes_out}")
    if args.plot:
        from .plot import stats_figure

        _save(stats_figure(ts, dist, window=window, x=by,
                           title=f"{os.path.basename(args.run)}, cohesion={args.cohesion}"), args.plot)
    lo, hi = window
    print(f"steady state over {'revolutions' if by == 'revolutions' else 'time [s]'} [{lo:g}, {hi:g}] "
          f"(C_agg={args.c_agg:g}, A_agg={args.a_agg_deg:g}°, cohesion={args.cohesion}):")
    with pd.option_context("display.float_format", "{:.5g}".format, "display.width", 120):
        print(steady.to_string())
    return 0


_TABLE_FORMATS = {".csv": "csv", ".parquet": "parquet", ".pq": "parquet"}


def _table_format(path):
    ext = os.path.splitext(path)[1].lower()
    if ext not in _TABLE_FORMATS:
        raise ParameterError(f"{path}: unknown table format {ext!r} (use .csv or .parquet)")
    return _TABLE_FORMATS[ext]


def cmd_sensitivity(args):
    from .sensitivity import sensitivity, sensitivity_summary

    _check_outputs(args, tables=(args.out, args.frames_out), plots=(args.plot,))
    if (args.c_agg < 0).any():
        raise ParameterError(f"--c-agg values must be >= 0, got min {args.c_agg.min():g}")
    bad = [a for a in args.a_agg_deg if not 0 < a <= 180]
    if bad:
        raise ParameterError(f"--a-agg-deg values must be in (0, 180] degrees, got {bad[0]:g}")
    with open_run(args.run) as run:
        check_window(_window_axis(run), args.window, source=args.run)  # refuses an empty window, warns for an uncovered one
        frames = run.select(revolutions=args.window)
        table = sensitivity(frames, args.c_agg, args.a_agg_deg, radius=args.radius, cohesion=args.cohesion,
                            jobs=args.jobs, progress=not args.quiet)
    summary = sensitivity_summary(table)
    if args.frames_out:
        _write_table(table, args.frames_out)
        print(f"wrote per-frame table ({len(table)} rows) to {args.frames_out}")
    if args.out:
        _write_table(summary, args.out)
        print(f"wrote summary over {len(frames)} frames ({len(summary)} grid points) to {args.out}")
    if args.plot:
        from .plot import sensitivity_figure

        _save(sensitivity_figure(summary, title=f"{os.path.basename(args.run)}, revolutions "
                                 f"[{args.window[0]:g}, {args.window[1]:g}], cohesion={args.cohesion}"), args.plot)
    import pandas as pd

    shown = summary[["a_agg_deg", "c_agg", "yield_fraction_mean", "n_granules_norm_mean", "mean_volume_norm_mean"]]
    with pd.option_context("display.float_format", "{:.4g}".format, "display.width", 120, "display.max_rows", 40):
        print(shown.to_string(index=False))
    return 0


def cmd_compare(args):
    from .compare import compare_methods

    _check_outputs(args, tables=(args.out, args.stats_out), plots=(args.plot,))
    methods = {name: (name, {}) for name in args.methods}
    for method, param, value in args.set or []:
        if method not in methods:
            raise ParameterError(f"--set {method}.{param}: {method!r} is not among --methods {','.join(methods)}")
        methods[method][1][param] = value
    with open_run(args.run) as run:
        frames = _frames(run, args)
        stats, pairs = compare_methods(frames, methods, cohesion=args.cohesion, progress=not args.quiet)
    if args.out:
        _write_table(pairs, args.out)
        print(f"wrote pairwise comparison to {args.out}")
    if args.stats_out:
        _write_table(stats, args.stats_out)
        print(f"wrote per-method statistics to {args.stats_out}")
    if args.plot:
        from .plot import comparison_figure

        _save(comparison_figure(stats, pairs, title=f"{os.path.basename(args.run)}, cohesion={args.cohesion}"), args.plot)
    import pandas as pd

    mean_stats = stats.groupby("method", sort=False)[["n_granules_norm", "yield_fraction", "mean_volume_norm"]].mean()
    mean_pairs = pairs.groupby(["method_a", "method_b"], sort=False)[["ari", "d_n_granules_norm", "d_yield_fraction"]].mean()
    with pd.option_context("display.float_format", "{:.4g}".format, "display.width", 120):
        print(f"means over {len(frames)} frames")
        print(mean_stats.to_string())
        print(mean_pairs.to_string())
    return 0


def cmd_compare_cg(args):
    import inspect

    from .cg import CGComparison, compare_cg
    from .identify import METHODS

    labels = [x.strip() for x in args.labels.split(",")] if args.labels else None
    accepted = inspect.signature(METHODS[args.method]).parameters
    params = {k: v for k, v in (("c_agg", args.c_agg), ("a_agg_deg", args.a_agg_deg)) if k in accepted}
    for param, value in args.set or []:
        params[param] = value
    CGComparison.check_outputs(args.out, overwrite=args.overwrite)  # before minutes of analysis
    comparison = compare_cg(args.runs, labels, window=args.window, method=args.method, cohesion=args.cohesion,
                            progress=not args.quiet, **params)
    written = comparison.save(args.out, overwrite=args.overwrite)
    print(f"wrote {len(written)} files to {args.out}: " + ", ".join(os.path.basename(p) for p in written))
    print(format_cg_table(comparison))
    return 0


def format_cg_table(comparison) -> str:
    """The CG table as text: steady-state mean ± s.e.m. of each metric, its deviation from the
    reference run, the KS distance of the size distributions and the speed-ups."""
    lines = [f"CG comparison, {comparison.description}; deviations from {comparison.reference}"]
    header = (f"{'run':<26} {'yield':>19} {'<V_g>/V_p':>21} {'N_g/N':>23} {'KS D':>6} "
              f"{'speed-up*':>9} {'paper':>6}")
    lines.append(header)
    for row in comparison.table.itertuples():
        cells = []
        for metric, fmt in (("yield_fraction", ".3f"), ("mean_volume_norm", ".2f"), ("n_granules_norm", ".4f")):
            mean, sem, dev = (getattr(row, f"{metric}_{x}") for x in ("mean", "sem", "rel_dev"))
            cells.append(f"{mean:{fmt}} ± {sem:{fmt}} ({dev:+.0%})")
        lines.append(f"{row.run:<26} {cells[0]:>19} {cells[1]:>21} {cells[2]:>23} {row.ks_distance:>6.3f} "
                     f"{row.speedup:>8.1f}× {row.paper_speedup:>5.1f}×")
    lines.append("* wall time per simulated second recorded by the simulator in each run; runs that shared the "
                 "machine unevenly give unfair ratios (benchmarks/cg_speedup.py measures them side by side)")
    return "\n".join(lines)


def cmd_subset(args):
    from .io import subset_run, thinned_frames

    if args.every < 1:
        raise ParameterError(f"--every must be >= 1, got {args.every}")
    if os.path.abspath(args.out) == os.path.abspath(args.run):
        raise ParameterError(f"{args.out}: --out is the input run")
    if os.path.exists(args.out) and not args.overwrite:
        raise ParameterError(f"{args.out}: file exists (pass --overwrite to replace it)")
    with open_run(args.run) as run:
        n_frames = len(run)
        # revolutions only where a window of them is asked for (a static run has none)
        frames = thinned_frames(run.times if args.full_window is None else run.revolutions, args.every,
                                args.full_window)
    subset_run(args.run, args.out, frames, float_dtype="float32" if args.float32 else "float64",
               overwrite=args.overwrite, progress=not args.quiet)
    print(f"wrote {args.out}: {len(frames)} of {n_frames} frames"
          + (", float32" if args.float32 else "") + f", {os.path.getsize(args.out) / 1e6:.1f} MB")
    return 0


def cmd_export_vtk(args):
    from .io import WriterLock
    from .io.vtk import export_vtk

    if os.path.exists(args.out) and not os.path.isdir(args.out):
        raise ParameterError(f"{args.out}: exists and is not a folder")
    try:  # before the export, not after its first frame
        os.makedirs(args.out, exist_ok=True)
    except OSError as exc:
        raise ParameterError(f"{args.out}: cannot create the output folder ({exc.strerror or exc})") from None
    pvd_path = os.path.join(args.out, "run.pvd")
    with WriterLock(pvd_path), open_run(args.run) as run:  # one export at a time into the folder
        if os.path.exists(pvd_path) and not args.overwrite:
            raise ParameterError(f"{pvd_path}: exists (pass --overwrite to replace the export in {args.out})")
        frames = _frames(run, args)
        ids = frames.frame_indices if hasattr(frames, "frame_indices") else range(len(frames))
        existing = [p for p in (os.path.join(args.out, f"frame_{int(k):05d}.vtu") for k in ids) if os.path.exists(p)]
        if existing and not args.overwrite:
            raise ParameterError(f"{existing[0]}: exists (pass --overwrite to replace {len(existing)} frame file(s) "
                                 f"in {args.out})")
        pvd = export_vtk(frames, args.out, "gna", progress=not args.quiet, c_agg=args.c_agg,
                         a_agg_deg=args.a_agg_deg, radius=args.radius, backend=args.backend,
                         cohesion=args.cohesion)
    print(f"wrote {len(frames)} frames and {pvd} (open it in ParaView)")
    return 0


def cmd_convert(args):
    from tqdm.auto import tqdm

    from .io import RunWriter, replacing_run
    from .io.lammps import DumpMapping, read_liggghts

    _check_new_file(args.out, args.overwrite)  # before reading the dumps
    if args.source == "yade":
        from .io.yade import read_yade_csv

        snapshots, meta = read_yade_csv(args.particles, args.contacts, args.mapping)
    else:
        snapshots, meta = read_liggghts(args.particles, args.contacts, DumpMapping.from_toml(args.mapping), dt=args.dt_s)
    with replacing_run(args.out, args.overwrite) as tmp, RunWriter(tmp, meta, overwrite=True) as writer:
        for snapshot in tqdm(snapshots, disable=args.quiet, unit="frame", desc="convert"):
            writer.append(snapshot)
    print(f"wrote {args.out}: {len(snapshots)} frames of {meta.n_particles} particles")
    return 0


def _save(fig, path):
    ext = os.path.splitext(path)[1].lstrip(".").lower() or "png"
    try:
        write_atomically(path, lambda tmp: fig.savefig(tmp, dpi=120, format=ext))
    except (OSError, ValueError) as exc:
        raise GranalyticsError(f"{path}: cannot write plot ({exc})") from None
    print(f"wrote plot to {path}")


def _check_new_file(path, overwrite):
    """Before any work: refuse to replace an existing file unless ``--overwrite``, a folder
    always, and a file whose folder does not exist or is not writable."""
    if os.path.isdir(path):
        raise ParameterError(f"{path}: is a folder, expected a file name")
    if os.path.exists(path) and not overwrite:
        raise ParameterError(f"{path}: file exists (pass --overwrite to replace it)")
    check_output_folder(path)


def _check_plot_path(path):
    """Refuse a figure file whose extension matplotlib's Agg canvas cannot write."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    formats = sorted(FigureCanvasAgg.get_supported_filetypes())
    ext = os.path.splitext(path)[1].lstrip(".").lower()
    if ext not in formats:
        raise ParameterError(f"{path}: unknown figure format {ext!r} (use one of {', '.join(formats)})")


def _check_table_paths(*paths):
    """Fail before any work if an output table has an unknown format."""
    for path in paths:
        if path:
            _table_format(path)


def _check_outputs(args, tables=(), others=(), plots=()):
    """Before any work: output tables and figures have a known format, no two outputs are the
    same file, none is the input run, none exists unless ``--overwrite``, and each one's folder
    exists and is writable."""
    paths = [p for p in (*tables, *others, *plots) if p]
    seen = {os.path.abspath(args.run): "the input run"} if getattr(args, "run", None) else {}
    for path in paths:
        key = os.path.abspath(path)
        if key in seen:
            raise ParameterError(f"{path}: the same file is given twice ({seen[key]} and an output)")
        seen[key] = path
    _check_table_paths(*tables)
    for path in plots:
        if path:
            _check_plot_path(path)
    for path in paths:
        _check_new_file(path, args.overwrite)


def _write_table(table, path):
    try:
        if _table_format(path) == "csv":
            write_atomically(path, lambda tmp: table.to_csv(tmp, index=False))
        else:
            write_atomically(path, lambda tmp: table.to_parquet(tmp, index=False))
    except OSError as exc:
        raise GranalyticsError(f"{path}: cannot write ({exc})") from None


def build_parser():
    parser = argparse.ArgumentParser(prog="granalytics", description="Granule analytics for wet-granulation DEM runs.")
    parser.add_argument("--version", action="version", version=f"granalytics {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    p = sub.add_parser("info", help="what a run file holds", description="Print what a run file holds: frames, particles, time span, metadata.")
    p.add_argument("run", help="run file (.h5)")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=cmd_info)

    p = sub.add_parser("identify", help="granule labels per frame to a file",
                       description="Identify granules in every frame and write the labels (−1 = free particle) to an HDF5 file.")
    p.add_argument("run", help="run file (.h5)")
    p.add_argument("--out", required=True, help="labels file to write (.h5): datasets labels, ids, time, frame_index, n_granules")
    p.add_argument("--overwrite", action="store_true", help="replace an existing labels file")
    _add_gna_options(p)
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_identify)

    p = sub.add_parser("stats", help="granulation time series and steady-state table",
                       description="Granule number, mean volume and yield per frame; steady-state averages over a revolution window.")
    p.add_argument("run", help="run file (.h5)")
    p.add_argument("--window", type=_interval, default=DEFAULT_WINDOW_REV, metavar="R0:R1",
                   help="steady-state window in revolutions (default 3:6)")
    p.add_argument("--out", help="time series table to write (.csv or .parquet)")
    p.add_argument("--sizes-out", help="particles-per-granule distribution over the window (.csv or .parquet)")
    p.add_argument("--plot", help="figure of the time series and size distribution (.png, .pdf, .svg)")
    p.add_argument("--window-time", type=_interval, metavar="T0:T1",
                   help="steady-state window in seconds instead of revolutions (any run, also without a rotating drum)")
    p.add_argument("--overwrite", action="store_true", help="replace existing output files")
    _add_gna_options(p)
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_stats)

    p = sub.add_parser("sensitivity", help="GNA statistics over a C_agg × A_agg grid",
                       description="Yield, granule number and mean granule volume of every frame in a revolution window "
                                   "at every (C_agg, A_agg), the C_agg axis in one pass per frame; mean ± std over the window.")
    p.add_argument("run", help="run file (.h5)")
    p.add_argument("--c-agg", type=_grid, default=_grid("0.1:1.0:19"), metavar="GRID",
                   help="cohesion thresholds: START:STOP:NUM or a list (default 0.1:1.0:19)")
    p.add_argument("--a-agg-deg", type=_grid, default=_grid("5,10,20,45,90"), metavar="GRID",
                   help="angle thresholds in degrees (default 5,10,20,45,90)")
    p.add_argument("--window", type=_interval, default=DEFAULT_WINDOW_REV, metavar="R0:R1",
                   help="revolution window (default 3:6)")
    p.add_argument("--radius", choices=("pair", "mean"), default="pair", help="R in 2πγR (default pair)")
    _add_cohesion_option(p)
    p.add_argument("--jobs", type=int, default=1, help="worker threads over frames (default 1)")
    p.add_argument("--out", help="summary table over the window (.csv or .parquet)")
    p.add_argument("--frames-out", help="per-frame table (.csv or .parquet)")
    p.add_argument("--plot", help="heatmaps and line plots (.png, .pdf, .svg)")
    p.add_argument("--overwrite", action="store_true", help="replace existing output files")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_sensitivity)

    p = sub.add_parser("compare-methods", help="compare identification methods frame by frame",
                       description="Run several identification methods on the same frames; adjusted Rand index and "
                                   "differences of granule number and yield for every pair.")
    p.add_argument("run", help="run file (.h5)")
    p.add_argument("--methods", type=lambda t: [m.strip() for m in t.split(",") if m.strip()],
                   default=["gna", "dbscan", "sieve", "community"], help="comma-separated (default gna,dbscan,sieve,community)")
    p.add_argument("--set", action="append", type=_setting, metavar="METHOD.PARAM=VALUE",
                   help="a method parameter, e.g. dbscan.eps_diameters=1.2 or gna.a_agg_deg=30 (repeatable)")
    _add_cohesion_option(p)
    p.add_argument("--window-rev", type=_interval, default=None, metavar="R0:R1",
                   help="only frames within this revolution window (default: all frames)")
    p.add_argument("--out", help="pairwise comparison per frame (.csv or .parquet)")
    p.add_argument("--stats-out", help="statistics per frame and method (.csv or .parquet)")
    p.add_argument("--plot", help="figure (.png, .pdf, .svg)")
    p.add_argument("--overwrite", action="store_true", help="replace existing output files")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_compare)

    p = sub.add_parser("compare-cg", help="compare runs at several CG factors (paper Figs 3–6)",
                       description="Granule volume, number, size distribution and yield of runs of one system at "
                                   "several CG factors α: the paper's Figs 3–6 (PNG and PDF), a table of steady-state "
                                   "mean ± std (block s.e.m.) with the relative deviation from the finest run, the "
                                   "Kolmogorov–Smirnov distance of the size distributions, and the measured CG speed-up.")
    p.add_argument("runs", nargs="+", help="run files (.h5), at least two")
    p.add_argument("--out", required=True, help="output folder: cg_table.csv, cg_timeseries.csv, cg_sizes.csv, fig3–fig6 .png/.pdf")
    p.add_argument("--labels", help="comma-separated run names (default: CG<α> (<N> particles))")
    p.add_argument("--window", type=_interval, default=DEFAULT_WINDOW_REV, metavar="R0:R1",
                   help="steady-state window in revolutions (default 3:6)")
    p.add_argument("--method", choices=("gna", "dbscan", "sieve", "community"), default="gna",
                   help="identification method (default gna, the paper's)")
    p.add_argument("--c-agg", type=float, default=0.6, help="cohesion threshold C_agg (default 0.6)")
    p.add_argument("--a-agg-deg", type=float, default=20.0, help="angle threshold A_agg in degrees (default 20)")
    p.add_argument("--set", action="append", type=lambda t: _setting("method." + t)[1:], metavar="PARAM=VALUE",
                   help="another method parameter, e.g. radius=mean or eps_diameters=1.2 (repeatable)")
    _add_cohesion_option(p)
    p.add_argument("--overwrite", action="store_true", help="replace existing output files")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_compare_cg)

    p = sub.add_parser("subset", help="copy some frames of a run, optionally as float32",
                       description="Write a smaller copy of a run: every --every-th frame, plus every frame inside "
                                   "--full-window; --float32 stores floating-point data in single precision.")
    p.add_argument("run", help="run file (.h5)")
    p.add_argument("--out", required=True, help="run file to write (.h5)")
    p.add_argument("--every", type=int, default=1, help="keep every N-th frame (default 1: all)")
    p.add_argument("--full-window", type=_interval, metavar="R0:R1",
                   help="keep every frame within this revolution window")
    p.add_argument("--float32", action="store_true", help="store floats as float32 (read back as float64)")
    p.add_argument("--overwrite", action="store_true", help="replace an existing file")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_subset)

    from .study import add_study_parser
    from .tracking import add_track_parser

    add_track_parser(sub)
    add_study_parser(sub)
    p = sub.add_parser("sweep", help="run a parameter sweep of the simulator on dask (same as python -m sim sweep)",
                       description="Run a parameter sweep of the bundled simulator on dask: the arguments are those of "
                                   "'python -m sim sweep' (SPEC.toml --out DIR [--workers N] [--scheduler ADDR]); "
                                   "see docs/parameter_studies.md.", add_help=False)
    p.add_argument("sweep_args", nargs=argparse.REMAINDER, help="SPEC.toml --out DIR [--workers N] [--scheduler ADDR]")
    # handled in main() before parsing: the sweep runner lives in the simulator and is imported only then

    p = sub.add_parser("export-vtk", help="VTK files for ParaView (one .vtu per frame + .pvd)",
                       description="Write particles (radius, velocities, film, granule label and size) and bonds "
                                   "(kept by GNA or not, F_coh, bridge volume, gap) per frame, plus a .pvd time series.")
    p.add_argument("run", help="run file (.h5)")
    p.add_argument("--out", required=True, help="output folder")
    p.add_argument("--overwrite", action="store_true", help="replace an earlier export of the same run in the folder")
    _add_gna_options(p)
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_export_vtk)

    p = sub.add_parser("convert", help="convert LIGGGHTS/LAMMPS dumps into a run file",
                       description="Read particle dumps (dump custom) and contact dumps (compute pair/gran/local + dump local), "
                                   "plain or gzip, one or many timesteps per file, and write a granalytics run file.")
    p.add_argument("particles", nargs="+", help="particle dump files (LIGGGHTS) or particle CSVs (YADE export)")
    p.add_argument("--from", dest="source", choices=("liggghts", "yade"), default="liggghts",
                   help="liggghts (LIGGGHTS/LAMMPS dumps) or yade (CSVs of docs/yade_export.py)")
    p.add_argument("--contacts", nargs="+", required=True, help="contact dump files or contact CSVs")
    p.add_argument("--mapping", required=True, help="TOML file: for liggghts units, contact columns and material metadata "
                   "(granalytics.io.lammps.DumpMapping); for yade surface_tension, density, drum_omega, contact_angle, alpha")
    p.add_argument("--dt-s", type=float, help="simulation time step in seconds (liggghts: time = timestep × dt; "
                   "yade files carry their time)")
    p.add_argument("--out", required=True, help="run file to write (.h5)")
    p.add_argument("--overwrite", action="store_true", help="replace an existing run file")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_convert)
    return parser


def main(argv=None):
    """Entry point of the ``granalytics`` console script; returns the exit status."""
    argv = sys.argv[1:] if argv is None else list(argv)
    if argv[:1] == ["sweep"]:  # the simulator's own command line, options and --help included
        from sim.sweep import main as sweep_main

        return sweep_main(argv[1:])
    args = build_parser().parse_args(argv)
    import matplotlib

    matplotlib.use("Agg")  # the command line only writes figures to files
    from . import configure_threading

    configure_threading()
    with warnings_as_lines("granalytics"):
        try:
            return args.func(args)
        except (GranalyticsError, OSError, ValueError, OverflowError) as exc:  # bad input or environment: one line
            print(f"granalytics: error: {exc}", file=sys.stderr)
            return 2


@contextlib.contextmanager
def warnings_as_lines(prog):
    """Inside: every warning that Python's filters let through is printed as one line
    ``PROG: warning: message`` on stderr, instead of Python's file, line and source."""
    def show(message, category, filename, lineno, file=None, line=None):
        print(f"{prog}: warning: {' '.join(str(message).split())}", file=sys.stderr)

    with warnings.catch_warnings():
        warnings.showwarning = show
        yield


if __name__ == "__main__":
    sys.exit(main())
