"""Reading run files: :func:`open_run`, the lazy frame sequences :class:`Run` and :class:`RunSlice`,
and the checks of the frame index before any frame is read."""

from __future__ import annotations

import json
import math
import os
import warnings
from collections.abc import Sequence
from numbers import Integral, Real

import h5py
import numpy as np

from granalytics.base.errors import (FrameKeyError, GranalyticsError, ParameterError, RunFileError, ValidationError,
                                     one_line, user_stacklevel)
from granalytics.core.format import (CONTACT_DATASETS, CONTACT_LAYOUT, FORMAT_NAME, FORMAT_VERSION, PARTICLE_LAYOUT,
                                     PER_FRAME_DATASETS)
from granalytics.core.hdf5_file import CONVERT_HINT, HDF5Handle, open_h5
from granalytics.base.resources import check_memory
from granalytics.base.validation import FLAG, PATH, WINDOW, Array, Instance, Interval, validate, validate_params
from granalytics.core.windows import window_mask
from granalytics.core.snapshot import PARTICLE_FIELDS, RunMeta, Snapshot, refuse_first

# bytes of one particle and one contact in memory (float64 and int64 fields; Snapshot and its checks
# hold about twice that while a frame is read and validated)
_PARTICLE_BYTES = 2 * 8 * sum(int(np.prod(trailing, dtype=np.int64)) for trailing, _, _ in PARTICLE_LAYOUT.values())
_CONTACT_BYTES = 2 * 8 * len(CONTACT_LAYOUT)


def _check_format(f, path) -> None:
    """The root attributes that make a file a run file: ``format``, the string FORMAT_NAME as
    :class:`RunWriter` writes it (UTF-8), and ``format_version``, an integer in [1, FORMAT_VERSION]."""
    fmt = f.attrs.get("format")
    info = h5py.check_string_dtype(f.attrs.get_id("format").dtype) if "format" in f.attrs else None
    if fmt != FORMAT_NAME or not isinstance(fmt, str) or info is None or info.encoding != "utf-8":
        stored = f" stored as {info.encoding} bytes" if isinstance(fmt, str) and info is not None else ""
        raise RunFileError(f"{path}: not a granalytics run file (attribute 'format' is {fmt!r}{stored}; "
                           f"a run file's is the UTF-8 string {FORMAT_NAME!r}){CONVERT_HINT}")
    version = f.attrs.get("format_version")
    if isinstance(version, (bool, np.bool_)) or not isinstance(version, (int, np.integer)) or version < 1:
        raise RunFileError(f"{path}: attribute 'format_version' must be an integer >= 1, got "
                           f"{type(version).__name__} {version!r}")
    if version > FORMAT_VERSION:
        raise RunFileError(f"{path}: format version {version} is newer than this granalytics reads ({FORMAT_VERSION})")


def _read_meta(group, path) -> RunMeta:
    data = {}
    for key, value in group.attrs.items():
        if key in ("sim_config", "provenance"):
            if not isinstance(value, str):
                raise ValidationError(f"/meta/{key}", f"must be a JSON text, got {type(value).__name__} {value!r}",
                                      path=path)
            data[key] = json.loads(value)
        elif isinstance(value, np.ndarray) and value.ndim:
            data[key] = tuple(value.tolist())
        else:
            data[key] = value.item() if hasattr(value, "item") else value
    try:
        return RunMeta.from_dict(data)
    except ValidationError as exc:
        raise exc.located(path) from None
    except TypeError as exc:
        raise RunFileError(f"{path}: incomplete run metadata in /meta ({exc})") from None


