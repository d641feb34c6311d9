"""Running a sweep's points on dask (:func:`run_sweep`): one task per point (:class:`PointTask`,
:func:`run_point`, resuming from a checkpoint), the manifest rewritten atomically after every
finished point, finished points skipped, a failing point recorded with its one-line error.
"""

from __future__ import annotations

import datetime
import os
import time
import uuid
from dataclasses import dataclass

from granalytics.base.errors import ParameterError, one_line, warnings_as_lines
from granalytics.base.files import WriterLock
from granalytics.base.cluster import dask_client
from granalytics.core.manifest import file_sha256, manifest_path, manifest_rows, read_manifest, write_manifest

from ..params import PHYSICS_VERSION, SimParams, frame_interval_steps
from .spec import GRID_ALIASES, build_params, load_spec


#: what every point of a folder shares (the simulator's physics version included: a finished
#: point of another version is not reused)
_SETTINGS = ("preset", "revolutions", "frame_every_rev", "physics_version")


@dataclass(frozen=True)
class PointTask:
    """What a point runner gets (picklable; sent to a dask worker).

    ``out`` is the absolute path of the run file to write (its checkpoint is ``out + '.ckpt.npz'``);
    ``overrides`` are SimParams fields of the original system (``alpha``: the CG factor)."""

    name: str
    point: dict
    overrides: dict
    preset: str
    revolutions: float
    frame_every_rev: float
    checkpoint_every: int
    threads: int
    out: str

    def sim_params(self) -> tuple[SimParams, SimParams]:
        """(original, params): the α = 1 parameters and those of the simulated (CG) system."""
        return build_params(self.preset, self.overrides)


# ----------------------------------------------------------------------------- running one point
def run_point(task: PointTask) -> dict:
    """The real point runner: simulate the point with :mod:`sim` and write ``task.out``.

    Resumes from ``task.out + '.ckpt.npz'`` when the checkpoint exists (bit-identical to an
    uninterrupted run). Returns ``{"resumed": bool, "wall_time_s": float}``, the latter the
    simulator's wall time for the whole point (summed over the attempts of a resumed point), as
    recorded in the run file's provenance.
    """
    import numba

    from ..threads import configure_threading

    configure_threading()  # before numba starts its threads: OpenMP, not TBB (tens of times slower here)
    numba.set_num_threads(max(1, min(task.threads, numba.config.NUMBA_NUM_THREADS)))
    # a worker's warnings as one line each, naming the point
    with warnings_as_lines(f"sim sweep: {os.path.basename(task.out)}"):
        return _run_point(task)


def _run_point(task: PointTask) -> dict:
    from granalytics.core import open_run

    from ..checkpoint import checkpoint_path, resume_run
    from ..run import Simulation

    original, params = task.sim_params()
    frame_every = frame_interval_steps(task.revolutions, task.frame_every_rev, params)
    ckpt = checkpoint_path(task.out)
    resumed = os.path.exists(ckpt) and os.path.exists(task.out)
    if resumed:
        sim = resume_run(task.out)
        if sim.params != params:
            raise ValueError(f"{ckpt}: checkpoint was made with other parameters")
    else:
        sim = Simulation(params, original)
    # the sweep owns its points folder: a point file without a checkpoint is an earlier failed start
    sim.run(task.out, task.revolutions, frame_every=frame_every, checkpoint_every=task.checkpoint_every,
            progress=False, resume=resumed, overwrite=not resumed)
    with open_run(task.out, validate=False) as run:
        wall_time_s = float(run.meta.provenance["wall_time_s"])
    return {"resumed": resumed, "wall_time_s": wall_time_s}


def _error_cell(exc) -> str:
    """A failed point's error for its manifest cell: the type and the message on one line, at most 500 characters."""
    text = one_line(exc)
    text = text if text == type(exc).__name__ else f"{type(exc).__name__}: {text}"
    return text if len(text) <= 500 else text[:497] + "..."


def _execute(runner, task: PointTask) -> dict:
    """Run one point on a worker; never raises for a failing point (the error is returned).

    ``wall_time_s`` is the runner's own figure when it reports one (the simulator's, over all
    attempts of the point), else this attempt's."""
    t0 = time.perf_counter()
    try:
        info = runner(task) or {}
        if not os.path.isfile(task.out):
            raise RuntimeError(f"the point runner wrote no run file {task.out}")
        wall_time_s = float(info.get("wall_time_s", time.perf_counter() - t0))
        return {"status": "done", "wall_time_s": wall_time_s, "sha256": file_sha256(task.out),
                "error": "", "resumed": bool(info.get("resumed", False))}
    except Exception as exc:  # reported in the manifest; the sweep goes on
        return {"status": "failed", "wall_time_s": time.perf_counter() - t0, "sha256": "", "error": _error_cell(exc),
                "resumed": False}


def _is_complete(out_dir, row) -> bool:
    if not row or row.get("status") != "done" or not row.get("sha256"):
        return False
    path = os.path.join(out_dir, row.get("file") or "")
    return os.path.isfile(path) and file_sha256(path) == row["sha256"]


def _same(a, b) -> bool:
    if isinstance(a, (int, float)) and isinstance(b, (int, float)):
        return float(a) == float(b)
    return str(a) == str(b)


