"""Data commands: subset (fewer frames, float32), export-vtk (ParaView), convert (other codes' output),
synthetic (a physics-free test run)."""

from __future__ import annotations

import contextlib
import json
import os
import sys


from granalytics.base.errors import ParameterError
from granalytics.base.files import WriterLock, check_apart, regular_input
from granalytics.report.files import output_folder, staged_outputs
from granalytics.convert.prefetch import prefetched
from granalytics.convert.registry import READERS
from granalytics.core import RunWriter, open_run, replacing_run
from granalytics.analysis.stats import check_window
from granalytics.cli.options import (add_continuation_option, add_gna_options, criterion_params, frame_stride, interval,
                                     selected_frames)
from granalytics.report.files import check_new_file, check_outputs, stream_table


def add_subset_parser(sub):
    """Add the ``subset`` command to ``sub`` (``ArgumentParser.add_subparsers``)."""
    p = sub.add_parser("subset", help="copy some frames of a run, optionally as float32",
                       description="Write a smaller copy of a run: every --every-th frame, plus every frame inside "
                                   "--full-window (every --window-every-th); --float32 stores floating-point data in "
                                   "single precision.")
    p.add_argument("run", help="run file (.h5)")
    p.add_argument("--out", required=True, help="run file to write (.h5)")
    p.add_argument("--every", type=frame_stride, default=1, help="keep every N-th frame (default 1: all)")
    full = p.add_mutually_exclusive_group()
    full.add_argument("--full-window", type=interval, metavar="R0:R1", help="keep every frame within this revolution window")
    full.add_argument("--full-window-time", type=interval, metavar="T0:T1", help="the same in seconds")
    p.add_argument("--window-every", type=frame_stride, default=1, metavar="K",
                   help="inside --full-window keep only the frames whose index is a multiple of K (default 1: all)")
    p.add_argument("--float32", action="store_true", help="store floats as float32 (read back as float64)")
    p.add_argument("--overwrite", action="store_true", help="replace an existing file")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_subset)
    return p


def add_export_vtk_parser(sub):
    """Add the ``export-vtk`` command to ``sub`` (``ArgumentParser.add_subparsers``)."""
    p = sub.add_parser("export-vtk", help="VTK files for ParaView (one .vtu per frame + .pvd)",
                       description="Write particles (radius, velocities, film, granule label and size) and bonds "
                                   "(kept by GNA or not, F_coh, bridge volume, gap) per frame, plus a .pvd time series.")
    p.add_argument("run", help="run file (.h5)")
    p.add_argument("--out", required=True, help="output folder")
    p.add_argument("--overwrite", action="store_true", help="replace an earlier export of the same run in the folder")
    add_gna_options(p)
    add_continuation_option(p)
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_export_vtk)
    return p


def add_convert_parser(sub):
    """Add the ``convert`` command to ``sub`` (``ArgumentParser.add_subparsers``)."""
    p = sub.add_parser("convert", help="convert LIGGGHTS/LAMMPS dumps into a run file",
                       description="Read particle dumps (dump custom) and contact dumps (compute pair/gran/local + dump local), "
                                   "plain or gzip, one or many timesteps per file, and write a granalytics run file. "
                                   "Frames are read and written one at a time (memory of about two frames); "
                                   "an interrupted conversion keeps the frames written and --append adds the rest.")
    p.add_argument("particles", nargs="+", help="particle dump files (LIGGGHTS), particle CSVs (YADE export), or a "
                                                "VTKRecorder folder or its files (yade-vtk)")
    p.add_argument("--from", dest="source", choices=tuple(READERS), default="liggghts",
                   help="; ".join(f"{r.name}: {r.description}" for r in READERS.values()) + " (default liggghts)")
    p.add_argument("--contacts", nargs="+", default=[], help="contact dump files or contact CSVs (not for yade-vtk, "
                                                              "whose folder holds them)")
    p.add_argument("--mapping", required=True, help="TOML file: for liggghts units, contact columns and material metadata "
                   "(granalytics.convert.lammps.DumpMapping); for yade surface_tension, density, drum_omega, contact_angle, alpha; "
                   "for yade-vtk those and bridge_volume (docs/readers.md)")
    p.add_argument("--dt-s", type=float, help="simulation time step in seconds (liggghts, yade-vtk: time = timestep "
                   "× dt; yade CSVs carry their time)")
    p.add_argument("--out", required=True, help="run file to write (.h5)")
    p.add_argument("--overwrite", action="store_true", help="replace an existing run file")
    p.add_argument("--append", action="store_true",
                   help="add the frames of the files after --out's last timestep to it (a run converted so far, or "
                        "an interrupted conversion); the files must describe the same system")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_convert)
    return p


