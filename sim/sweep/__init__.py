"""Parameter sweeps on dask: ``python -m sim sweep SPEC.toml --out DIR [--workers N] [--scheduler ADDR]``
(the command line is in :mod:`sim.cli`).

A sweep is a TOML file::

    preset = "lab-cg3"          # any of sim.params.PRESETS (default lab-cg3)
    revolutions = 6.0           # drum revolutions after settling (required)
    frame_every_rev = 0.05      # output interval [revolutions] (default 0.05)
    checkpoint_every = 20       # checkpoint every N frames (default 20; resume needs checkpoints)
    threads = 1                 # numba threads per point (default 1)

    [grid]                      # every key a list; the points are the cartesian product
    gamma = [0.05, 0.1, 0.2]    # surface tension of the ORIGINAL system [N/m] (scaled by alpha)
    omega = [2.0, 3.0]          # drum angular velocity [rad/s]
    alpha = [2.0]               # CG factor (default: the preset's)
    seed = [0, 1]               # filling seed
    particles = [3000]          # particle count of the ORIGINAL system (scaled by 1/alpha^3)
    drum_ratio = [11.0, 17.0]   # or: the preset's drum sized for this D/d of the simulated particles
    drum_particles = [375]      # or: the preset's drum sized for this many simulated particles

``gamma``, ``omega``, ``seed`` and ``particles`` apply to the original (α = 1) system, exactly
like the options of ``python -m sim run``; the point is then coarse-grained by ``alpha``.
``drum_ratio`` and ``drum_particles`` are ``--drum-ratio`` and ``--drum-particles``: the preset's
drum geometry rule (fill, L/R_d, r_s/R_d, baffles) sized for a confinement D/d or a particle count
at the point's α (:func:`sim.params.sized_drum`); neither goes with ``particles``. Any
other scalar field of :class:`sim.params.SimParams` of the original system (``viscosity``,
``friction``, ``spray_dose``, ``settle_time``, …) may also be swept under its own name.

Each point runs as one dask task and writes ``DIR/points/<point>.h5``; the client records it in
``DIR/manifest.csv`` (rewritten atomically after every finished point). A point whose manifest row
says ``done`` and whose file still has the recorded sha256 is skipped; any other point is run,
resuming from its checkpoint ``<point>.h5.ckpt.npz`` when there is one. A failing point is
recorded with its one-line error and the others go on. See docs/parameter_studies.md.
"""

from __future__ import annotations

import dataclasses
import datetime
import hashlib
import itertools
import math
import os
import time
import uuid
from dataclasses import dataclass, field

from granalytics.core import (MANIFEST_COLUMNS, NAMED_PARAMETERS, ParameterError, WriterLock, dask_client,
                              manifest_path, manifest_rows, one_line, read_manifest, regular_input, warnings_as_lines,
                              write_manifest)

from ..params import (PHYSICS_VERSION, PRESETS, SimParams, cg_scale, check_cg_particle_count, frame_interval_steps,
                     preset_original, sized_drum)

__all__ = [
    "SweepSpec", "SweepPoint", "PointTask", "load_spec", "parse_spec", "point_name", "run_point", "run_sweep",
    "read_manifest", "GRID_ALIASES", "MANIFEST_COLUMNS",
]

#: grid keys that are the ``python -m sim run`` overrides -> SimParams field of the original system
GRID_ALIASES = {"gamma": "surface_tension", "omega": "drum_omega", "seed": "seed", "particles": "n_particles"}
#: canonical order of the named keys in point names and manifest columns (others follow, sorted)
_NAMED = NAMED_PARAMETERS
#: SimParams fields that cannot be grid keys under their own name
_NOT_FIELDS = {"alpha", "surface_tension", "drum_omega", "n_particles", "seed", "gravity"}
#: grid keys that size the preset's drum (sim.params.sized_drum) -> python type
_SIZING = {"drum_ratio": float, "drum_particles": int}
_TOP_LEVEL = {"preset", "revolutions", "frame_every_rev", "checkpoint_every", "threads", "grid"}

#: what every point of a folder shares (the simulator's physics version included: a finished
#: point of another version is not reused)
_SETTINGS = ("preset", "revolutions", "frame_every_rev", "physics_version")
_SIM_FIELDS = {f.name: f for f in dataclasses.fields(SimParams)}


# ----------------------------------------------------------------------------- the spec
@dataclass(frozen=True)
class SweepPoint:
    """One point of a sweep: its name, the grid values (``grid``, spec names) and the five named
    parameters of the original system resolved from the preset where the grid does not set them
    (``resolved``: gamma, omega, alpha, seed, particles, then the other grid keys)."""

    name: str
    grid: dict
    resolved: dict


@dataclass(frozen=True)
class SweepSpec:
    """A parsed sweep: fixed settings and the points (cartesian product of ``grid``)."""

    path: str
    preset: str
    revolutions: float
    frame_every_rev: float
    checkpoint_every: int
    threads: int
    grid: dict
    points: tuple = field(default_factory=tuple)


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
        return _build_params(self.preset, self.overrides)