class _FrameSequence(Sequence):
    """Shared behaviour of :class:`Run` and :class:`RunSlice`: a lazy sequence of frames."""

    _run: "Run"
    _indices: np.ndarray

    def __len__(self):
        return len(self._indices)

    def __getitem__(self, key):
        if isinstance(key, slice):
            return RunSlice(self._run, self._indices[key])
        if isinstance(key, (int, np.integer)):  # NumPy raises the IndexError of a key out of range
            return self._run.frame(int(self._indices[key]))
        raise FrameKeyError(f"frames are indexed by int or slice, not {type(key).__name__}")

    def __iter__(self):
        for k in self._indices:
            yield self._run.frame(int(k))

    @property
    def meta(self) -> RunMeta:
        """Run metadata."""
        return self._run._meta

    @property
    def frame_indices(self) -> np.ndarray:
        """Indices of these frames in the run file."""
        return self._indices.copy()

    @property
    def times(self) -> np.ndarray:
        """Simulated time of each frame [s]."""
        return self._run._time[self._indices]

    @property
    def steps(self) -> np.ndarray:
        """Step number of each frame."""
        return self._run._step[self._indices]

    @property
    def revolutions(self) -> np.ndarray:
        """Drum revolutions t·Ω/2π of each frame (raises if the run has Ω = 0)."""
        omega = self.meta.drum_omega
        if omega == 0:
            raise ValidationError("drum_omega", "is 0 in this run: revolutions are undefined", path=self._run.path)
        return self.times * abs(omega) / (2 * math.pi)

    @property
    def n_contacts(self) -> np.ndarray:
        """Number of contacts and bridges in each frame."""
        return self._run._count[self._indices]

    def select(self, *, time=None, revolutions=None) -> "RunSlice":
        """Frames whose time [s] or revolution count lies in a closed interval (a frame within
        a tenth of the smallest frame spacing of an edge counts as inside: frames lie on whole time
        steps).

        Parameters
        ----------
        time : (float, float), optional
            ``(t_min, t_max)`` in seconds.
        revolutions : (float, float), optional
            ``(r_min, r_max)`` in drum revolutions.
        """
        if (time is None) == (revolutions is None):
            raise ValidationError("select", "give exactly one of time=(t0, t1) or revolutions=(r0, r1)")
        name, window = ("time", time) if time is not None else ("revolutions", revolutions)
        validate("select", {name: [WINDOW]}, {name: window})
        lo, hi = np.asarray(window, dtype=float)
        values = self.times if time is not None else self.revolutions
        return RunSlice(self._run, self._indices[window_mask(values, lo, hi)])

    def nearest(self, *, time=None, revolutions=None) -> Snapshot:
        """The frame closest to a time [s] or a revolution count."""
        if (time is None) == (revolutions is None):
            raise ValidationError("nearest", "give exactly one of time= or revolutions=")
        validate("nearest", {"time": [Interval(Real), None], "revolutions": [Interval(Real), None]},
                 {"time": time, "revolutions": revolutions})
        if not len(self):
            raise IndexError("no frames")
        values = self.times if time is not None else self.revolutions
        target = float(time if time is not None else revolutions)
        name = "time" if time is not None else "revolutions"
        k = int(np.argmin(np.abs(values - target)))
        spacing = float(np.min(np.diff(values))) if len(values) > 1 else 0.0
        if abs(values[k] - target) > max(spacing, 0.0):
            unit = " s" if time is not None else " revolutions"
            warnings.warn(f"nearest: no frame near {name}={target:g}: the frames span {values[0]:g}–{values[-1]:g}"
                          f"{unit}; returning frame {k} at {values[k]:g}{unit}", stacklevel=user_stacklevel())
        return self[k]