def cmd_subset(args):
    from granalytics.core import subset_run, thinned_frames

    if args.every < 1:
        raise ParameterError(f"--every must be >= 1, got {args.every}")
    if args.window_every != 1 and args.full_window is None and args.full_window_time is None:
        raise ParameterError(f"--window-every {args.window_every} thins --full-window; give one")
    # not the input (links resolved), no device, --overwrite
    check_outputs(others=(args.out,), overwrite=args.overwrite, run=args.run)
    with open_run(args.run) as run:
        n_frames = len(run)
        # revolutions only where a window of them is asked for (a static run has none)
        if args.full_window_time is not None:
            check_window(run.times, args.full_window_time, by="time_s", source=args.run)
            frames = thinned_frames(run.times, args.every, args.full_window_time, args.window_every)
        else:
            if args.full_window is not None:
                check_window(run.revolutions, args.full_window, source=args.run)  # warns when the run does not cover it
            frames = thinned_frames(run.times if args.full_window is None else run.revolutions, args.every,
                                    args.full_window, args.window_every)
    subset_run(args.run, args.out, frames, float_dtype="float32" if args.float32 else "float64",
               overwrite=args.overwrite, progress=not args.quiet)
    print(f"wrote {args.out}: {len(frames)} of {n_frames} frames"
          + (", float32" if args.float32 else "") + f", {os.path.getsize(args.out) / 1e6:.1f} MB")
    return 0


def cmd_export_vtk(args):
    from granalytics.export.vtk import export_vtk

    pvd_path = os.path.join(args.out, "run.pvd")
    # the folder made before the export (and removed again if the export fails and leaves it empty),
    # one export at a time into it
    with output_folder(args.out), WriterLock(pvd_path), open_run(args.run) as run:
        if os.path.exists(pvd_path) and not args.overwrite:
            raise ParameterError(f"{pvd_path}: exists (pass --overwrite to replace the export in {args.out})")
        frames = selected_frames(run, args)
        ids = frames.frame_indices if hasattr(frames, "frame_indices") else range(len(frames))
        existing = [p for p in (os.path.join(args.out, f"frame_{int(k):05d}.vtu") for k in ids) if os.path.exists(p)]
        if existing and not args.overwrite:
            raise ParameterError(f"{existing[0]}: exists (pass --overwrite to replace {len(existing)} frame file(s) "
                                 f"in {args.out})")
        pvd = export_vtk(frames, args.out, "gna", continuation=args.continuation, progress=not args.quiet,
                         c_agg=args.c_agg, a_agg_deg=args.a_agg_deg, radius=args.radius, backend=args.backend,
                         cohesion=args.cohesion, **criterion_params(args))
    print(f"wrote {len(frames)} frames and {pvd} (open it in ParaView)")
    return 0


