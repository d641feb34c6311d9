"""Bundled snapshot series (``datasets/`` in the source tree), made by ``sim``.

Each dataset is one run file registered here with its sha256 sum, the exact commands that made
it (the simulation, then :func:`granalytics.io.subset_run` through ``granalytics subset``), the
code version and the wall time (also in ``datasets/README.md``). :func:`dataset_path` checks the
sum before handing the file out, so a corrupted or regenerated file is never analysed silently.
``make datasets`` (``python -m granalytics.datasets make``) regenerates every file from its
recipe; nothing is downloaded.

The big runs are bundled with fewer frames outside their steady-state window (every fourth frame,
i.e. every 0.2 revolution, which still samples every phase of the 0.25-revolution baffle period)
and all floating-point data stored as float32 (read back as float64); the small ones keep every
frame, also as float32.

Datasets
--------
lab-cg1, lab-cg2, lab-cg3
    The lab drum (10 000 original particles of 1.5 mm, R_d = 39.7 mm, L = 23.8 mm, 4 baffles,
    Ω = 2 rad/s, Table 1 physics) at CG factors 1, 2, 3 (10 000, 1 250, 370 particles), seed 0:
    the CG comparison with the original system. lab-cg1 runs 3 revolutions (steady window [2, 3]),
    lab-cg2 and lab-cg3 six.
paper-cg2, paper-cg3
    The paper's drum (R_d = 0.1 m, L = 0.045 m, 120 000 original particles) at CG2 (15 000
    particles, 3 revolutions) and CG3 (4 444 particles, 6 revolutions), seed 0.
"""

from __future__ import annotations

import hashlib
import shlex
import subprocess
import sys
from pathlib import Path

from .errors import GranalyticsError

__all__ = ["DATASETS", "dataset_path", "open_dataset", "make_dataset"]

DATASET_DIR = Path(__file__).resolve().parents[1] / "datasets"
_RAW_DIR = "build/runs"  # full-resolution simulator output (not bundled), relative to the repository root


def _recipe(preset, revolutions, full_window=None):
    raw = f"{_RAW_DIR}/{preset}.h5"
    sim = (f"python -m sim run --preset {preset} --revolutions {revolutions:g} --seed 0 --threads 1 "
           f"--checkpoint-every 2 --quiet --out {raw}")
    subset = f"granalytics subset {raw} --out datasets/{preset}.h5 --float32 --overwrite"
    if full_window is not None:
        subset += f" --full-window {full_window} --every 4"
    return [sim, subset]


_LAB_CODE = "85aa70e85a0494805a84ffec09690de064b05e85"  # git commit whose simulator made the lab runs

#: name -> file, sha256, the commands that made it (from the repository root, in order), the
#: code version (git commit) and simulator wall time, description
DATASETS = {
    "lab-cg1": {
        "file": "lab-cg1.h5",
        "sha256": "5203b924e3a15766ffff2bfc125ba9a83fc9455893d76c279c49154ec45be0fd",
        "commands": _recipe("lab-cg1", 3, full_window="2:3"),
        "code_version": _LAB_CODE,
        "wall_time": "1 h 43 min 41 s (1 thread to 0.35 revolution, then resumed on 2 threads, which is "
                     "bit-identical; sharing the 2 cores with other runs and tests throughout)",
        "description": "lab drum, CG1: the 3 000 original particles of 1.5 mm, to 2.95 revolutions (the simulator "
                       "of that version stopped one frame short of 3); every frame in [2, 3], every fourth before "
                       "(30 of 60 frames)",
    },
    "lab-cg2": {
        "file": "lab-cg2.h5",
        "sha256": "d5a0064dfdcbbe4d7d8d224b60bb9c7144868e3f85652ab84664611f467ae5ce",
        "commands": _recipe("lab-cg2", 6),
        "code_version": _LAB_CODE,
        "wall_time": "47 min 11 s (1 thread, sharing the 2 cores with two other runs and tests)",
        "description": "lab drum, CG2: 375 particles of 3 mm standing for 3 000 of 1.5 mm, to 5.95 revolutions "
                       "(the simulator of that version stopped one frame short of 6), every frame (120 frames)",
    },
    "lab-cg3": {
        "file": "lab-cg3.h5",
        "sha256": "56d25fc98249fea05d27afda6918a5a1b2cc5f9a5f0b56dd1da9d9ebca6cfd73",
        "commands": _recipe("lab-cg3", 6),
        "code_version": _LAB_CODE,
        "wall_time": "3 min 41 s (1 thread; the other core busy)",
        "description": "lab drum, CG3: 111 particles of 4.5 mm standing for 3 000 of 1.5 mm, 6 revolutions, "
                       "every frame (0.05 revolution, 121 frames)",
    },
}