class Run(HDF5Handle, _FrameSequence):
    """A run file opened for lazy reading: a sequence of :class:`Snapshot`.

    Frames are read and validated only when accessed; the frame index (see ``docs/format.md``,
    "Checks on open") is checked when the file is opened. Use :func:`open_run` to create one,
    and close it (or use it as a context manager) when done.

    Attributes
    ----------
    path : str
        The file.
    n_particles : int
        Particles per frame.
    """

    @validate_params({"path": [PATH], "validate": [FLAG]})
    def __init__(self, path, *, validate=True):
        self.path = os.fspath(path)
        self.validate = validate
        if not os.path.exists(self.path):
            raise RunFileError(f"{self.path}: no such file")
        if not os.path.isfile(self.path):  # a FIFO would block for ever, a folder is no run
            raise RunFileError(f"{self.path}: not a regular file (a folder, FIFO, socket or device is no run file)")
        self._file, self._writer_open = open_h5(self.path)
        try:
            self._load_index()
        except GranalyticsError:
            self._file.close()
            raise
        except Exception as exc:  # h5py raises OSError, KeyError, ValueError, ... on a damaged file
            self._file.close()
            raise RunFileError(f"{self.path}: broken run file ({one_line(exc)})") from None

    def _load_index(self):
        f, path = self._file, self.path
        _check_format(f, path=path)
        if "meta" not in f:
            raise RunFileError(f"{path}: missing group /meta")
        self._meta = _read_meta(f["meta"], path=path)
        self._run = self
        if "frames" not in f:  # created, but no frame was ever committed
            self.n_particles = self._meta.n_particles
            self._time = np.zeros(0)
            self._step = np.zeros(0, dtype=np.int64)
            self._count = np.zeros(0, dtype=np.int64)
            self._offset = np.zeros(1, dtype=np.int64)
            self._indices = np.zeros(0, dtype=np.int64)
            return
        for name in PER_FRAME_DATASETS + CONTACT_DATASETS:
            if name not in f:
                raise RunFileError(f"{path}: missing dataset /{name}")
        n_particles = f["particles/radius"].shape[1]
        for name, (trailing, _dtype, _unit) in PARTICLE_LAYOUT.items():
            shape = f["particles"][name].shape
            if shape[1:] != (n_particles,) + trailing:
                raise RunFileError(f"{path}: dataset /particles/{name} has shape {shape}, expected (frames, "
                                   f"{', '.join(map(str, (n_particles,) + trailing))})")
        if n_particles != self._meta.n_particles:
            raise ValidationError("/meta", f"attribute n_particles is {self._meta.n_particles}, but /particles/radius "
                                  f"holds {n_particles} particles per frame", path=path)
        lengths = {name: f[name].shape[0] for name in PER_FRAME_DATASETS}
        rows = {name: f[name].shape[0] for name in CONTACT_DATASETS}
        if self._writer_open:
            # the writer is running or was killed: its last frame may be partly written, and a
            # running writer appends while the lengths are read, so the committed frames are
            # those every per-frame dataset holds
            n_frames = min(lengths.values())
        else:
            # closed normally: one entry per frame in every per-frame dataset
            n_frames = lengths["frames/time"]
            for name, n in lengths.items():
                if n != n_frames:
                    raise RunFileError(f"{path}: dataset /{name}, index {min(n, n_frames)}: holds {n} frames, "
                                       f"but /frames/time holds {n_frames}")
            n_rows = rows[CONTACT_DATASETS[0]]
            for name, n in rows.items():
                if n != n_rows:
                    raise RunFileError(f"{path}: dataset /{name}, index {min(n, n_rows)}: holds {n} contact rows, "
                                       f"but /{CONTACT_DATASETS[0]} holds {n_rows}")
        # the frame index (time, step, count, offset: 32 bytes a frame) is read whole
        check_memory(f"{path}: reading the index of {n_frames} frames", 32 * n_frames)
        count = _read_index(f, "contacts/count", n_frames, path).astype(np.int64)
        refuse_first("/contacts/count", count < 0, lambda k: f"negative count {count[k]}", path=path)
        offset = np.zeros(n_frames + 1, dtype=np.int64)
        np.cumsum(count, out=offset[1:])
        if self._writer_open:
            n_frames = int(np.searchsorted(offset, min(rows.values()), side="right")) - 1
        elif offset[-1] != n_rows:
            raise ValidationError("/contacts/count", f"the counts of the {n_frames} frames add up to {offset[-1]} "
                                  f"contact rows, but the contact datasets hold {n_rows}: an entry was changed or "
                                  "contact rows are missing", path=path)
        largest = int(count[:n_frames].max()) if n_frames else 0
        check_memory(f"{path}: reading one frame ({n_particles} particles, up to {largest} contacts)",
                     _PARTICLE_BYTES * n_particles + _CONTACT_BYTES * largest)
        time = _read_index(f, "frames/time", n_frames, path).astype(np.float64)
        step = _read_index(f, "frames/step", n_frames, path).astype(np.int64)
        _check_index(time, step, path=path)
        self.n_particles = int(n_particles)
        self._time = time
        self._step = step
        self._count = count[:n_frames]
        self._offset = offset[: n_frames + 1]
        self._indices = np.arange(n_frames, dtype=np.int64)
        if self._writer_open:
            _check_inside_file(f, path, n_frames, int(self._offset[-1]))
        if n_frames:
            _check_records_agree(self._meta, f["particles/radius"][0], path=path)

    def _read(self, name, selection, frame):
        try:
            return self._file[name][selection]
        except Exception as exc:
            raise RunFileError(f"{self.path}: dataset /{name}, frame {frame}: cannot be read "
                               f"({one_line(exc)}); the file is damaged or was cut short") from None

    def frame(self, index: int) -> Snapshot:
        """Read and validate frame ``index`` (an index into the file, 0-based).

        Raises
        ------
        RunFileError
            A chunk of the frame cannot be read (e.g. its checksum does not match): the message
            names the file, the dataset and the frame.
        ValidationError
            The frame's data violate the data model.
        """
        if self._file is None:
            raise RunFileError(f"{self.path}: run is closed")
        start, stop = int(self._offset[index]), int(self._offset[index + 1])
        data = {name: self._read(f"particles/{name}", index, index) for name in PARTICLE_FIELDS}
        for field, (name, _unit) in CONTACT_LAYOUT.items():
            data[field] = self._read(f"contacts/{name}", slice(start, stop), index)
        for name, value in data.items():  # float32 storage is read back as float64
            if value.dtype == np.float32:
                data[name] = value.astype(np.float64)
        try:
            return _make_snapshot(self.validate, time=self._time[index], step=self._step[index], meta=self._meta,
                                  **data)
        except ValidationError as exc:
            raise exc.located(self.path, index) from None

    @property
    def unfinished(self) -> str | None:
        """Why this run is unfinished (one phrase), or None when nothing says so.

        A run is unfinished when its writer did not close the file (a simulation killed, or
        still running), when it holds fewer frames than its producer planned
        (``provenance["planned_frames"]``), when its producer recorded that it stopped early
        (``provenance["interrupted"]``, a phrase), or when it comes from the simulator and records no
        wall time (``sim`` writes it after the last frame; a copy of a stopped run keeps its
        provenance and is unfinished too).
        """
        reasons = []
        planned = self._meta.provenance.get("planned_frames")
        if planned is not None and len(self) < planned:
            reasons.append(f"it holds {len(self)} of the {planned} frames planned")
        if self._writer_open:
            reasons.append("its writer did not close it (killed, or still writing)")
        reasons += self._meta.stopped_early(held=f" after its {len(self)} frames")
        return "; ".join(reasons) or None

    def info(self) -> dict:
        """Summary of what the file holds (for ``granalytics info``)."""
        times = self._time
        out = {
            "path": self.path,
            "format_version": int(self._file.attrs.get("format_version", 0)),
            "created_by": str(self._file.attrs.get("created_by", "")),
            "finished": "no: " + self.unfinished if self.unfinished else "yes",
            "frames": len(self),
            "particles": self.n_particles,
            "time_first_s": float(times[0]) if len(times) else math.nan,
            "time_last_s": float(times[-1]) if len(times) else math.nan,
            "contacts_per_frame_mean": float(self._count.mean()) if len(times) else math.nan,
            "file_size_bytes": os.path.getsize(self.path),
        }
        if len(times) and self._meta.drum_omega != 0:
            revs = self.revolutions
            out["revolutions_first"] = float(revs[0])
            out["revolutions_last"] = float(revs[-1])
        return out

    def __repr__(self):
        return f"Run({self.path!r}, frames={len(self)}, particles={self.n_particles})"


