"""The datasets commands (``granalytics datasets …``, also ``python -m granalytics.datasets …``):
list the registry, regenerate datasets from their recipes, bundle a sweep folder."""

from __future__ import annotations

import sys
from concurrent.futures import ThreadPoolExecutor
import argparse

from granalytics import datasets
from granalytics.base.errors import GranalyticsError
from granalytics.base.interrupts import interrupted
from granalytics.cli.options import frame_stride, interval


def main(argv=None, prog="python -m granalytics.datasets") -> int:
    """List, regenerate or bundle the datasets; returns the exit status."""
    parser = argparse.ArgumentParser(prog=prog,
                                     description="List or regenerate the bundled datasets.")
    sub = parser.add_subparsers(dest="command", required=True)
    sub.add_parser("list", help="the registry")
    p = sub.add_parser("make", help="regenerate datasets from their recipes")
    p.add_argument("names", nargs="*", help="datasets (default: all)")
    p.add_argument("--dry-run", action="store_true", help="print the commands only")
    p.add_argument("--jobs", "-j", type=int, default=1,
                   help="recipes run at the same time (default 1; each simulation uses the threads its recipe "
                        "names, one or, for paper-cg2, two; the sweep its own workers)")
    b = sub.add_parser("bundle-sweep", help="copy a sweep folder's finished points as float32 for bundling")
    b.add_argument("src", help="sweep folder written by python -m sim sweep")
    b.add_argument("dst", help="folder to write")
    b.add_argument("--overwrite", action="store_true", help="replace dst if it exists")
    b.add_argument("--every", type=frame_stride, default=1, help="keep one frame in N outside --full-window (default 1: all)")
    b.add_argument("--full-window", type=interval, default=None, metavar="R0:R1",
                   help="revolutions in which every frame is kept (with --every)")
    b.add_argument("--window-every", type=frame_stride, default=1, metavar="K",
                   help="inside --full-window keep only the frames whose index is a multiple of K (default 1: all)")
    args = parser.parse_args(argv)
    if args.command == "list":
        for name, entry in {**datasets.DATASETS, **datasets.FOREIGN, **datasets.SWEEPS}.items():
            print(f"{name:<20} {entry.get('file', entry.get('dir')):<28} {entry['description']}")
            if "physics_version" in entry:  # a run of our simulator
                print(f"{'':<21}{datasets.physics_note(name, entry)}")
            for command in entry["commands"]:
                print(f"{'':<21}$ {command}")
        print("\nnot bundled (the 100 MB budget): the confinement runs of scripts/confinement_study.py; the first command "
              "makes the raw run it reads")
        for name, entry in datasets.CONFINEMENT.items():
            print(f"{name:<20} {entry['file']:<28} {entry['description']} ({entry['wall_time']})")
            for command in entry["commands"]:
                print(f"{'':<21}$ {command}")
        return 0
    if args.command == "bundle-sweep":
        try:
            print(datasets.bundle_sweep(args.src, args.dst, overwrite=args.overwrite, every=args.every,
                                        full_window=args.full_window, window_every=args.window_every))
        except (GranalyticsError, OSError) as exc:
            print(f"{prog} bundle-sweep: error: {exc}", file=sys.stderr)
            return 2
        except (KeyboardInterrupt, SystemError) as exc:
            if not interrupted(exc):
                raise
            print(f"{prog} bundle-sweep: interrupted; {args.dst} was left as it was", file=sys.stderr)
            return 130
        return 0
    known = {**datasets.DATASETS, **datasets.FOREIGN, **datasets.SWEEPS}
    unknown = [n for n in args.names if n not in known]
    if unknown:
        print(f"{prog}: error: unknown dataset {unknown[0]!r}; available: "
              f"{', '.join(known)}", file=sys.stderr)
        return 2
    if args.jobs < 1:
        print(f"{prog}: error: --jobs must be at least 1, got {args.jobs}", file=sys.stderr)
        return 2

    def make(name):  # progress bars only when one recipe runs at a time (side by side they would interleave)
        return (datasets.make_sweep if name in datasets.SWEEPS else datasets.make_foreign if name in datasets.FOREIGN else datasets.make_dataset)(name, dry_run=args.dry_run, progress=args.jobs == 1)

    names = args.names or list(known)
    # the recipes' processes run side by side (or one after the other); a failed one does not stop
    # the others, and each failure is one line
    with ThreadPoolExecutor(max_workers=args.jobs) as pool:
        futures = {name: pool.submit(make, name) for name in names}
    failed = {name: f.exception() for name, f in futures.items() if f.exception() is not None}
    for name, exc in failed.items():
        print(f"{prog}: error: {name}: {exc}", file=sys.stderr)
    return 1 if failed else 0


def add_datasets_parser(sub):
    """Add the ``datasets`` command to ``sub``; :func:`forwarded_main` receives its arguments unparsed."""
    p = sub.add_parser("datasets", help="list, regenerate or bundle the bundled datasets (as python -m granalytics.datasets)",
                       description="list | make [NAME ...] [--jobs N] [--dry-run] | bundle-sweep SRC DST: the registry of "
                                   "bundled runs and sweeps, their regeneration from their recipes, the bundling of a "
                                   "sweep folder. See datasets/README.md.", add_help=False)
    p.add_argument("datasets_args", nargs=argparse.REMAINDER, help="list | make ... | bundle-sweep ...")
    return p


def forwarded_main(argv) -> int:
    """``granalytics datasets …``."""
    return main(argv, prog="granalytics datasets")