def cmd_convert(args):
    from granalytics.base.resources import check_disk, check_memory
    from granalytics.convert.registry import open_run_files

    if READERS[args.source].needs_dt and args.dt_s is None:
        raise ParameterError(f"--dt-s: {args.source} files do not record the time step; give it in seconds "
                             "(time = timestep × dt)")
    if READERS[args.source].needs_contacts and not args.contacts:
        raise ParameterError(f"--contacts: {args.source} reads the contacts from their own files; give them")
    if args.append and args.overwrite:
        raise ParameterError("--append adds frames to --out and --overwrite replaces it: give one of them")
    inputs = [*args.particles, *args.contacts, args.mapping]
    check_apart(args.out, inputs, "converted run")  # --overwrite must never replace an input
    for path in inputs:
        regular_input(path)
    if args.append:
        if not os.path.exists(args.out):
            raise ParameterError(f"{args.out}: no such run to --append to")
    else:
        check_new_file(args.out, args.overwrite)  # before reading the dumps
    source = open_run_files(args.source, args.particles, args.contacts, args.mapping, args.dt_s)  # headers only
    check_memory(f"converting {args.particles[0]} (three frames at a time)", 3 * source.frame_bytes())
    check_disk(f"the converted run {args.out}", _converted_size(source, inputs), args.out)
    if args.append:
        return _convert_append(args, source)
    existed, kept = os.path.exists(args.out), None
    source = prefetched(source)  # the next frame is read while this one is written
    with contextlib.closing(source), replacing_run(args.out, args.overwrite) as tmp:
        writer = None
        try:
            with _ReadingBar(source, args.quiet) as bar:
                first = source.first()
                with RunWriter(tmp, source.meta, overwrite=True) as writer:
                    _append_frames(writer, source, bar)
        except KeyboardInterrupt:
            if existed or writer is None or not writer.n_frames:
                raise  # an earlier file stays as it was; nothing read is nothing kept
            kept = writer.n_frames
            _mark_interrupted(tmp, kept)
    if kept:
        print(f"convert: interrupted; {args.out} holds the first {kept} frames (marked unfinished); the same "
              "command with --append adds the rest", file=sys.stderr)
        return 130
    print(f"wrote {args.out}: {writer.n_frames} frames of {first.n_particles} particles")
    return 0


def _converted_size(source, inputs) -> int:
    """The disk a converted run needs [bytes], estimated from the files its reader reads (those
    of a folder included): about 0.6 of their text, which gzip keeps in about a third of it."""
    gzipped = any(str(p).endswith(".gz") for p in inputs)
    return int(0.6 * source.total_bytes * (3 if gzipped else 1))


class _ReadingBar:
    """The progress bar of a conversion: bytes of the input files read (as stored), the rate,
    the time left and the frames written; on from before the first frame is read."""

    def __init__(self, source, quiet):
        from tqdm.auto import tqdm

        self.source = source
        self.bar = tqdm(total=source.total_bytes, unit="B", unit_scale=True, desc="convert", disable=quiet,
                        mininterval=1.0)

    def frame(self, n_frames):
        self.bar.update(self.source.bytes_read - self.bar.n)
        self.bar.set_postfix_str(f"{n_frames} frames", refresh=False)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.bar.close()


def _append_frames(writer, source, bar) -> None:
    for snapshot in source:
        writer.append(snapshot)
        bar.frame(writer.n_frames)


def _mark_interrupted(path, n_frames) -> None:
    """Record in ``path``'s provenance that its conversion stopped after ``n_frames`` frames."""
    import h5py

    with h5py.File(path, "r+") as f:
        provenance = json.loads(f["meta"].attrs["provenance"])
        provenance["interrupted"] = f"the conversion stopped after {n_frames} frames; convert --append adds the rest"
        f["meta"].attrs["provenance"] = json.dumps(provenance, sort_keys=True)


#: the run metadata that the frames --append adds must share with the run
_SAME_SYSTEM = ("n_particles", "surface_tension", "density", "drum_omega", "alpha", "contact_angle",
                "capillary_in_contact")