class RunSlice(_FrameSequence):
    """A lazy selection of frames of a :class:`Run` (from slicing or :meth:`Run.select`)."""

    @validate_params({"run": [Instance(Run, "an open Run (granalytics.open_run)")],
                      "indices": [Array(ndim=1, dtype=Integral)]})
    def __init__(self, run: Run, indices):
        indices = np.asarray(indices, dtype=np.int64)
        if indices.size and not (0 <= indices.min() and indices.max() < len(run)):
            raise ParameterError(f"RunSlice: frame indices must lie in [0, {len(run)}) for the {len(run)} frames of "
                                 f"{run.path}, got {indices.min()}..{indices.max()}")
        self._run = run
        self._indices = indices

    def __repr__(self):
        return f"RunSlice({self._run.path!r}, frames={len(self)})"

    @property
    def path(self) -> str:
        """The run file's path."""
        return self._run.path


def _make_snapshot(validate, **fields) -> Snapshot:
    if validate:
        return Snapshot(**fields)
    snapshot = Snapshot.__new__(Snapshot)
    for name, value in fields.items():
        setattr(snapshot, name, value)
    snapshot.contact_i = snapshot.contact_i.astype(np.int64)
    snapshot.contact_j = snapshot.contact_j.astype(np.int64)
    snapshot.time, snapshot.step = float(snapshot.time), int(snapshot.step)
    return snapshot


def _read_index(f, name, n, path) -> np.ndarray:
    """The first ``n`` entries of an index dataset; a damaged chunk names its frames."""
    ds = f[name]
    try:
        return ds[:n]
    except Exception as exc:
        reason = one_line(exc)
    chunk = ds.chunks[0] if ds.chunks else max(n, 1)
    for start in range(0, n, chunk):
        stop = min(start + chunk, n)
        try:
            ds[start:stop]
        except Exception:
            raise RunFileError(f"{path}: dataset /{name}, frames {start}-{stop - 1}: cannot be read ({reason}); "
                               "the file is damaged or was cut short") from None
    raise RunFileError(f"{path}: dataset /{name} cannot be read ({reason}); the file is damaged or was cut short")


#: the fields of the run metadata that the simulator's own record (sim_config["params"]) repeats
_RECORDED_TWICE = ("alpha", "n_particles", "surface_tension", "drum_omega", "density")


