"""Checkpoints of a run: the simulation written to one file, restored from it, and resumed once
the run file and the checkpoint are shown to belong together.

The checkpoint of run file ``OUT`` is ``OUT.ckpt.npz`` (:func:`checkpoint_path`), format 2: every
array of :meth:`sim.state.State.to_arrays` under its field name, and the 0-d string array
``checkpoint_info`` holding a JSON object: ``format`` (2), ``physics_version``, ``params`` and
``original`` (:meth:`sim.params.SimParams.to_dict`), ``liquid_initial`` [m³] and what the run adds
(``frames``, ``frame_every``, ``wall_s``; ``cpu_s`` where the simulator recorded it). The state is
at frame ``frames − 1`` or, written between frames, at a later step before frame ``frames`` (a
simulator older than that refuses such a checkpoint rather than misread it). Long runs resume
from such files: the format changes only with :data:`CHECKPOINT_FORMAT`.
"""

from __future__ import annotations

import contextlib
import dataclasses
import json
import math
import os
import warnings
from typing import TYPE_CHECKING

import numpy as np

from .drum import n_walls
from .params import PHYSICS_VERSION, SimParams
from .state import SLOT_OUTPUT_FIELDS, State

if TYPE_CHECKING:
    from .run import Simulation

__all__ = ["CHECKPOINT_FORMAT", "ResumePoint", "checkpoint_path", "write_checkpoint", "read_checkpoint",
           "remove_checkpoint", "resume_run", "check_resume", "check_new_part", "compact_checkpoint"]

#: version of the one-file checkpoint (the JSON information inside the .npz under _INFO_KEY)
CHECKPOINT_FORMAT = 2
_INFO_KEY = "checkpoint_info"


@dataclasses.dataclass(frozen=True)
class ResumePoint:
    """Where a run restored from its checkpoint (:func:`resume_run`) goes on.

    Attributes
    ----------
    frames : int
        Frames the run file held when the checkpoint was written; the state is that of frame
        ``frames - 1`` or, for a checkpoint written between frames (``checkpoint_minutes``), of a
        later step before frame ``frames``.
    frame_every : int
        Steps between frames.
    wall_s : float
        Wall time of the run's earlier sittings [s].
    cpu_s : float or None
        CPU time of the run's earlier sittings, all threads [s]; None where a sitting's simulator
        did not record it.
    physics_version : int or None
        The physics version the checkpoint records (None: its simulator recorded none).
    """

    frames: int
    frame_every: int
    wall_s: float
    physics_version: object
    cpu_s: float | None = None


def checkpoint_path(out) -> str:
    """The checkpoint of run file ``out``: ``out + '.ckpt.npz'``."""
    return f"{os.fspath(out)}.ckpt.npz"


def write_checkpoint(sim: Simulation, path, extra=None) -> None:
    """Write the state and parameters of ``sim`` as ONE file, atomically.

    The state arrays and the JSON information (parameters, initial liquid, ``extra``) go
    into a single ``.npz`` (the JSON as the 0-d string array ``checkpoint_info``), written
    to ``path + '.tmp'`` in the same directory, flushed to disk (fsync), then renamed over
    ``path`` (``os.replace``, atomic) and the directory synced. A kill at any point leaves
    either the previous checkpoint or the new one, never a mix.
    """
    path = os.fspath(path)
    info = {"format": CHECKPOINT_FORMAT, "physics_version": PHYSICS_VERSION, "params": sim.params.to_dict(),
            "original": sim.original.to_dict(), "liquid_initial": sim.liquid_initial, **(extra or {})}
    arrays = sim.state.to_arrays()
    arrays[_INFO_KEY] = np.array(json.dumps(info))
    _write_npz(path, arrays, np.savez)


def _write_npz(path, arrays, save) -> None:
    """Write ``arrays`` with ``save`` (``np.savez`` or ``np.savez_compressed``) to ``path + '.tmp'``,
    fsync it, rename it over ``path`` and sync the directory: the old file or the new, never a mix."""
    tmp = f"{path}.tmp"
    try:
        with open(tmp, "wb") as f:
            save(f, **arrays)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except Exception:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
    _fsync_directory(os.path.dirname(os.path.abspath(path)))