def _sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def dataset_path(name: str) -> Path:
    """Path of a bundled dataset after checking its sha256 sum.

    Raises
    ------
    GranalyticsError
        Unknown name, missing file (e.g. an installed package without the source tree), or a
        checksum mismatch.
    """
    try:
        entry = DATASETS[name]
    except KeyError:
        raise GranalyticsError(f"unknown dataset {name!r}; available: {', '.join(DATASETS)}") from None
    path = DATASET_DIR / entry["file"]
    if not path.exists():
        raise GranalyticsError(f"{path}: dataset file missing (datasets live in the source tree; "
                               f"made by: {' && '.join(entry['commands'])})")
    digest = _sha256(path)
    if digest != entry["sha256"]:
        raise GranalyticsError(f"{path}: sha256 {digest} does not match the registry ({entry['sha256']})")
    return path


def open_dataset(name: str):
    """Open a bundled dataset as a :class:`~granalytics.Run`."""
    from .io import open_run

    return open_run(dataset_path(name))


def make_dataset(name: str, *, dry_run=False) -> str:
    """Regenerate a dataset from its recipe (minutes to hours: see its ``wall_time``), resuming
    an interrupted simulation from its checkpoint; returns the new file's sha256.

    The simulator is bit-reproducible for a given seed and thread count, so the physics is
    identical; the bytes (and so the sum) also depend on the HDF5 library version.
    """
    entry = DATASETS[name]
    root = DATASET_DIR.parent
    for command in entry["commands"]:
        argv = shlex.split(command)
        if argv[0] == "python":
            argv[0] = sys.executable
        elif argv[0] == "granalytics":
            argv = [sys.executable, "-m", "granalytics"] + argv[1:]
        raw = argv[argv.index("--out") + 1]
        if argv[1:3] == ["-m", "sim"] and (root / f"{raw}.ckpt.npz").exists():
            argv.append("--resume")
        elif argv[1:3] == ["-m", "sim"] and (root / raw).exists():
            argv.append("--overwrite")  # a raw run without its checkpoint cannot be resumed: make it again
        print("$", shlex.join(argv), flush=True)
        if not dry_run:
            subprocess.run(argv, cwd=root, check=True)
    if dry_run:
        return ""
    digest = _sha256(DATASET_DIR / entry["file"])
    print(f"{name}: sha256 {digest}")
    return digest


def _main(argv=None) -> int:
    import argparse

    parser = argparse.ArgumentParser(prog="python -m granalytics.datasets",
                                     description="List or regenerate the bundled datasets.")
    sub = parser.add_subparsers(dest="command", required=True)
    sub.add_parser("list", help="the registry")
    p = sub.add_parser("make", help="regenerate datasets from their recipes")
    p.add_argument("names", nargs="*", help="datasets (default: all)")
    p.add_argument("--dry-run", action="store_true", help="print the commands only")
    args = parser.parse_args(argv)
    if args.command == "list":
        for name, entry in DATASETS.items():
            print(f"{name:<10} {entry['file']:<14} {entry['description']}")
            for command in entry["commands"]:
                print(f"           $ {command}")
        return 0
    unknown = [n for n in args.names if n not in DATASETS]
    if unknown:
        print(f"python -m granalytics.datasets: error: unknown dataset {unknown[0]!r}; available: "
              f"{', '.join(DATASETS)}", file=sys.stderr)
        return 2
    for name in args.names or list(DATASETS):
        make_dataset(name, dry_run=args.dry_run)
    return 0


if __name__ == "__main__":
    sys.exit(_main())
