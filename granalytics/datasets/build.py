"""Remaking the bundled files from their recipes (:mod:`granalytics.datasets.catalogue`): run a
recipe's commands (resuming an interrupted simulation from its checkpoint), bundle a sweep's
finished points, and check the new file's sha256."""

from __future__ import annotations

import os
import shlex
import subprocess
import sys
import threading
from pathlib import Path

from granalytics.base.errors import GranalyticsError
from granalytics.datasets.catalogue import DATASET_DIR, DATASETS, FOREIGN, SWEEPS, file_sha256

__all__ = ["make_dataset", "make_foreign", "make_sweep", "bundle_sweep"]

_PRINT_LOCK = threading.Lock()  # recipes may run side by side (make --jobs): one line at a time


def _say(label, text) -> None:
    with _PRINT_LOCK:
        print(f"[{label}] {text}", flush=True)


def _run_recipe(commands, dry_run, label, progress=False) -> None:
    """Run a registry recipe from the repository root with this interpreter (``python`` and
    ``granalytics`` become ``sys.executable [-m granalytics]``). A ``python -m sim run`` whose
    output has a checkpoint gets ``--resume``; one whose output exists without a checkpoint
    cannot be resumed and gets ``--overwrite`` (it is made again). With ``progress`` (one recipe
    at a time) the simulations show their progress bars (the recipes' ``--quiet`` is dropped)."""
    root = DATASET_DIR.parent
    for command in commands:
        argv = shlex.split(command)
        if argv[0] == "python":
            argv[0] = sys.executable
        elif argv[0] == "granalytics":
            argv = [sys.executable, "-m", "granalytics"] + argv[1:]
        if argv[1:4] == ["-m", "sim", "run"]:
            if progress:
                argv = [a for a in argv if a != "--quiet"]
            raw = argv[argv.index("--out") + 1]
            if (root / f"{raw}.ckpt.npz").exists():
                argv.append("--resume")
            elif (root / raw).exists():
                argv.append("--overwrite")
        _say(label, f"$ {shlex.join(argv)}")
        if not dry_run:
            subprocess.run(argv, cwd=root, check=True)


def _remade(name, file, dry_run) -> str:
    """The sha256 of the file a recipe made (said as it is), or "" for a dry run."""
    if dry_run:
        return ""
    digest = file_sha256(DATASET_DIR / file)
    _say(name, f"sha256 {digest}")
    return digest


def make_dataset(name: str, *, dry_run=False, progress=False) -> str:
    """Regenerate a dataset from its recipe (minutes to hours: see its ``wall_time``), resuming
    an interrupted simulation from its checkpoint; returns the new file's sha256.

    The simulator is bit-reproducible for a given seed and thread count, so the physics is
    identical; the bytes (and so the sum) also depend on the HDF5 library version.
    """
    entry = DATASETS[name]
    _run_recipe(entry["commands"], dry_run, name, progress)
    return _remade(name, entry["file"], dry_run)


def make_foreign(name: str, *, dry_run=False, progress=False) -> str:
    """Remake a run of another DEM code (:data:`FOREIGN`): its program's commands where the program
    is installed (said so, and the raw output in the folder kept, where not), then the conversion;
    returns the converted file's sha256."""
    import shutil

    entry = FOREIGN[name]
    folder = DATASET_DIR.parent / entry["folder"]
    if shutil.which(entry["program"]) is None:
        _say(name, f"{entry['program']} is not installed: the raw output in {entry['folder']} is kept "
                   f"(apt-get install {entry['program']} to remake it)")
    else:
        for command in entry["program_commands"]:
            _say(name, f"$ (cd {entry['folder']} && {command})")
            if not dry_run:
                subprocess.run(command, shell=True, cwd=folder, check=True)  # registry constants, never user input
    _run_recipe(entry["commands"], dry_run, name, progress)
    return _remade(name, entry["file"], dry_run)