def read_checkpoint(path) -> tuple[Simulation, dict]:
    """The simulation that :func:`write_checkpoint` wrote to ``path``, and the ``extra`` information
    written with it.

    Raises
    ------
    ValueError
        Missing, unreadable or damaged checkpoint (one line, naming the file).
    """
    from .run import Simulation  # the run writes its checkpoints through this module

    path = os.fspath(path)
    if not os.path.exists(path):
        raise ValueError(f"{path}: no checkpoint to resume from")
    try:
        with open(path, "rb") as f, np.load(f, allow_pickle=False) as data:  # closed also when not a zip
            arrays = {name: data[name] for name in data.files}
        if _INFO_KEY not in arrays:
            earlier = (f"; {os.path.basename(path)}.json beside it is the two-file checkpoint of an earlier "
                       "version: finish the run with that version, or start it again" if os.path.exists(
                           f"{path}.json") else "")
            raise ValueError(f"{path}: not a checkpoint of this simulator (no '{_INFO_KEY}' inside){earlier}")
        info = json.loads(str(arrays.pop(_INFO_KEY)))
        if info.get("format") != CHECKPOINT_FORMAT:
            raise ValueError(f"{path}: checkpoint format {info.get('format')!r}, this simulator reads format "
                             f"{CHECKPOINT_FORMAT}: not a checkpoint it wrote")
        state = State.from_arrays(arrays)
        params = SimParams.from_dict(info.pop("params"))
        original = SimParams.from_dict(info.pop("original"))
        state.check(n_walls(params.n_baffles))  # never hand the kernels indices past the arrays
        liquid_initial = float(info.pop("liquid_initial"))
        if "frames" in info or "frame_every" in info:
            frames, frame_every = int(info["frames"]), int(info["frame_every"])
            if frame_every < 1 or not (frames - 1) * frame_every <= state.step < frames * frame_every:
                raise ValueError(f"state at step {state.step} is not at or after the last of {frames} frames every "
                                 f"{frame_every} steps, before the next")
        for key, nullable in (("wall_s", False), ("cpu_s", True)):  # the run's time so far [s]; cpu_s null
            value = info.get(key)                                       # where a sitting did not record it
            if key not in info or nullable and value is None:
                continue
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not (math.isfinite(value) and value >= 0):
                raise ValueError(f"{key} is {value!r}, not a time in seconds >= 0")
    except ValueError as exc:
        message = str(exc)
        raise ValueError(message if message.startswith(path) else f"{path}: damaged checkpoint ({message})") from None
    except Exception as exc:  # zip, npy and JSON errors of a truncated or garbled file
        raise ValueError(f"{path}: damaged checkpoint ({type(exc).__name__}: {exc})") from None
    info.pop("format", None)
    sim = Simulation(params, original, state=state)
    sim.liquid_initial = liquid_initial
    return sim, info


def compact_checkpoint(path, out) -> int:
    """Write a small copy of checkpoint ``path`` to ``out`` (atomically), to keep a long run's
    state where its machine's disk does not last (a repository, say), and return its size [bytes].

    The copy holds the same state but for the slot outputs of the last step
    (:data:`sim.state.SLOT_OUTPUT_FIELDS`), zeroed: each step's force pass writes them before
    anything reads them, so the copy resumes to the same trajectory, bit for bit. Its arrays are
    deflated (``np.savez_compressed``; ``np.load`` reads them as before). With the outputs zeroed a
    bed's checkpoint shrinks about eightfold (≈ 340 bytes a particle against ≈ 2 800 at D/d 44).

    Raises
    ------
    ValueError
        ``path`` is not a readable checkpoint (as :func:`read_checkpoint`).
    """
    read_checkpoint(path)  # refuse a damaged one before copying it
    with open(path, "rb") as f, np.load(f, allow_pickle=False) as data:
        arrays = {name: data[name] for name in data.files}
    for name in SLOT_OUTPUT_FIELDS:
        arrays[name] = np.zeros_like(arrays[name])
    out = os.fspath(out)
    _write_npz(out, arrays, np.savez_compressed)
    return os.path.getsize(out)


def remove_checkpoint(out) -> None:
    """Remove the checkpoint of run file ``out`` left by an earlier run, if any (and the ``.json``
    half of an earlier version's two-file checkpoint)."""
    ckpt = checkpoint_path(out)
    for stale in (ckpt, f"{ckpt}.json"):
        with contextlib.suppress(FileNotFoundError):
            os.unlink(stale)


