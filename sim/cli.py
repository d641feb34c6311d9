"""Command line: ``python -m sim run --preset lab-cg3 --revolutions 2 --out run.h5``, ``python -m sim presets``,
``python -m sim sweep SPEC.toml --out DIR`` (also ``python -m sim.sweep …``).

Overrides (``--gamma``, ``--omega``, ``--seed``, ``--particles``) apply to the *original*
(α = 1) system; the run is then coarse-grained by the preset's α or ``--alpha`` (Table 2), so
``--gamma 0.2 --alpha 2`` simulates γ = 0.4 N/m on CG2 particles.

Every refusal — a bad option value, an existing ``--out`` without ``--overwrite``, a checkpoint
that does not belong to the run file — is one line on stderr with exit status 2, before anything
is written. A simulation that fails while running (e.g. a particle left the drum) exits with 1.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
import sys

from granalytics.base.errors import RunWriteError, exit_after_write_failure, one_line, warnings_as_lines
from granalytics.base.files import check_not_open_elsewhere, check_output_folder
from granalytics.base.interrupts import interrupted, terminate_as_interrupt
from granalytics.core.manifest import manifest_path

from .cg_rules import CG_RULES, DEFAULT_CG_RULE
from .laws import CONTACT_LAWS
from .threads import check_threads
from .params import (MAX_CYLINDER_FACETS, MIN_PARTICLES, PRESETS, cg_scale, check_cg_particle_count, frame_interval_steps, preset_original,
                     similar_system, sized_drum, with_step_factor)


#: the most particles a run may ask for (10⁸: beyond any run this simulator can finish)
MAX_PARTICLES = 100_000_000


class _Parser(argparse.ArgumentParser):
    """argparse, with its errors in one line like every other refusal of the command."""

    def error(self, message):
        self.exit(2, f"sim: error: {message} (see {self.prog} --help)\n")


def _check_options(args) -> None:
    """Refuse option values the simulation cannot use, naming the option (ValueError)."""
    finite = math.isfinite
    checks = [
        ("--revolutions", args.revolutions, finite(args.revolutions) and args.revolutions > 0, "a finite number > 0"),
        ("--frame-every-rev", args.frame_every_rev, finite(args.frame_every_rev) and args.frame_every_rev > 0,
         "a finite number > 0"),
        ("--checkpoint-every", args.checkpoint_every, 1 <= args.checkpoint_every <= 10**9,
         "a whole number of frames in [1, 10⁹]"),
        ("--checkpoint-minutes", args.checkpoint_minutes, args.checkpoint_minutes is None or (
            finite(args.checkpoint_minutes) and args.checkpoint_minutes > 0), "a finite number of minutes > 0"),
        ("--omega", args.omega, args.omega is None or (finite(args.omega) and args.omega != 0),
         "a finite non-zero number (a run is measured in drum revolutions)"),
        ("--gamma", args.gamma, args.gamma is None or (finite(args.gamma) and args.gamma > 0), "a finite number > 0"),
        ("--alpha", args.alpha, args.alpha is None or (finite(args.alpha) and args.alpha >= 1), "a finite number >= 1"),
        ("--particles", args.particles, args.particles is None or args.particles >= 1, "a whole number >= 1"),
        ("--seed", args.seed, args.seed is None or 0 <= args.seed < 2**63, "a whole number in [0, 2⁶³)"),
        ("--cylinder-facets", args.cylinder_facets, args.cylinder_facets is None or args.cylinder_facets == 0 or
         3 <= args.cylinder_facets <= MAX_CYLINDER_FACETS, f"0 (smooth) or a whole number in [3, {MAX_CYLINDER_FACETS}]"),
        ("--particles", args.particles, args.particles is None or args.particles <= MAX_PARTICLES,
         f"at most {MAX_PARTICLES} (a whole number)"),
        ("--drum-particles", args.drum_particles, args.drum_particles is None or 1 <= args.drum_particles <= MAX_PARTICLES,
         f"a whole number in [1, {MAX_PARTICLES}]"),
        ("--dt-factor", args.dt_factor, finite(args.dt_factor) and 0 < args.dt_factor <= 100,
         "a finite number in (0, 100]"),
        ("--bridge-volume", args.bridge_volume, args.bridge_volume is None or (finite(args.bridge_volume) and
                                                                            args.bridge_volume > 0), "a finite volume > 0 [m³]"),
    ]
    for option, value, ok, requirement in checks:
        if not ok:
            raise ValueError(f"{option} must be {requirement}, got {value:g}")


def _threads(text):
    """``--threads``: ``auto`` or a whole number (its range is checked against numba's pool later)."""
    if text == "auto":
        return text
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be 'auto' or a whole number, got {text!r}") from None


def _law_parameter(text):
    """``--law-parameter NAME=VALUE``: a contact-law parameter's name and its value as a float (the
    name is checked against the chosen law's parameters later, in :func:`_params`)."""
    name, sep, value = text.partition("=")
    try:
        if not sep:
            raise ValueError
        return name.strip(), float(value)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be NAME=NUMBER, got {text!r}") from None


def _law_changes(args, preset_law: str) -> dict:
    """The ``SimParams`` changes of ``--contact-law`` and ``--law-parameter`` (the law is the
    preset's, ``preset_law``, unless ``--contact-law`` names another); ValueError naming a
    parameter the law does not have."""
    law = CONTACT_LAWS[args.contact_law or preset_law]
    changes = {"contact_law": args.contact_law}
    names = [parameter.name for parameter in law.parameters]
    for name, value in args.law_parameter or ():
        if name not in names:
            raise ValueError(f"--law-parameter {name}: the contact law {law.name!r} has no parameter {name!r} "
                             f"(it has {', '.join(names)})")
        changes[name] = value
    return changes


def build_parser():
    parser = _Parser(prog="python -m sim", description="Numba wet-DEM of a baffled drum granulator.")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    p = sub.add_parser("run", help="simulate and write a granalytics run file",
                       description="Fill and settle the drum, then simulate and write a frame every --frame-every-rev revolutions.")
    p.add_argument("--preset", choices=PRESETS, default="lab-cg3", help="parameter set (default lab-cg3)")
    p.add_argument("--revolutions", type=float, required=True,
                   help="drum revolutions to simulate after settling: a whole number of --frame-every-rev intervals")
    p.add_argument("--out", required=True, help="run file to write (.h5); the checkpoint is OUT.ckpt.npz")
    p.add_argument("--overwrite", action="store_true", help="replace --out if it exists (refused otherwise)")
    p.add_argument("--alpha", type=float, help="CG factor α >= 1 (default: the preset's)")
    p.add_argument("--cg-rule", choices=tuple(CG_RULES),
                   help=f"coarse-graining rule (default {DEFAULT_CG_RULE}): "
                        + "; ".join(f"{rule.name}: {rule.description}" for rule in CG_RULES.values()))
    p.add_argument("--twin", action="store_true",
                   help="run the α = 1 twin of the coarse-grained system instead: the same system with every length "
                        "÷ α under the same gravity (times ÷ √α, forces ÷ α³; sim.params.similar_system), recorded "
                        "as α = 1. Its dimensionless groups are the CG run's, so its statistics must equal the CG "
                        "run's within replica errors; under --cg-rule bond it is the original system with Ω, η × √α "
                        "and the spray interval and settling time ÷ √α")
    p.add_argument("--gamma", type=float, help="surface tension of the original system [N/m] (scaled by α)")
    p.add_argument("--omega", type=float, help="drum angular velocity [rad/s], not 0")
    p.add_argument("--cylinder-facets", type=int, metavar="N",
                   help="make the cylinder a polygon of N flat facets turning with the drum, as YADE's facetCylinder "
                        "(default 0: the smooth cylinder)")
    p.add_argument("--particles", type=int,
                   help=f"particle count of the original system (scaled by 1/α³, at least {MIN_PARTICLES} after scaling)")
    p.add_argument("--drum-ratio", type=float, metavar="D/d",
                   help="size the preset's drum (same fill, L/R_d, r_s/R_d, baffles) for this drum-to-particle "
                        "diameter ratio D/d of the simulated particles; the particle count follows (replaces "
                        "--particles)")
    p.add_argument("--drum-particles", type=int, metavar="N",
                   help="size the preset's drum for N simulated particles (N·α³ original ones) by the same rule")
    p.add_argument("--bridge-volume", type=float, metavar="M3",
                   help="fixed bridge volume V_b of the original system [m³] (scaled by α³): YADE's ViscElCapMat "
                        "without LiqControl, every bridge has V_b from its touch to its rupture; no films, spraying "
                        "or migration (default: films, spraying and migration)")
    p.add_argument("--contact-law", choices=tuple(CONTACT_LAWS),
                   help=f"mechanical contact law (default the preset's, {next(iter(CONTACT_LAWS))}); its parameters "
                        "are set by --law-parameter")
    p.add_argument("--law-parameter", type=_law_parameter, action="append", metavar="NAME=VALUE",
                   help="a parameter of the contact law in the original system, SI units (repeatable; scaled by "
                        "the law's CG rule), e.g. youngs_modulus=1e7 for hertz_mindlin; the names are the law's "
                        "(docs/physics.md, \"Contact law\")")
    p.add_argument("--no-wall-bridges", action="store_true",
                   help="with --bridge-volume: wall contacts stay dry (no bridges with the drum, baffles or end plates)")
    p.add_argument("--no-viscous", action="store_true",
                   help="switch off the viscous (lubrication) force of the bridges, as YADE's ViscElCapMat")
    p.add_argument("--dt-factor", type=float, default=1.0, metavar="F",
                   help="multiply the time step by F after the CG rule has set it (default 1: the paper's 3 µs × the "
                        "rule's factor); refused beyond t_c/20 of the smallest particles. Recorded in the run file "
                        "(sim_config.params.dt_factor) and shown by granalytics info; docs/simulator.md (\"Time "
                        "step\") gives the factors that leave the statistics unchanged")
    p.add_argument("--seed", type=int, help="random seed of the filling (>= 0)")
    p.add_argument("--threads", type=_threads, default="auto",
                   help="numba threads: a count, or 'auto' (the default): the count is chosen as the run goes by "
                        "measuring 1 thread against all the cores the process may use, again at intervals of 2 "
                        "to 20 s and whenever the rate falls, so that a busy machine (another program on a "
                        "core) does not stall the threads; results are bit-identical for any count")
    p.add_argument("--frame-every-rev", type=float, default=0.05,
                   help="output interval [revolutions] (default 0.05)")
    p.add_argument("--checkpoint-every", type=int, default=20, help="checkpoint every N >= 1 frames (default 20)")
    p.add_argument("--checkpoint-minutes", type=float, default=None, metavar="M",
                   help="also checkpoint between frames once M minutes have passed since the last checkpoint "
                        "(for frames that take long: a stop loses at most M minutes; default: at frames only)")
    p.add_argument("--resume", action="store_true",
                   help="continue the run in --out from its checkpoint (same options as when it started; a "
                        "finished run is left as it is)")
    p.add_argument("--resume-from", metavar="CKPT",
                   help="start --out as a new part of the run whose checkpoint CKPT is (a copy kept when its files "
                        "were lost, say): the part holds the frames from the checkpoint's next one on (same "
                        "options as when the run started)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    sub.add_parser("presets", help="list the presets")
    add_sweep_parser(sub)
    return parser


def _params(args):
    original, alpha = preset_original(args.preset)
    changes = {"surface_tension": args.gamma, "drum_omega": args.omega, "seed": args.seed, "n_particles": args.particles,
               "bridge_volume": args.bridge_volume, "viscous": False if args.no_viscous else None,
               "cg_rule": args.cg_rule, "cylinder_facets": args.cylinder_facets,
               "wall_bridges": False if args.no_wall_bridges else None}
    changes.update(_law_changes(args, original.contact_law))
    original = dataclasses.replace(original, **{k: v for k, v in changes.items() if v is not None})
    alpha = alpha if args.alpha is None else args.alpha
    if args.particles is not None and (args.drum_ratio is not None or args.drum_particles is not None):
        raise ValueError("--particles keeps the preset's drum; --drum-ratio and --drum-particles size the drum and "
                         "set the count: give one of them")
    original = sized_drum(args.preset, original, alpha, drum_ratio=args.drum_ratio, drum_particles=args.drum_particles)
    check_cg_particle_count(original.n_particles, alpha,
                            f"--particles {args.particles}" if args.particles is not None else None)
    params = original if alpha == 1 else cg_scale(original, alpha)
    if args.twin:
        if alpha == 1:
            raise ValueError("--twin is the α = 1 twin of a coarse-grained run: give a CG preset or --alpha > 1")
        twin = dataclasses.replace(similar_system(params, 1 / alpha), alpha=1.0)
        return twin, with_step_factor(twin, args.dt_factor)
    return original, with_step_factor(params, args.dt_factor)


def _run(args) -> int:
    from .threads import configure_threading

    configure_threading()  # the program tunes its process; the library does not
    out = args.out
    _check_options(args)
    if args.resume and args.overwrite:
        raise ValueError("--resume continues --out and --overwrite replaces it: give one of them")
    if args.resume and args.resume_from:
        raise ValueError("--resume continues --out from its own checkpoint, --resume-from starts it from another: "
                         "give one of them")
    from .checkpoint import checkpoint_path, resume_run

    if args.resume_from and os.path.abspath(args.resume_from) == os.path.abspath(checkpoint_path(out)):
        raise ValueError(f"--resume-from {args.resume_from} is {out}'s own checkpoint, which a new part in {out} "
                         "would replace along with its frames: give --resume to continue it, or another --out")
    if not args.resume and os.path.exists(out) and not args.overwrite:
        raise ValueError(f"{out} exists; give --overwrite to replace it, or --resume to continue it from its checkpoint")
    original, params = _params(args)
    check_threads(args.threads, "--threads")  # before the settling, not after it
    frame_every = frame_interval_steps(args.revolutions, args.frame_every_rev, params,
                                       names=("--revolutions", "--frame-every-rev"))
    from .run import Simulation, check_room

    ckpt = checkpoint_path(out)

    # a missing or read-only folder, a name too long, a file another process has open, frames that
    # cannot fit on the disk: refused now, not after the settling
    check_output_folder(out)
    if not args.resume:
        check_not_open_elsewhere(out)
    check_room(params, round(args.revolutions / args.frame_every_rev) + 1, out)

    if args.resume or args.resume_from:
        sim = resume_run(out, from_checkpoint=args.resume_from)
        sim.threads = args.threads
        if sim.params != params or sim.original != original:
            changed = sorted(k for k, v in params.to_dict().items() if sim.params.to_dict().get(k) != v)
            raise ValueError(f"{args.resume_from or ckpt}: checkpoint was made with other parameters "
                             f"({', '.join(changed) or 'original system'}); "
                             f"give the options the run started with")
    else:
        try:
            sim = Simulation(params, original, progress=not args.quiet, threads=args.threads)
        except RuntimeError as exc:  # e.g. a particle left the drum while settling
            print(f"sim: error: {one_line(exc)} (while settling; nothing was written)", file=sys.stderr)
            return 1
        except (KeyboardInterrupt, SystemError) as exc:
            if not interrupted(exc):
                raise
            print("sim: interrupted while settling; nothing was written", file=sys.stderr)
            return 130
    try:
        sim.run(out, args.revolutions, frame_every=frame_every, checkpoint_every=args.checkpoint_every,
                progress=not args.quiet, resume=args.resume, overwrite=args.overwrite,
                checkpoint_minutes=args.checkpoint_minutes, new_part=bool(args.resume_from))
    except RuntimeError as exc:  # the simulation itself failed (e.g. a particle left the drum)
        print(f"sim: error: {one_line(exc)}; {_what_is_left(out, ckpt)}", file=sys.stderr)
        return 1
    except (KeyboardInterrupt, SystemError) as exc:
        if not interrupted(exc):
            raise
        print(f"sim: interrupted; {_what_is_left(out, ckpt)}", file=sys.stderr)
        return 130
    from granalytics.core import open_run

    with open_run(out, validate=False) as run:  # what the file holds (a finished run resumed is left as it was)
        n_frames, t_last = len(run), float(run.times[-1])
    print(f"{out}: {n_frames} frames, t = {t_last:.4g} s ({t_last / params.revolution_period:.3g} revolutions)")
    return 0


def _what_is_left(out, ckpt) -> str:
    """What a run stopped early leaves on disk, and how to go on from it."""
    if os.path.exists(ckpt) and os.path.exists(out):
        return f"--resume continues {out} from its last checkpoint {ckpt}"
    if os.path.exists(out):
        return f"{out} holds the frames written so far but no checkpoint yet: start again with --overwrite"
    return f"nothing was written to {out}"


def main(argv=None):
    args = build_parser().parse_args(argv)
    if args.command == "presets":
        from .params import preset

        for name in PRESETS:
            p = preset(name)
            print(f"{name:<11} {p.n_particles:>7} particles  α={p.alpha:g}  R_d={p.drum_radius:.4f} m  "
                  f"L={p.drum_length:.4f} m  Δt={p.dt:.1e} s  r_s={p.spray_radius:.4f} m")
        return 0
    with terminate_as_interrupt():  # kill PID: the run stops as with Ctrl-C (its checkpoint kept, its lock released)
        return reporting_errors(lambda: args.func(args) if args.command == "sweep" else _run(args))


def reporting_errors(command) -> int:
    """``command()``'s exit status, with bad input or environment (``ValueError``, ``OSError``,
    ``OverflowError``) as one line ``sim: error: ...`` and exit status 2, and warnings as one
    line each; shared by ``python -m sim`` and ``python -m sim.sweep``."""
    with warnings_as_lines("sim"):
        try:
            return command()
        except (ValueError, OSError, OverflowError) as exc:
            print(f"sim: error: {one_line(exc)}", file=sys.stderr)
            if isinstance(exc, RunWriteError):  # HDF5 cannot close the broken file: no interpreter shutdown
                exit_after_write_failure(2)
            return 2


# ----------------------------------------------------------------------------- sweeps (sim.sweep runs them)
def _configure_sweep(p):
    p.add_argument("spec", help="sweep spec (.toml): preset, revolutions, frame_every_rev and a [grid] of lists")
    p.add_argument("--out", required=True, help="sweep folder: points/<point>.h5 and manifest.csv")
    p.add_argument("--workers", type=int, help="worker processes of the local dask cluster, one thread each "
                                               "(default: the cores, at most the points to run)")
    p.add_argument("--scheduler", metavar="ADDR", help="use an existing dask cluster (tcp://host:port) instead "
                                                       "of a local one; its workers must see --out at the same path")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_sweep)
    return p


def add_sweep_parser(subparsers):
    """Add the ``sweep`` subcommand to ``subparsers`` (from ``ArgumentParser.add_subparsers``);
    its ``func`` is :func:`cmd_sweep`. Returns the subcommand's parser."""
    p = subparsers.add_parser(
        "sweep", help="run a parameter study on dask (one run file per grid point)",
        description="Run every point of the grid of a TOML sweep spec as a dask task (a local cluster of "
                    "single-threaded worker processes, or --scheduler), one run file per point in OUT/points, "
                    "recorded in OUT/manifest.csv. Finished points are skipped, interrupted ones resume from "
                    "their checkpoint, failed ones are recorded and the others go on. See docs/parameter_studies.md.")
    return _configure_sweep(p)


def cmd_sweep(args) -> int:
    """Run the ``sweep`` subcommand. Bad input raises :class:`ParameterError` (a ``ValueError``;
    the caller prints it as one line, exit 2). Returns 0, 1 when a point failed, 130 when
    interrupted (Ctrl-C)."""
    from .sweep import load_spec, run_sweep

    try:
        table = run_sweep(args.spec, args.out, workers=args.workers, scheduler=args.scheduler, progress=not args.quiet)
    except KeyboardInterrupt:
        print(f"sim: interrupted; the same command continues the sweep in {args.out} (finished points are "
              "skipped, the others resume from their checkpoints)", file=sys.stderr)
        return 130
    spec = load_spec(args.spec)
    mine = table[table["point"].isin([p.name for p in spec.points])]
    done = int((mine["status"] == "done").sum())
    failed = mine[mine["status"] == "failed"]
    print(f"sweep {args.out}: {len(mine)} points, {done} done, {len(failed)} failed; "
          f"manifest {manifest_path(args.out)}")
    for row in failed.itertuples():
        print(f"  failed {row.point}: {row.error}")
    return 1 if len(failed) else 0


def sweep_main(argv=None, prog="python -m sim.sweep") -> int:
    """``python -m sim.sweep SPEC.toml --out DIR ...`` (the same as ``python -m sim sweep``); ``prog``
    is the command's name in its usage and errors."""
    parser = argparse.ArgumentParser(prog=prog, description="Run a parameter sweep on dask.")
    args = _configure_sweep(parser).parse_args(argv)
    return reporting_errors(lambda: args.func(args))  # as python -m sim sweep