# ----------------------------------------------------------------------------- the sweep
def run_sweep(spec_path, out_dir, workers=None, scheduler=None, progress=True, point_runner=None):
    """Run every point of a sweep on dask and return the manifest.

    Parameters
    ----------
    spec_path : path
        Sweep spec (TOML; see the module docstring).
    out_dir : path
        Sweep folder: ``points/<point>.h5`` and ``manifest.csv``.
    workers : int, optional
        Worker processes of the local cluster (``LocalCluster(n_workers=workers,
        threads_per_worker=1)``); default: the number of cores, at most the points to run.
    scheduler : str, optional
        Address of an existing dask scheduler (``tcp://host:port``) to use instead of a local
        cluster; its workers must see ``out_dir`` at the same path (shared file system).
    progress : bool, default True
        A tqdm bar over the points.
    point_runner : callable, optional
        ``point_runner(task: PointTask) -> dict | None`` writes ``task.out``; default
        :func:`run_point` (the simulator). Tests pass a fast fake. It must be importable or
        picklable by the workers.

    Returns
    -------
    DataFrame
        The manifest (all rows of ``DIR/manifest.csv``, also those of points of earlier sweeps
        into the same folder that this spec does not list).

    Raises
    ------
    ParameterError
        A bad spec, folder, worker count or scheduler (before any point runs), or a folder whose
        manifest ran these points with another preset, revolutions or frame interval.
    RunLockedError
        Another sweep is running into the same folder (it holds ``DIR/manifest.csv.lock``).
    """
    spec = load_spec(spec_path)
    if workers is not None and scheduler is not None:
        raise ParameterError("--workers applies to the local cluster only; the scheduler's cluster has its own workers")
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int) or workers < 1):
        raise ParameterError(f"--workers must be an integer >= 1, got {workers!r}")
    out_dir = os.path.abspath(os.fspath(out_dir))
    if os.path.exists(out_dir) and not os.path.isdir(out_dir):
        raise ParameterError(f"{out_dir}: exists and is not a folder")
    runner = point_runner if point_runner is not None else run_point
    os.makedirs(os.path.join(out_dir, "points"), exist_ok=True)
    # one sweep at a time per folder: a second one would run the same points and overwrite the
    # manifest (the lock of its manifest is released when its holder is killed)
    with WriterLock(manifest_path(out_dir)):
        rows = manifest_rows(out_dir)
        settings = {"preset": spec.preset, "revolutions": spec.revolutions, "frame_every_rev": spec.frame_every_rev,
                    "physics_version": PHYSICS_VERSION}
        todo = []
        for point in spec.points:
            row = rows.get(point.name)
            if row is not None:
                for key in _SETTINGS:
                    if row.get(key) is not None and not _same(row[key], settings[key]):
                        now = "this simulator has" if key == "physics_version" else "the spec has"
                        raise ParameterError(
                            f"{manifest_path(out_dir)}: point {point.name} was run with {key}="
                            f"{row[key]!r}, {now} {settings[key]!r}; use another --out folder")
            if not _is_complete(out_dir, row):
                todo.append(point)
        if todo:
            _run_points(spec, out_dir, todo, rows, settings, runner, workers, scheduler, progress)
        elif not os.path.exists(manifest_path(out_dir)):
            write_manifest(out_dir, rows.values())
        return read_manifest(out_dir)


def _run_points(spec, out_dir, todo, rows, settings, runner, workers, scheduler, progress):
    from distributed import as_completed
    from tqdm.auto import tqdm

    tasks = {}
    for point in todo:
        rel = os.path.join("points", f"{point.name}.h5")
        rows[point.name] = {"point": point.name, "status": "running", **point.resolved, **settings,
                            "wall_time_s": None, "resumed": None, "file": rel, "sha256": "", "error": "",
                            "finished_utc": ""}
        overrides = {GRID_ALIASES.get(k, k): v for k, v in point.grid.items()}
        tasks[point.name] = PointTask(point.name, dict(point.resolved), overrides, spec.preset, spec.revolutions,
                                      spec.frame_every_rev, spec.checkpoint_every, spec.threads,
                                      os.path.join(out_dir, rel))
    n_local = None if scheduler is not None else (
        workers if workers is not None else max(1, min(os.cpu_count() or 1, len(todo))))
    with dask_client(scheduler, n_local, what="sweeps") as client:
        write_manifest(out_dir, rows.values())  # the points as running, once there is a cluster to run them
        token = uuid.uuid4().hex[:8]
        futures = {client.submit(_execute, runner, task, key=f"sweep-{token}-{name}", pure=False, retries=0): name
                   for name, task in tasks.items()}
        bar = tqdm(as_completed(list(futures)), total=len(spec.points), initial=len(spec.points) - len(todo),
                   unit="point", desc="sweep", disable=not progress)
        for future in bar:
            name = futures[future]
            try:
                result = future.result()
            except Exception as exc:  # the task itself did not finish (e.g. its worker kept dying)
                result = {"status": "failed", "wall_time_s": None, "sha256": "", "error": _error_cell(exc),
                          "resumed": False}
            rows[name].update(result)
            rows[name]["finished_utc"] = datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")
            write_manifest(out_dir, rows.values())
            bar.set_postfix_str(f"{name}: {result['status']}")
        bar.close()