def resume_run(out, from_checkpoint=None) -> Simulation:
    """The simulation of run ``out`` restored from its checkpoint, with its :class:`ResumePoint`
    as ``resume_point``: ready for ``run(out, ..., resume=True)``; or, with ``from_checkpoint``,
    restored from that checkpoint of any run (a copy kept elsewhere), ready for ``run(out, ...,
    new_part=True)``.

    Raises
    ------
    ValueError
        No checkpoint, a damaged one, or one that is not a run's (no frame count or interval).
    """
    ckpt = checkpoint_path(out) if from_checkpoint is None else os.fspath(from_checkpoint)
    sim, info = read_checkpoint(ckpt)
    try:
        frames, frame_every = int(info["frames"]), int(info["frame_every"])
    except KeyError as exc:
        raise ValueError(f"{ckpt}: not a run checkpoint (no {exc.args[0]!r})") from None
    cpu_s = info.get("cpu_s")
    sim.resume_point = ResumePoint(frames=frames, frame_every=frame_every, wall_s=float(info.get("wall_s", 0.0)),
                                   physics_version=info.get("physics_version"),
                                   cpu_s=None if cpu_s is None else float(cpu_s))
    return sim


def _check_frame_plan(ckpt, point, frame_every, n_frames) -> None:
    """Refuse a resume whose frame interval differs from the checkpoint's, or whose run ends before
    the checkpoint's frames."""
    if point.frame_every != frame_every:
        raise ValueError(
            f"{ckpt}: the run writes a frame every {point.frame_every} steps, the resumed run asks for "
            f"{frame_every} (give the same frame interval, --frame-every-rev, as when the run started)")
    if point.frames > n_frames:
        raise ValueError(f"{ckpt}: the checkpoint comes after {point.frames} frames, past the end of the requested "
                         f"run ({n_frames} frames); ask for at least as many revolutions as it holds")


def _check_physics_version(where, version) -> None:
    """Refuse a checkpoint or run file made by another physics version (or recording a version
    that is not a whole number)."""
    if version is not None and (isinstance(version, bool) or not isinstance(version, int)):
        raise ValueError(f"{where}: records its physics version as {type(version).__name__} {version!r}, not a "
                         "whole number: not written by this simulator")
    if version is not None and version != PHYSICS_VERSION:
        raise ValueError(
            f"{where}: made by the simulator's physics version {version}, this simulator has version "
            f"{PHYSICS_VERSION} (docs/simulator.md, 'Physics versions'); resuming would join two force laws "
            "in one trajectory: finish the run with the version that started it, or start it again with "
            "--overwrite")


def check_new_part(sim: Simulation, frame_every, n_frames) -> int:
    """Check that the checkpoint ``sim`` was restored from (:func:`resume_run` with
    ``from_checkpoint``) can start a new part of its run: same frame interval, made by this physics
    version, and frames left to make in the requested run of ``n_frames`` frames.

    Returns
    -------
    int
        The part's first frame: the checkpoint's frame count (its state lies at or after the frame
        before it).

    Raises
    ------
    ValueError
        One line naming what does not match.
    """
    point = sim.resume_point
    where = "the checkpoint"
    _check_frame_plan(where, point, frame_every, n_frames)
    _check_physics_version(where, point.physics_version)
    if point.physics_version is None:
        raise ValueError(f"{where} records no physics version (its simulator predates them): it cannot start a "
                         "part, whose frames would join another version's")
    if point.frames >= n_frames:
        raise ValueError(f"{where} comes after {point.frames} frames, the requested run has {n_frames}: no frame "
                         "is left for a new part; ask for more revolutions")
    return point.frames