def _check_records_agree(meta, radius_0, path) -> None:
    """Refuse a run whose records contradict each other: the metadata against the simulator's
    parameters it repeats, and its mean radius against the particles of the first frame (more than
    10 % apart: a nominal mean may differ from a sample's by a little, another scale by far; a run
    relabelled α = 1 while its particles are CG3's would be analysed at the wrong scale)."""
    params = meta.sim_config.get("params", {})  # RunMeta's schema: a table of finite numbers where present
    for name in _RECORDED_TWICE:
        value, recorded = getattr(meta, name), params.get(name)
        if recorded is not None and not math.isclose(float(value), float(recorded), rel_tol=1e-9):
            raise ValidationError("/meta", f"attribute {name} is {value!r}, but the simulator's parameters "
                                  f"(sim_config.params) record {recorded!r}: the run's records disagree", path=path)
    mean = float(np.mean(radius_0))
    if not math.isclose(mean, float(meta.mean_radius), rel_tol=0.1):  # a nominal mean may differ from a sample's
        raise ValidationError("/meta", f"attribute mean_radius is {meta.mean_radius:.6g} m, but the particles of "
                              f"frame 0 have a mean radius of {mean:.6g} m: the run's records disagree", path=path)


def _check_index(time, step, path) -> None:
    """Times finite and strictly increasing; steps >= 0 and strictly increasing (or all equal:
    the producer did not record steps). Each test runs only after the one before it passed."""
    refuse_first("/frames/time", ~np.isfinite(time), lambda k: f"non-finite value {time[k]}", path=path)
    refuse_first("/frames/time", np.diff(time) <= 0,
                  lambda k: f"must increase from frame to frame: {time[k]!r} after {time[k - 1]!r}", path=path, shift=1)
    refuse_first("/frames/step", step < 0, lambda k: f"must be >= 0, got {step[k]}", path=path)
    if step.size and not (step == step[0]).all():
        refuse_first("/frames/step", np.diff(step) <= 0,
                      lambda k: f"must increase from frame to frame: {step[k]} after {step[k - 1]}", path=path, shift=1)


def _check_inside_file(f, path, n_frames, n_rows) -> None:
    """Every chunk of the committed frames lies inside the file. A file whose writer did not
    close it records no reliable end-of-file address, so a copy cut short is found here.

    The file size is taken after the chunk index is read: a running writer writes a chunk before
    the index entry that points to it, so only a cut file has chunks beyond its end."""
    for name in PER_FRAME_DATASETS + CONTACT_DATASETS:
        ds = f[name]
        limit = n_frames if name in PER_FRAME_DATASETS else n_rows
        if ds.chunks is None or not hasattr(ds.id, "chunk_iter"):
            continue
        chunks = []
        ds.id.chunk_iter(lambda info, chunks=chunks: chunks.append(
            (info.chunk_offset[0], info.byte_offset + info.size)))
        size = os.path.getsize(path)
        beyond = [start for start, end in chunks if start < limit and end > size]
        if beyond:
            first = min(beyond)
            where = f"frame {first}" if name in PER_FRAME_DATASETS else f"contact row {first}"
            raise RunFileError(f"{path}: dataset /{name}, {where}: stored beyond the end of the file "
                               f"({size} bytes); the file was cut short")


@validate_params({"path": [PATH], "validate": [FLAG]})
def open_run(path, *, validate=True) -> Run:
    """Open a run file for lazy, frame-by-frame reading.

    Parameters
    ----------
    path : str or path-like
        A file written by :class:`RunWriter` (also one whose writer was killed: every complete
        frame is readable).
    validate : bool, default True
        Validate every frame when it is read (see :meth:`Snapshot.validate`). Turn off only for
        trusted files when speed matters.

    Returns
    -------
    Run
        A sequence of :class:`Snapshot` with ``len``, indexing, slicing, iteration, and
        :meth:`~Run.select` / :meth:`~Run.nearest` by time or revolution.

    Opening checks the frame index (``docs/format.md``, "Checks on open") and returns or raises
    within seconds, also for a file that was cut short. Reading a frame whose chunk fails its
    checksum raises :class:`RunFileError` naming the dataset and the frame.

    Raises
    ------
    RunFileError
        The file is missing, not HDF5, cut short, damaged, structurally inconsistent (per-frame
        datasets of different lengths), or not a granalytics run.
    ValidationError
        Metadata or frame index data are invalid (contact counts that do not add up to the
        contact rows, time or step not increasing, ``n_particles`` not matching the arrays).
    """
    return Run(path, validate=validate)