def _build_params(preset, overrides):
    """(original, params) of a point, refusing the particle counts ``python -m sim run`` refuses."""
    original, alpha = preset_original(preset)
    changes = {k: v for k, v in overrides.items() if k != "alpha" and k not in _SIZING}
    original = dataclasses.replace(original, **changes)
    alpha = float(overrides.get("alpha", alpha))
    sizing = {k: overrides[k] for k in _SIZING if k in overrides}
    if sizing and "n_particles" in overrides:
        raise ValueError("grid key 'particles' keeps the preset's drum; drum_ratio and drum_particles size the drum "
                         "and set the count: give one of them")
    original = sized_drum(preset, original, alpha, **sizing)
    check_cg_particle_count(original.n_particles, alpha)
    return original, (original if alpha == 1 else cg_scale(original, alpha))


def _fmt_value(value) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        text = repr(value)
        return text[:-2] if text.endswith(".0") else text
    return str(value)


def point_name(grid_values: dict) -> str:
    """Deterministic file-system-safe name of a point from its grid values, e.g.
    ``gamma=0.1_omega=2_seed=0``: the named keys (gamma, omega, alpha, seed, particles) in that
    order, then the other keys alphabetically; floats in their shortest exact form."""
    keys = [k for k in _NAMED if k in grid_values] + sorted(k for k in grid_values if k not in _NAMED)
    name = "_".join(f"{k}={_fmt_value(grid_values[k])}" for k in keys)
    if len(name) > 150:  # keep file names short; the hash keeps them unique
        digest = hashlib.sha256(name.encode()).hexdigest()[:12]
        name = f"{name[:130]}_{digest}"
    return name


def _expected_type(key):
    """(python types, description) a grid value of ``key`` must have."""
    if key in ("gamma", "omega", "alpha"):
        return float, "a number"
    if key in ("seed", "particles"):
        return int, "an integer"
    if key in _SIZING:
        return (float, "a number") if _SIZING[key] is float else (int, "an integer")
    default = _SIM_FIELDS[key].default
    if isinstance(default, bool):
        return bool, "true or false"
    if isinstance(default, int):
        return int, "an integer"
    if isinstance(default, float):
        return float, "a number"
    return str, "a string"


def _check_value(where, key, value):
    kind, what = _expected_type(key)
    if kind is float:
        ok = isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
        value = float(value) if ok else value
    elif kind is int:
        ok = isinstance(value, int) and not isinstance(value, bool)
    else:
        ok = isinstance(value, kind)
    if not ok:
        raise ParameterError(f"{where}: grid key {key!r}: every value must be {what}, got {value!r}")
    if key == "omega" and value == 0:
        raise ParameterError(f"{where}: grid key 'omega': a sweep needs a rotating drum, got 0")
    if key == "alpha" and value < 1:
        raise ParameterError(f"{where}: grid key 'alpha': the CG factor must be >= 1, got {value!r}")
    return value


def _number(where, spec, key, default, kind, positive=True):
    value = spec.get(key, default)
    if value is None:
        raise ParameterError(f"{where}: {key} is required")
    good = isinstance(value, (int, float)) and not isinstance(value, bool)
    if kind is int:
        good = good and isinstance(value, int)
    if not good or not math.isfinite(value) or (positive and value <= 0):
        raise ParameterError(f"{where}: {key} must be {'an integer' if kind is int else 'a number'} > 0, got {value!r}")
    return kind(value)


#: the most points one sweep spec may hold (each point is a simulation of minutes to hours)
MAX_POINTS = 10_000