def check_resume(sim: Simulation, out, frame_every, n_frames) -> tuple[bool, int]:
    """Check that run file ``out`` and the checkpoint that ``sim`` was resumed from
    (:func:`resume_run`) belong together before a resume changes anything: same parameters
    (preset, overrides, seed: the whole :class:`SimParams` and its original), same frame
    interval, the checkpoint's frame within the requested run of ``n_frames`` frames every
    ``frame_every`` steps, the run file holding at least the checkpoint's frame count on the same
    grid of steps, and its frame ``frames − 1`` at exactly the time and step of the checkpoint's
    last frame (the checkpoint's own step where it was written at a frame). A part of a run
    (``provenance["first_frame"]`` = f, see :meth:`sim.run.Simulation.run`) holds the run's frames
    from f on: its k-th frame is the run's frame f + k.

    Returns
    -------
    (bool, int)
        Whether the run finished already: the file holds at least ``n_frames`` frames (of the run,
        with those of the parts before it) and the wall time that
        :meth:`sim.run.Simulation.run` writes at its end (a run stopped before its end has no wall
        time, or fewer frames: a finished run resumed for more revolutions and killed keeps the
        old wall time but not the frames); and the file's first frame f (0 but for a part).

    Raises
    ------
    ValueError
        One line naming what does not match.
    """
    from granalytics.core import open_run

    ckpt = checkpoint_path(out)
    point, s = sim.resume_point, sim.state
    frames = point.frames
    _check_frame_plan(ckpt, point, frame_every, n_frames)
    if not os.path.exists(out):
        raise ValueError(f"{out}: run file missing; the checkpoint {ckpt} continues it and cannot be resumed without it")
    try:
        with open_run(out, validate=False) as run:
            meta, steps, times = run.meta, run.steps, run.times
    except (OSError, ValueError) as exc:
        raise ValueError(f"{out}: cannot resume, the run file is unreadable ({exc})") from None
    try:
        file_params = SimParams.from_dict(meta.sim_config["params"])
        file_original = SimParams.from_dict(meta.sim_config["original"])
    except (KeyError, TypeError, ValueError):
        raise ValueError(f"{out}: not a run of this simulator (no simulation parameters in its metadata)") from None
    ckpt_version = point.physics_version
    for where, version in ((ckpt, ckpt_version), (out, meta.provenance.get("physics_version"))):
        _check_physics_version(where, version)
    if ckpt_version is None:
        warnings.warn(f"{ckpt}: records no physics version (its simulator predates them); resuming it assumes it "
                      f"was made by physics version {PHYSICS_VERSION} (docs/simulator.md, 'Physics versions')",
                      stacklevel=3)
    if file_params != sim.params or file_original != sim.original:
        changed = sorted(k for k, v in sim.params.to_dict().items() if file_params.to_dict().get(k) != v)
        changed += sorted(f"original {k}" for k, v in sim.original.to_dict().items()
                          if file_original.to_dict().get(k) != v)
        raise ValueError(f"{out}: the run file and the checkpoint {ckpt} were made with different parameters "
                         f"({', '.join(changed)})")
    first = meta.provenance.get("first_frame", 0)
    if isinstance(first, bool) or not isinstance(first, int) or not 0 <= first <= frames:
        raise ValueError(f"{out}: its first frame (provenance first_frame) is {first!r}, not a whole number from 0 to "
                         f"the checkpoint {ckpt}'s frame count {frames}")
    held = frames - first  # the checkpoint's frames that lie in this file
    if len(steps) < held:
        raise ValueError(f"{out}: holds {len(steps)} frames from frame {first} but the checkpoint {ckpt} comes after "
                         f"{frames}")
    if not np.array_equal(steps[:held], (first + np.arange(held)) * frame_every):
        raise ValueError(f"{out}: its frames are not every {frame_every} steps like the checkpoint's {ckpt}")
    frame_step = (frames - 1) * frame_every  # the checkpoint's last frame; its state is there or up to a frame later
    frame_time = frame_step * sim.params.dt  # as the simulator times its frames (t = step·Δt)
    if held and (steps[held - 1] != frame_step or times[held - 1] != frame_time):
        raise ValueError(f"{out}: frame {frames - 1} (the checkpoint's last) is at step {steps[held - 1]}, "
                         f"t = {times[held - 1]!r} s, the checkpoint {ckpt}'s at step {frame_step}, t = "
                         f"{frame_time!r} s")
    finished = first + len(steps) >= n_frames and "wall_time_s" in meta.provenance
    if not finished and frames >= n_frames and s.step > frame_step:
        raise ValueError(f"{ckpt}: the checkpoint's state (step {s.step}) lies past the last frame of the requested "
                         f"run (frame {n_frames - 1}, step {frame_step}); ask for more revolutions")
    return finished, first


def _fsync_directory(directory) -> None:
    """Make a rename in ``directory`` durable (POSIX; a no-op where directories cannot be opened)."""
    try:
        fd = os.open(directory, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)
