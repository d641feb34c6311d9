"""What every command shares: option parsers and adders, and the frame selection they give. The
outputs are checked and written by the report layer (:mod:`granalytics.report`)."""

from __future__ import annotations

import argparse
import math
import warnings

import numpy as np

from granalytics.identification.cohesion import COHESION_CONVENTIONS
from granalytics.base.errors import ParameterError, ValidationError
from granalytics.identification import BACKENDS, make_identifier
from granalytics.identification.contacts import warn_if_c_agg_unreachable


def gna_default(name):
    """The default of GNA's constructor parameter ``name``: the command line's default, so that a
    command and ``GraphNetworkAnalysis()`` agree (``tests/test_cli.py`` checks every option)."""
    import inspect

    from granalytics.identification.gna import GraphNetworkAnalysis

    return inspect.signature(GraphNetworkAnalysis).parameters[name].default


def interval(text):
    """Parse ``A:B`` into a pair of floats."""
    try:
        lo, hi = (float(x) for x in text.split(":"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected START:STOP (two numbers), got {text!r}") from None
    if not (math.isfinite(lo) and math.isfinite(hi) and lo <= hi):
        raise argparse.ArgumentTypeError(f"expected START <= STOP, got {text!r}")
    if not (math.isfinite(hi - lo) and abs(lo) < 1e15 and abs(hi) < 1e15):
        raise argparse.ArgumentTypeError(f"expected a window of revolutions or seconds below 1e15 in size, got {text!r}")
    return lo, hi


#: the largest frame stride an option accepts (a run has far fewer frames)
MAX_EVERY = 10**9


def frame_stride(text):
    """Parse a frame stride N (keep one frame in N): a whole number in [1, MAX_EVERY]."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number of frames, got {text!r}") from None
    if not 1 <= value <= MAX_EVERY:
        raise argparse.ArgumentTypeError(f"expected a whole number in [1, {MAX_EVERY}], got {text}")
    return value


def threshold_options(args, method, names=("c_agg", "a_agg_deg")) -> dict:
    """The thresholds ``--c-agg`` / ``--a-agg-deg`` given for ``method``; one not given is left
    to the method's own default (its constructor's, so the command line and the library agree).
    A threshold given for a method that ignores it is refused (``ParameterError`` naming the
    option), never silently dropped."""
    from granalytics.identification import method_parameters

    accepted = method_parameters(method)
    out = {}
    for name in names:
        value = getattr(args, name)
        if name in accepted:
            if value is not None:
                out[name] = value
        elif value is not None:
            raise ParameterError(f"--{name.replace('_', '-')} {value:g}: method {method!r} has no such threshold "
                                 f"(it takes {', '.join(accepted)})")
    return out


#: most values a START:STOP:NUM grid may have (a sensitivity table has frames × C × A rows)
MAX_GRID = 10_000


def grid(text):
    """Parse ``START:STOP:NUM`` (NUM evenly spaced values, both ends included) or ``A,B,C``."""
    try:
        if ":" in text:
            start, stop, num = text.split(":")
            num = int(num)
            if not 1 <= num <= MAX_GRID:
                raise argparse.ArgumentTypeError(f"NUM must be in [1, {MAX_GRID}], got {num} in {text!r}")
            # the values a user would write: 0.15, not linspace's 0.15000000000000002
            values = np.array([float(f"{v:.12g}") for v in np.linspace(float(start), float(stop), num)])
        else:
            values = np.array([float(x) for x in text.split(",") if x.strip()])
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected START:STOP:NUM or a comma-separated list, got {text!r}") from None
    if values.size == 0 or not np.isfinite(values).all():
        raise argparse.ArgumentTypeError(f"no valid values in {text!r}")
    return values


def setting(text):
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


def add_size_unit_option(parser):
    """``--size-unit``: granule sizes in the run's particles or in original-particle equivalents
    (:data:`granalytics.analysis.stats.SIZE_UNITS`)."""
    from granalytics.analysis.stats import SIZE_UNITS

    parser.add_argument("--size-unit", choices=SIZE_UNITS, default="particles",
                        help="granule sizes in the run's (CG) particles per granule (default), or in original-particle "
                             "equivalents α³·n with α the run's CG factor (the unit to compare runs at several α in); "
                             "the axes and the tables' size_unit say which")


def add_frame_loop_options(parser):
    """``--jobs`` and ``--scheduler``: where a command analyses its frames
    (:func:`granalytics.analysis.frames.map_frames`); :func:`frame_loop` reads them."""
    parser.add_argument("--jobs", type=int, default=1, help="worker threads over frames (default 1)")
    parser.add_argument("--scheduler", metavar="ADDR",
                        help="analyse the frames as tasks on the dask cluster of this scheduler (tcp://host:8786; "
                             "its workers must read the run file at the same path); not with --jobs")


def frame_loop(args) -> dict:
    """The frame-loop keywords (``jobs``, ``scheduler``) of a command's arguments."""
    return {"jobs": args.jobs, "scheduler": args.scheduler}


def add_cohesion_option(parser):
    parser.add_argument("--cohesion", choices=COHESION_CONVENTIONS, default=gna_default("cohesion"),
                        help="which force is F_coh: 'acting' = the cohesion the DEM code applied (a separated "
                             "bridge's force; 0 for touching pairs unless the run applied capillary force in contact), "
                             "'bridge' = the bridge force of every wet pair, touching or not (default acting)")


def add_continuation_option(parser):
    """``--continuation``: which granule keeps its track id in the ids a command writes
    (:func:`granalytics.track_granules`)."""
    from granalytics.analysis.tracking.linking import CONTINUATIONS

    parser.add_argument("--continuation", choices=CONTINUATIONS, default="main",
                        help="which granule keeps its granule_track id through a coalescence or breakage: "
                             "'main' = the piece that keeps most of a breaking granule and the coalescence of which "
                             "it is the largest contributor, 'strict' = none, every event starts new ids (the "
                             "tracks of the kinetics); the events are the same (default main)")


def add_criterion_options(parser, grid_tol=False):
    """The co-motion test and the granule size floor of GNA (:func:`criterion_params` reads them);
    ``grid_tol``: ``--rigid-tol`` takes a grid (the sensitivity pass)."""
    from granalytics.identification.contacts import COMOTION_TESTS, DEFAULT_RIGID_SCALE, DEFAULT_RIGID_TOL, RIGID_SCALES

    parser.add_argument("--comotion", choices=COMOTION_TESTS, default=gna_default("comotion"),
                        help="co-motion test: 'angle' = the paper's (velocities or angular velocities within A_agg), "
                             "'rigid' = the pair moves as one rigid body, |v_j - v_i - w x (r_j - r_i)| < "
                             f"rigid_tol·V (default {gna_default('comotion')})")
    # None: not given (resolve_rigid_options fills the default, and refuses them without --comotion rigid)
    if grid_tol:
        parser.add_argument("--rigid-tol", type=grid, default=None, metavar="GRID",
                            help="tolerances of the rigid test, with --comotion rigid (default 0.05,0.1,0.2,0.4,0.8)")
    else:
        parser.add_argument("--rigid-tol", type=float, default=None,
                            help=f"tolerance of the rigid test, with --comotion rigid (default {DEFAULT_RIGID_TOL:g})")
    parser.add_argument("--rigid-scale", choices=RIGID_SCALES, default=None,
                        help="V of the rigid test: 'granular' = sqrt(g·d) of each pair (d = R_i + R_j), 'drum' = the "
                             f"rim speed Ω·R_d (default {DEFAULT_RIGID_SCALE})")
    parser.add_argument("--min-size", type=int, default=gna_default("min_size"),
                        help="fewest particles of a granule; smaller groups count as free particles "
                             f"(default {gna_default('min_size')})")


def resolve_rigid_options(args, grid_tol=False) -> None:
    """Refuse ``--rigid-tol`` / ``--rigid-scale`` without ``--comotion rigid`` (they would be
    ignored without a word), then fill in their defaults where they were not given."""
    from granalytics.identification.contacts import DEFAULT_RIGID_SCALE, DEFAULT_RIGID_TOL

    given = [name for name, value in (("--rigid-tol", args.rigid_tol), ("--rigid-scale", args.rigid_scale))
             if value is not None]
    if given and args.comotion != "rigid":
        raise ParameterError(f"{' and '.join(given)} set the rigid co-motion test: give --comotion rigid too (the "
                             f"angle test, --comotion {args.comotion}, uses --a-agg-deg)")
    if args.rigid_tol is None:  # grid_tol: the sensitivity pass's grid of tolerances
        args.rigid_tol = grid("0.05,0.1,0.2,0.4,0.8") if grid_tol else DEFAULT_RIGID_TOL
    if args.rigid_scale is None:
        args.rigid_scale = DEFAULT_RIGID_SCALE


def criterion_params(args) -> dict:
    """GNA's co-motion and size-floor parameters from :func:`add_criterion_options`' options
    (only those that differ from the defaults with ``--comotion angle``, so a method without them
    is not handed them)."""
    resolve_rigid_options(args)
    out = {"comotion": args.comotion, "min_size": args.min_size}
    if args.comotion == "rigid":
        out.update(rigid_tol=args.rigid_tol, rigid_scale=args.rigid_scale)
    return out


def add_gna_options(parser, time_twin=True):
    """The GNA thresholds and the frame window (``--window-rev``, and ``--window-time`` unless
    ``time_twin`` is False: a command with a steady-state ``--window`` gives it that one)."""
    group = parser.add_argument_group("granule identification (graph network analysis, paper §2.2)")
    add_cohesion_option(group)
    group.add_argument("--c-agg", type=float, default=gna_default("c_agg"),
                       help=f"cohesion threshold: keep F_coh >= C_agg·2πγR (default {gna_default('c_agg'):g})")
    group.add_argument("--a-agg-deg", type=float, default=gna_default("a_agg_deg"),
                       help=f"co-motion threshold angle A_agg in degrees (default {gna_default('a_agg_deg'):g})")
    add_criterion_options(group)
    group.add_argument("--radius", choices=("pair", "mean"), default=gna_default("radius"),
                       help="R in 2πγR: pair effective radius 2RiRj/(Ri+Rj) or the run's mean radius "
                            f"(default {gna_default('radius')})")
    group.add_argument("--backend", choices=sorted(BACKENDS), default=gna_default("backend"),
                       help=f"connected-components backend (default {gna_default('backend')})")
    add_frame_window_options(group, time_twin)


def add_frame_window_options(parser, time_twin=True):
    """``--window-rev R0:R1``: only the frames of this revolution window; and the same in
    seconds: ``--window-time T0:T1`` (with ``time_twin``), or ``--frames-time T0:T1`` in a command
    whose ``--window-time`` is the seconds of its steady-state ``--window``
    (:func:`add_window_options`)."""
    parser.add_argument("--window-rev", type=interval, default=None, metavar="R0:R1",
                        help="only frames within this revolution window (default: all frames)")
    parser.add_argument("--window-time" if time_twin else "--frames-time", dest="frames_time", type=interval,
                        default=None, metavar="T0:T1", help="only frames within this time window [s] (instead of "
                                                            "--window-rev)")


def add_window_options(parser, default=None, what="steady-state window"):
    """``--window R0:R1`` (revolutions) and ``--window-time T0:T1`` (seconds), one of them: the
    window a command's result is averaged over. The same meaning in every command that has them;
    read with :func:`revolution_window` (or directly, where the analysis takes seconds)."""
    from granalytics.analysis.stats import DEFAULT_WINDOW_REV

    default = DEFAULT_WINDOW_REV if default is None else default
    group = parser.add_mutually_exclusive_group()
    group.add_argument("--window", type=interval, default=None, metavar="R0:R1",
                       help=f"{what} in drum revolutions (default {default[0]:g}:{default[1]:g})")
    group.add_argument("--window-time", type=interval, default=None, metavar="T0:T1",
                       help=f"{what} in seconds instead of revolutions (a run shorter than the default window, or "
                            "runs compared at equal time)")
    parser.set_defaults(window_default=tuple(default), window_time_steady=True)


def revolution_window(args, metas, names=()) -> tuple:
    """The revolution window of ``--window`` / ``--window-time``: ``--window`` (or the default),
    or ``--window-time`` converted with the runs' drum speed (t·|Ω|/2π, the revolutions of every
    frame). ``metas`` are the runs' :class:`~granalytics.core.RunMeta`; a time window needs them to
    turn at one speed (ParameterError naming the runs otherwise)."""
    if getattr(args, "window_time", None) is None:
        return args.window if args.window is not None else args.window_default
    speeds = {abs(float(m.drum_omega)) for m in metas}
    if 0.0 in speeds:
        raise ParameterError("--window-time: a run's drum does not turn (Ω = 0): this command measures in "
                             "revolutions; `granalytics stats --window-time` averages over seconds")
    if len(speeds) > 1:
        raise ParameterError(f"--window-time: the runs turn at different speeds ({', '.join(f'{w:g}' for w in sorted(speeds))} "
                             f"rad/s{': ' + ', '.join(map(str, names)) if names else ''}): equal times are other "
                             "revolutions in each; give --window in revolutions")
    (omega,) = speeds
    return tuple(t * omega / (2 * math.pi) for t in args.window_time)


def run_metas(paths) -> list:
    """The :class:`~granalytics.core.RunMeta` of each run file (opened for its metadata only), or
    of each :class:`~granalytics.RunStatistics` (:func:`run_items`)."""
    from granalytics.core import open_run

    metas = []
    for path in paths:
        if hasattr(path, "meta"):
            metas.append(path.meta)
            continue
        with open_run(path, validate=False) as run:
            metas.append(run.meta)
    return metas


def run_items(paths) -> list:
    """The runs a command was given: each run file's path, and for a folder the
    :class:`~granalytics.RunStatistics` kept in it (``granalytics.save`` of them)."""
    import os

    from granalytics.analysis.run_statistics import RunStatistics

    return [RunStatistics.read(path) if os.path.isdir(path) else path for path in paths]


def gna_identifier(args):
    return make_identifier(
        "gna", c_agg=args.c_agg, a_agg_deg=args.a_agg_deg, radius=args.radius, backend=args.backend,
        cohesion=args.cohesion, **criterion_params(args),
    )


def warn_if_unfinished(run) -> None:
    """One warning line when ``run`` is unfinished (:attr:`~granalytics.core.Run.unfinished`): its
    statistics are those of the frames it holds."""
    if run.unfinished:
        warnings.warn(f"{run.path}: unfinished run: {run.unfinished}; the results are those of the frames it holds")


def selected_frames(run, args):
    """The frames of ``run`` in ``--window-rev`` or its seconds twin (all without them); warns once for an unfinished
    run and for a ``--c-agg`` that no contact can pass."""
    warn_if_unfinished(run)
    frames = run
    frame_time = getattr(args, "frames_time", None)
    if args.window_rev is not None and frame_time is not None:
        raise ParameterError("--window-rev (revolutions) and a frame window in seconds both given: give one")
    if args.window_rev is not None:
        frames = run.select(revolutions=args.window_rev)
    elif frame_time is not None:
        frames = run.select(time=frame_time)
    if not len(frames):
        raise ParameterError(f"{run.path}: no frame in the selection (the run has {len(run)} frames)")
    if getattr(args, "c_agg", None) is not None:
        warn_if_c_agg_unreachable(frames, args.c_agg, args.cohesion, getattr(args, "radius", "pair"))
    return frames


def window_axis(frames, by="revolutions"):
    """The frames' times [s] or revolutions for :func:`~granalytics.analysis.stats.check_window`; NaN
    revolutions for a run whose drum does not turn (which check_window then reports)."""
    try:
        return frames.times if by == "time_s" else frames.revolutions
    except ValidationError:
        return np.full(len(frames), np.nan)


def progress(args):
    return not args.quiet