def parse_spec(spec: dict, path="<spec>") -> SweepSpec:
    """Validate a sweep spec (the TOML file as a dict) and expand its grid.

    Raises
    ------
    ParameterError
        One line naming the file and the problem: an unknown key, a grid value that is not a
        list, an empty grid or list, a duplicate or invalid value, a point the simulator refuses.
    """
    where = str(path)
    unknown = sorted(set(spec) - _TOP_LEVEL)
    if unknown:
        raise ParameterError(f"{where}: unknown key {unknown[0]!r} (known: {', '.join(sorted(_TOP_LEVEL))})")
    preset = spec.get("preset", "lab-cg3")
    if preset not in PRESETS:
        raise ParameterError(f"{where}: unknown preset {preset!r}; available: {', '.join(PRESETS)}")
    revolutions = _number(where, spec, "revolutions", None, float)
    frame_every_rev = _number(where, spec, "frame_every_rev", 0.05, float)
    checkpoint_every = _number(where, spec, "checkpoint_every", 20, int)
    threads = _number(where, spec, "threads", 1, int)
    grid = spec.get("grid")
    if not isinstance(grid, dict):
        raise ParameterError(f"{where}: a [grid] table is required (keys: parameters, values: lists)")
    if not grid:
        raise ParameterError(f"{where}: the [grid] table is empty")
    known = set(_NAMED) | set(_SIZING) | (set(_SIM_FIELDS) - _NOT_FIELDS)
    values = {}
    for key, items in grid.items():
        if key not in known:
            hint = f" (use {next(k for k, v in GRID_ALIASES.items() if v == key)!r})" if key in GRID_ALIASES.values() else ""
            raise ParameterError(f"{where}: unknown grid key {key!r}{hint}; known: {', '.join(_NAMED)} "
                                 f"or a field of sim.params.SimParams")
        if not isinstance(items, list):
            raise ParameterError(f"{where}: grid key {key!r} must be a list of values, got {items!r}")
        if not items:
            raise ParameterError(f"{where}: grid key {key!r} has an empty list")
        checked = [_check_value(where, key, v) for v in items]
        if len({_fmt_value(v) for v in checked}) != len(checked):
            raise ParameterError(f"{where}: grid key {key!r} lists a value twice: {items!r}")
        values[key] = checked
    keys = [k for k in _NAMED if k in values] + sorted(k for k in values if k not in _NAMED)
    n_points = math.prod(len(values[k]) for k in keys)
    if n_points > MAX_POINTS:  # refused before a million parameter sets are built and checked
        raise ParameterError(f"{where}: the grid has {n_points:,} points ({' × '.join(str(len(values[k])) for k in keys)}), "
                             f"more than the {MAX_POINTS:,} a sweep may run (each is a simulation); split it")
    points = []
    for combo in itertools.product(*(values[k] for k in keys)):
        grid_values = dict(zip(keys, combo))
        name = point_name(grid_values)
        overrides = {GRID_ALIASES.get(k, k): v for k, v in grid_values.items()}
        try:
            original, params = _build_params(preset, overrides)
            frame_interval_steps(revolutions, frame_every_rev, params)  # the frame plan of `sim run`
        except ValueError as exc:
            raise ParameterError(f"{where}: point {name}: {exc}") from None
        resolved = {"gamma": original.surface_tension, "omega": original.drum_omega, "alpha": params.alpha,
                    "seed": original.seed, "particles": original.n_particles}
        resolved.update({k: v for k, v in grid_values.items() if k not in resolved})
        points.append(SweepPoint(name, grid_values, resolved))
    return SweepSpec(where, preset, revolutions, frame_every_rev, checkpoint_every, threads,
                     {k: values[k] for k in keys}, tuple(points))


def load_spec(path) -> SweepSpec:
    """Read and validate a sweep spec TOML file (see the module docstring)."""
    try:
        import tomllib
    except ImportError:  # Python < 3.11
        import tomli as tomllib
    regular_input(path)  # a FIFO would block for ever
    try:
        with open(path, "rb") as f:
            spec = tomllib.load(f)
    except RecursionError:
        raise ParameterError(f"{path}: not a sweep spec: its tables or arrays are nested too deeply") from None
    except OSError as exc:
        raise ParameterError(f"{path}: cannot read the sweep spec ({exc.strerror or exc})") from None
    except tomllib.TOMLDecodeError as exc:
        raise ParameterError(f"{path}: not valid TOML ({' '.join(str(exc).split())})") from None
    except UnicodeDecodeError as exc:
        raise ParameterError(f"{path}: not UTF-8 text, as TOML must be (byte {exc.start}: {exc.reason})") from None
    return parse_spec(spec, path)


# ----------------------------------------------------------------------------- running one point
def run_point(task: PointTask) -> dict:
    """The real point runner: simulate the point with :mod:`sim` and write ``task.out``.

    Resumes from ``task.out + '.ckpt.npz'`` when the checkpoint exists (bit-identical to an
    uninterrupted run). Returns ``{"resumed": bool, "wall_time_s": float}``, the latter the
    simulator's wall time for the whole point (summed over the attempts of a resumed point), as
    recorded in the run file's provenance.
    """
    import numba

    from granalytics.core import configure_threading

    configure_threading()  # before numba starts its threads: OpenMP, not TBB (tens of times slower here)
    numba.set_num_threads(max(1, min(task.threads, numba.config.NUMBA_NUM_THREADS)))
    # a worker's warnings (e.g. a stale lock of the point file taken over) as one line each, naming the point
    with warnings_as_lines(f"sim sweep: {os.path.basename(task.out)}"):
        return _run_point(task)


def _run_point(task: PointTask) -> dict:
    from granalytics.core import open_run

    from ..run import Simulation

    original, params = task.sim_params()
    frame_every = frame_interval_steps(task.revolutions, task.frame_every_rev, params)
    ckpt = f"{task.out}.ckpt.npz"
    resumed = os.path.exists(ckpt) and os.path.exists(task.out)
    if resumed:
        sim = Simulation.resume(task.out)
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


def _sha256(path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


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
        return {"status": "done", "wall_time_s": wall_time_s, "sha256": _sha256(task.out),
                "error": "", "resumed": bool(info.get("resumed", False))}
    except Exception as exc:  # reported in the manifest; the sweep goes on
        return {"status": "failed", "wall_time_s": time.perf_counter() - t0, "sha256": "", "error": _error_cell(exc),
                "resumed": False}


def _is_complete(out_dir, row) -> bool:
    if not row or row.get("status") != "done" or not row.get("sha256"):
        return False
    path = os.path.join(out_dir, row.get("file") or "")
    return os.path.isfile(path) and _sha256(path) == row["sha256"]


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
    # manifest (the lock file of its manifest, taken over when its holder was killed)
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