def _convert_append(args, source) -> int:
    """``convert --append``: the frames of the files after the run's last timestep, added to it."""
    with open_run(args.out) as run:
        n_frames, last_step, meta = len(run), int(run.steps[-1]) if len(run) else -1, run.meta
    source.start_after(last_step)
    source = prefetched(source)
    with contextlib.closing(source), _ReadingBar(source, args.quiet) as bar:
        source.first()
        for name in _SAME_SYSTEM:
            ours, theirs = getattr(meta, name), getattr(source.meta, name)
            if ours != theirs:
                raise ParameterError(f"--append: {args.out} has {name} = {ours!r}, the files give {theirs!r}: "
                                     "they are not the same run")
        with RunWriter.continue_from(args.out, n_frames) as writer:
            writer.update_provenance(interrupted=None, appended_files=[*args.particles, *args.contacts])
            _append_frames(writer, source, bar)
    print(f"appended {writer.n_frames - n_frames} frames to {args.out} (after timestep {last_step}): "
          f"{writer.n_frames} frames")
    return 0


def add_synthetic_parser(sub):
    """Add the ``synthetic`` command to ``sub``."""
    p = sub.add_parser("synthetic", help="write a physics-free synthetic run (planted granules, for tests and demos)",
                       description="Write a physics-free synthetic run (planted granules; not simulation output).")
    p.add_argument("--out", required=True, help="run file to write (.h5)")
    p.add_argument("--particles", type=int, default=3000, help="number of particles (default 3000)")
    p.add_argument("--revolutions", type=float, default=6.0, help="drum revolutions covered (default 6)")
    p.add_argument("--frames-per-revolution", type=int, default=20, help="default 20")
    p.add_argument("--alpha", type=float, default=1.0, help="CG factor α (default 1)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--overwrite", action="store_true", help="replace an existing run file")
    p.set_defaults(func=cmd_synthetic)
    return p


def cmd_synthetic(args) -> int:
    from granalytics.datasets.synthetic import write_synthetic_run

    check_new_file(args.out, args.overwrite)
    path = write_synthetic_run(args.out, args.particles, args.revolutions, args.frames_per_revolution,
                               alpha=args.alpha, seed=args.seed, overwrite=args.overwrite)
    print(f"wrote synthetic (physics-free) run {path}")
    return 0


def add_table_parser(sub):
    """Add the ``table`` command to ``sub``."""
    p = sub.add_parser("table", help="tidy per-particle table: one row per particle and frame, with granule and track id",
                       description="One row per particle and frame (frame, time_s, revolutions, id, x, y, z, vx, vy, "
                                   "vz, wx, wy, wz, radius, film_volume, granule, granule_track), written frame by "
                                   "frame (.parquet or .csv). granule_track keeps its value while a granule lives, "
                                   "by default through the events it survives as the main branch (docs/tracking.md).")
    p.add_argument("run", help="run file (.h5)")
    p.add_argument("--out", required=True, help="table to write (.parquet or .csv)")
    p.add_argument("--overwrite", action="store_true", help="replace an existing table")
    add_gna_options(p)
    add_continuation_option(p)
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_table)
    return p


def cmd_table(args) -> int:
    from granalytics.analysis.particle_tables import particle_frames

    check_outputs(tables=(args.out,), overwrite=args.overwrite, run=args.run)
    with WriterLock(args.out), open_run(args.run) as run, staged_outputs() as stage:
        check_outputs(tables=(args.out,), overwrite=args.overwrite, run=args.run)
        frames = selected_frames(run, args)
        pieces = particle_frames(frames, "gna", continuation=args.continuation, progress=not args.quiet,
                                 c_agg=args.c_agg, a_agg_deg=args.a_agg_deg,
                                 radius=args.radius, backend=args.backend, cohesion=args.cohesion,
                                 **criterion_params(args))
        rows = stream_table(pieces, args.out, stage)
    print(f"wrote {args.out}: {rows} rows ({len(frames)} frames of {run.n_particles} particles)")
    return 0