def bundle_sweep(src, dst, *, overwrite=False, progress=True, every=1, full_window=None, window_every=1) -> Path:
    """Copy the finished points of sweep folder ``src`` (``python -m sim sweep``) into ``dst``
    for bundling: the frames of every point as float32 (:func:`granalytics.core.subset_run`), and
    the manifest with the finished rows only, ``sha256`` the bundled file's sum and
    ``source_sha256`` the simulator's file's. Points not finished are left out (and named).

    Every frame is kept by default; ``every``, ``full_window`` (revolutions (r0, r1)) and
    ``window_every`` thin the points as ``granalytics subset --every N --full-window R0:R1
    --window-every K`` does (:func:`granalytics.core.thinned_frames`): one frame in ``window_every``
    inside the window (all by default), one in ``every`` outside it.

    Raises
    ------
    GranalyticsError
        ``dst`` exists and ``overwrite`` is False, or ``src`` has no finished point.
    """
    import shutil
    import tempfile

    from granalytics.base.files import WriterLock
    from granalytics.core import open_run, subset_run, thinned_frames
    from granalytics.core.manifest import read_manifest

    from granalytics.base.files import check_apart
    from granalytics.report.files import swap_folder

    src, dst = Path(src), Path(dst)
    thinned_frames([], every, full_window, window_every)  # refuses bad thinning options before any work
    check_apart(dst, [src], "bundle folder")  # --overwrite must never delete the sweep it copies
    dst.parent.mkdir(parents=True, exist_ok=True)
    with WriterLock(dst):  # DST.lock beside it: one bundling at a time, dst checked under the lock
        if dst.exists() and not dst.is_dir():
            raise GranalyticsError(f"{dst}: exists and is not a folder")
        if dst.exists() and not overwrite:
            raise GranalyticsError(f"{dst}: exists (pass overwrite=True, or --overwrite, to replace it)")
        if dst.is_dir():  # --overwrite replaces a bundle, never the user's other files beside it
            others = sorted(p.name for p in dst.iterdir() if p.name not in ("manifest.csv", "points"))
            if others:
                raise GranalyticsError(f"{dst}: holds files that are not a bundle's ({', '.join(others[:3])}"
                                       f"{' …' if len(others) > 3 else ''}); --overwrite replaces only a bundle "
                                       "(manifest.csv and points/): bundle into a new folder")
        table = read_manifest(src)
        done = table[table.status == "done"].copy()
        if done.empty:
            raise GranalyticsError(f"{src}/manifest.csv: no finished point to bundle")
        points = os.path.realpath(src / "points")
        for row in done.itertuples():  # a manifest names files inside its points/ folder, nothing else
            rel = str(row.file)
            target = os.path.realpath(src / rel)
            if (os.path.isabs(rel) or ".." in Path(rel).parts or not rel.startswith("points/")
                    or os.path.commonpath([target, points]) != points):
                raise GranalyticsError(f"{src}/manifest.csv: point {row.point}: file {rel!r} is not inside {src}/points")
        left = table.point[table.status != "done"].tolist()
        if left:
            print(f"bundle-sweep: {len(left)} unfinished points left out: {', '.join(left)}", file=sys.stderr)
        tmp = Path(tempfile.mkdtemp(prefix=f".{dst.name}.", dir=dst.parent))  # built aside, then swapped in
        try:
            (tmp / "points").mkdir()
            sums = []
            iterator = done.file
            if progress:
                from tqdm.auto import tqdm

                iterator = tqdm(done.file, desc="bundle-sweep", unit="point")
            for rel in iterator:
                with open_run(src / rel) as run:
                    frames = thinned_frames(run.revolutions, every, full_window, window_every)
                subset_run(src / rel, tmp / rel, frames, float_dtype="float32")
                sums.append(file_sha256(tmp / rel))
            done["source_sha256"] = done["sha256"]
            done["sha256"] = sums
            done.to_csv(tmp / "manifest.csv", index=False)
            umask = os.umask(0)
            os.umask(umask)
            tmp.chmod(0o777 & ~umask)  # mkdtemp made it private; the bundle is a normal folder
            swap_folder(tmp, dst)
        except BaseException:
            shutil.rmtree(tmp, ignore_errors=True)
            raise
    return dst


def make_sweep(name: str, *, dry_run=False, progress=False) -> str:
    """Regenerate a bundled sweep from its recipe: the sweep (finished points skipped,
    interrupted ones resumed) and then :func:`bundle_sweep`; returns the new manifest's sha256."""
    entry = SWEEPS[name]
    _run_recipe(entry["commands"], dry_run, name, progress)
    if dry_run:
        return ""
    digest = file_sha256(DATASET_DIR / entry["dir"] / "manifest.csv")
    _say(name, f"manifest sha256 {digest}")
    return digest

