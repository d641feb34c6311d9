"""Native run file: one HDF5 file per run (layout in ``docs/format.md``).

The writer works in HDF5's single-writer/multiple-reader (SWMR) mode: the library orders its
metadata flushes so that the file on disk is always a consistent HDF5 file, even when the writer
is killed. On top of that, every frame is committed by writing the frame's ``/frames/time`` entry
*last*; a reader counts only the frames that every dataset holds completely, so a frame is either
entirely in the file or absent.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Sequence

import h5py
import numpy as np

from .. import __version__
from ..errors import RunFileError, ValidationError
from ..snapshot import CONTACT_FIELDS, PARTICLE_FIELDS, RunMeta, Snapshot

__all__ = ["RunWriter", "open_run", "Run", "RunSlice", "subset_run", "FORMAT_NAME", "FORMAT_VERSION"]

FORMAT_NAME = "granalytics-run"
FORMAT_VERSION = 1

# dataset name in /particles -> (trailing shape, dtype, unit)
_PARTICLE_LAYOUT = {
    "ids": ((), np.int64, "1"),
    "radius": ((), np.float64, "m"),
    "position": ((3,), np.float64, "m"),
    "velocity": ((3,), np.float64, "m s-1"),
    "angular_velocity": ((3,), np.float64, "rad s-1"),
    "film_volume": ((), np.float64, "m3"),
}
# Snapshot field -> (dataset name in /contacts, unit); index dtype chosen at creation
_CONTACT_LAYOUT = {
    "contact_i": ("i", "1"),
    "contact_j": ("j", "1"),
    "f_cap": ("f_cap", "N"),
    "f_normal": ("f_normal", "N"),
    "gap": ("gap", "m"),
    "bridge_volume": ("bridge_volume", "m3"),
}
assert tuple(_PARTICLE_LAYOUT) == PARTICLE_FIELDS and tuple(_CONTACT_LAYOUT) == CONTACT_FIELDS

_CONTACT_CHUNK_ROWS = 1 << 10
_CHUNK_CACHE_BYTES = 64 * 1024**2


class _HDF5Handle:
    """Owns an open h5py file: ``close()`` (idempotent) and context-manager use."""

    _file: h5py.File | None

    def close(self) -> None:
        """Close the file (idempotent)."""
        if self._file is not None:
            self._file.close()
            self._file = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


class RunWriter(_HDF5Handle):
    """Append snapshots to a new run file, one complete frame at a time.

    Parameters
    ----------
    path : str or path-like
        File to create. An existing file is replaced only with ``overwrite=True``.
    meta : RunMeta
        Run metadata, stored once in the file.
    compression : {"gzip", "lzf", None}, default "gzip"
        HDF5 filter for every dataset (gzip is readable by every HDF5 tool).
    compression_level : int, default 4
        gzip level 0–9.
    overwrite : bool, default False
        Replace an existing file.
    float_dtype : {"float64", "float32"}, default "float64"
        Storage type of the per-particle and per-contact floating-point datasets (times are
        always float64). ``"float32"`` halves the file for bundling and archiving (relative
        precision 6e-8: 2 nm on a 4 cm drum); readers always return float64 arrays.

    Examples
    --------
    >>> with RunWriter("run.h5", meta) as writer:       # doctest: +SKIP
    ...     for snapshot in frames:
    ...         writer.append(snapshot)
    """

    def __init__(self, path, meta, *, compression="gzip", compression_level=4, overwrite=False, float_dtype="float64"):
        if not isinstance(meta, RunMeta):
            raise ValidationError("meta", f"must be a RunMeta, got {type(meta).__name__}")
        self.path = os.fspath(path)
        if os.path.exists(self.path) and not overwrite:
            raise RunFileError(f"{self.path}: file exists (pass overwrite=True to replace it)")
        self.meta = meta
        if float_dtype not in ("float64", "float32"):
            raise ValidationError("float_dtype", f"must be 'float64' or 'float32', got {float_dtype!r}")
        self._float = np.dtype(float_dtype)
        if compression not in ("gzip", "lzf", None):
            raise ValidationError("compression", f"must be 'gzip', 'lzf' or None, got {compression!r}")
        self._filter = {}
        if compression is not None:
            self._filter = {"compression": compression, "shuffle": True}
            if compression == "gzip":
                self._filter["compression_opts"] = int(compression_level)
        try:
            self._file = h5py.File(self.path, "w", libver="latest")
        except OSError as exc:
            raise RunFileError(f"{self.path}: cannot create run file ({exc})") from None
        self._file.attrs["format"] = FORMAT_NAME
        self._file.attrs["format_version"] = FORMAT_VERSION
        self._file.attrs["created_by"] = f"granalytics {__version__}"
        _write_meta(self._file.create_group("meta"), meta)
        self._file.flush()
        self._n_particles = None
        self._n_frames = 0
        self._n_contact_rows = 0
        self._last_time = -math.inf
        self._provenance_update = {}

    @property
    def n_frames(self) -> int:
        """Number of frames committed so far."""
        return self._n_frames

    @classmethod
    def continue_from(cls, path, n_frames, **kwargs) -> "RunWriter":
        """Reopen a run for appending after its first ``n_frames`` complete frames.

        Used to resume a killed writer (e.g. a simulation restarted from a checkpoint): the
        first ``n_frames`` frames and the metadata are copied bit for bit into a new file that
        then atomically replaces ``path``; later frames of the old file are dropped.

        Raises
        ------
        RunFileError
            If ``path`` holds fewer than ``n_frames`` complete frames.
        """
        path = os.fspath(path)
        tmp = path + ".continue.tmp"
        with open_run(path) as run:
            if len(run) < n_frames:
                raise RunFileError(f"{path}: holds {len(run)} complete frames, cannot continue after frame {n_frames}")
            writer = cls(tmp, run.meta, overwrite=True, **kwargs)
            for k in range(n_frames):
                writer.append(run[k])
        writer._file.flush()
        os.replace(tmp, path)  # the open handle follows the file to its new name
        writer.path = path
        return writer

    def append(self, snapshot: Snapshot) -> None:
        """Write one frame and commit it.

        Raises
        ------
        ValidationError
            If the snapshot is invalid, has a different particle count than earlier frames or
            than ``meta.n_particles``, or its time does not increase.
        """
        if self._file is None:
            raise RunFileError(f"{self.path}: writer is closed")
        if not isinstance(snapshot, Snapshot):
            raise ValidationError("snapshot", f"must be a Snapshot, got {type(snapshot).__name__}")
        frame = self._n_frames
        try:
            snapshot.validate()
        except ValidationError as exc:
            raise exc.located(self.path, frame) from None
        n = snapshot.n_particles
        if self._n_particles is None:
            if n != self.meta.n_particles:
                raise ValidationError(
                    "radius", f"frame has {n} particles but meta.n_particles is {self.meta.n_particles}",
                    frame=frame, path=self.path,
                )
            self._create_datasets(n)
        elif n != self._n_particles:
            raise ValidationError(
                "radius", f"particle count changed from {self._n_particles} to {n}; a run holds a fixed particle set",
                frame=frame, path=self.path,
            )
        if not snapshot.time > self._last_time:
            raise ValidationError(
                "time", f"must increase from frame to frame: {snapshot.time!r} after {self._last_time!r}",
                frame=frame, path=self.path,
            )
        f = self._file
        for name in PARTICLE_FIELDS:
            ds = f["particles"][name]
            ds.resize(frame + 1, axis=0)
            ds[frame] = getattr(snapshot, name)
            ds.flush()
        m = snapshot.n_contacts
        start, stop = self._n_contact_rows, self._n_contact_rows + m
        for field, (name, _unit) in _CONTACT_LAYOUT.items():
            ds = f["contacts"][name]
            ds.resize(stop, axis=0)
            if m:
                ds[start:stop] = getattr(snapshot, field)
            ds.flush()
        self._append_scalar(f["contacts/count"], frame, m)
        self._append_scalar(f["frames/step"], frame, snapshot.step)
        self._append_scalar(f["frames/time"], frame, snapshot.time)  # commit point: written last
        self._n_contact_rows = stop
        self._n_frames += 1
        self._last_time = snapshot.time

    def update_provenance(self, **items) -> None:
        """Merge ``items`` into the run's ``provenance`` metadata when the writer closes.

        For facts known only at the end of a run, e.g. the producing code's wall time
        (``wall_time_s``). Values must be JSON-serialisable. A killed writer loses them; its
        frames are unaffected.
        """
        json.dumps(items)  # refuse what cannot be stored, now rather than at close
        self._provenance_update.update(items)

    @staticmethod
    def _append_scalar(ds, frame, value):
        ds.resize(frame + 1, axis=0)
        ds[frame] = value
        ds.flush()

    def close(self, compact=True) -> None:
        """Close the file (idempotent).

        With ``compact`` (default), the datasets are then copied into a fresh file that replaces
        the original: appending in SWMR mode leaves the space of every rewritten partial chunk
        unused, and the copy drops it (and HDF5's "open for write" flag). A killed writer skips
        this step; its file stays valid, only larger.
        """
        if self._file is None:
            return
        super().close()
        if compact:
            tmp = self.path + ".compact.tmp"
            with h5py.File(self.path, "r") as src, h5py.File(tmp, "w", libver="latest") as dst:
                for key, value in src.attrs.items():
                    dst.attrs[key] = value
                for name in src:
                    src.copy(src[name], dst, name=name)
                self._write_provenance_update(dst)
            os.replace(tmp, self.path)
        elif self._provenance_update:
            with h5py.File(self.path, "r+") as f:
                self._write_provenance_update(f)

    def _write_provenance_update(self, f) -> None:
        if self._provenance_update:
            provenance = json.loads(f["meta"].attrs["provenance"])
            provenance.update(self._provenance_update)
            f["meta"].attrs["provenance"] = json.dumps(provenance, sort_keys=True)

    def _create_datasets(self, n):
        f = self._file
        frames = f.create_group("frames")
        frames.create_dataset("time", shape=(0,), maxshape=(None,), dtype=np.float64, chunks=(4096,))
        frames["time"].attrs["unit"] = "s"
        frames.create_dataset("step", shape=(0,), maxshape=(None,), dtype=np.int64, chunks=(4096,))
        frames["step"].attrs["unit"] = "1"
        particles = f.create_group("particles")
        for name, (trailing, dtype, unit) in _PARTICLE_LAYOUT.items():
            ds = particles.create_dataset(
                name, shape=(0, n) + trailing, maxshape=(None, n) + trailing,
                dtype=self._float if dtype is np.float64 else dtype,
                chunks=(1, n) + trailing, **self._filter,
            )
            ds.attrs["unit"] = unit
        contacts = f.create_group("contacts")
        index_dtype = np.int32 if n < 2**31 else np.int64
        for field, (name, unit) in _CONTACT_LAYOUT.items():
            dtype = index_dtype if field in ("contact_i", "contact_j") else self._float
            ds = contacts.create_dataset(
                name, shape=(0,), maxshape=(None,), dtype=dtype, chunks=(_CONTACT_CHUNK_ROWS,),
                **self._filter,
            )
            ds.attrs["unit"] = unit
        contacts.create_dataset("count", shape=(0,), maxshape=(None,), dtype=np.int64, chunks=(4096,))
        self._n_particles = n
        f.swmr_mode = True



def _write_meta(group, meta: RunMeta):
    for key, value in meta.to_dict().items():
        if key in ("sim_config", "provenance"):
            group.attrs[key] = json.dumps(value, sort_keys=True)
        else:
            group.attrs[key] = np.asarray(value)


def _read_meta(group, path) -> RunMeta:
    data = {}
    for key, value in group.attrs.items():
        if key in ("sim_config", "provenance"):
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
        if isinstance(key, (int, np.integer)):
            n = len(self._indices)
            if not -n <= key < n:
                raise IndexError(f"frame {key} out of range for {n} frames")
            return self._run.frame(int(self._indices[key]))
        raise TypeError(f"frames are indexed by int or slice, not {type(key).__name__}")

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
            raise ValidationError(
                "drum_omega", "is 0 in this run: revolutions are undefined", path=self._run.path
            )
        return self.times * abs(omega) / (2 * math.pi)

    @property
    def n_contacts(self) -> np.ndarray:
        """Number of contacts and bridges in each frame."""
        return self._run._count[self._indices]

    def select(self, *, time=None, revolutions=None) -> "RunSlice":
        """Frames whose time [s] or revolution count lies in a closed interval.

        Parameters
        ----------
        time : (float, float), optional
            ``(t_min, t_max)`` in seconds.
        revolutions : (float, float), optional
            ``(r_min, r_max)`` in drum revolutions.
        """
        if (time is None) == (revolutions is None):
            raise ValidationError("select", "give exactly one of time=(t0, t1) or revolutions=(r0, r1)")
        lo, hi = time if time is not None else revolutions
        values = self.times if time is not None else self.revolutions
        if not lo <= hi:
            raise ValidationError("select", f"empty interval [{lo}, {hi}]")
        keep = (values >= lo) & (values <= hi)
        return RunSlice(self._run, self._indices[keep])

    def nearest(self, *, time=None, revolutions=None) -> Snapshot:
        """The frame closest to a time [s] or a revolution count."""
        if (time is None) == (revolutions is None):
            raise ValidationError("nearest", "give exactly one of time= or revolutions=")
        if not len(self):
            raise IndexError("no frames")
        values = self.times if time is not None else self.revolutions
        target = time if time is not None else revolutions
        return self[int(np.argmin(np.abs(values - target)))]


class Run(_HDF5Handle, _FrameSequence):
    """A run file opened for lazy reading: a sequence of :class:`Snapshot`.

    Frames are read and validated only when accessed. Use :func:`open_run` to create one, and
    close it (or use it as a context manager) when done.

    Attributes
    ----------
    path : str
        The file.
    n_particles : int
        Particles per frame.
    """

    def __init__(self, path, *, validate=True):
        self.path = os.fspath(path)
        self.validate = validate
        if not os.path.exists(self.path):
            raise RunFileError(f"{self.path}: no such file")
        self._file = _open_h5(self.path)
        try:
            self._load_index()
        except (OSError, KeyError) as exc:
            self._file.close()
            if isinstance(exc, RunFileError):
                raise
            raise RunFileError(f"{self.path}: broken run file ({exc})") from None
        except Exception:
            self._file.close()
            raise

    def _load_index(self):
        f, path = self._file, self.path
        if f.attrs.get("format") != FORMAT_NAME:
            raise RunFileError(f"{path}: not a granalytics run file (attribute 'format' is {f.attrs.get('format')!r})")
        version = int(f.attrs.get("format_version", -1))
        if version > FORMAT_VERSION:
            raise RunFileError(f"{path}: format version {version} is newer than this granalytics reads ({FORMAT_VERSION})")
        if "meta" not in f:
            raise RunFileError(f"{path}: missing group /meta")
        self._meta = _read_meta(f["meta"], path)
        self._run = self
        if "frames" not in f:  # created, but no frame was ever committed
            self.n_particles = self._meta.n_particles
            self._time = np.zeros(0)
            self._step = np.zeros(0, dtype=np.int64)
            self._count = np.zeros(0, dtype=np.int64)
            self._offset = np.zeros(1, dtype=np.int64)
            self._indices = np.zeros(0, dtype=np.int64)
            return
        required = ["frames/time", "frames/step", "contacts/count"]
        required += [f"particles/{name}" for name in PARTICLE_FIELDS]
        required += [f"contacts/{name}" for name, _ in _CONTACT_LAYOUT.values()]
        for name in required:
            if name not in f:
                raise RunFileError(f"{path}: missing dataset /{name}")
        n_particles = f["particles/radius"].shape[1]
        for name, (trailing, _dtype, _unit) in _PARTICLE_LAYOUT.items():
            shape = f["particles"][name].shape
            if shape[1:] != (n_particles,) + trailing:
                raise RunFileError(
                    f"{path}: dataset /particles/{name} has shape {shape}, expected (frames, {n_particles}"
                    + "".join(f", {t}" for t in trailing) + ")"
                )
        # committed frames: those every per-frame dataset holds completely
        n_frames = min(
            [len(f["frames/time"]), len(f["frames/step"]), len(f["contacts/count"])]
            + [len(f["particles"][name]) for name in PARTICLE_FIELDS]
        )
        count = f["contacts/count"][:n_frames].astype(np.int64)
        if (count < 0).any():
            k = int(np.flatnonzero(count < 0)[0])
            raise ValidationError("contacts/count", f"negative count {count[k]}", index=k, frame=k, path=path)
        offset = np.zeros(n_frames + 1, dtype=np.int64)
        np.cumsum(count, out=offset[1:])
        rows = min(len(f["contacts"][name]) for name, _ in _CONTACT_LAYOUT.values())
        n_frames = int(np.searchsorted(offset, rows, side="right")) - 1
        self.n_particles = int(n_particles)
        self._time = f["frames/time"][:n_frames].astype(np.float64)
        self._step = f["frames/step"][:n_frames].astype(np.int64)
        self._count = count[:n_frames]
        self._offset = offset[: n_frames + 1]
        self._indices = np.arange(n_frames, dtype=np.int64)
        if not np.isfinite(self._time).all():
            k = int(np.flatnonzero(~np.isfinite(self._time))[0])
            raise ValidationError("time", f"non-finite value {self._time[k]}", frame=k, path=path)

    def frame(self, index: int) -> Snapshot:
        """Read and validate frame ``index`` (an index into the file, 0-based)."""
        if self._file is None:
            raise RunFileError(f"{self.path}: run is closed")
        f = self._file
        start, stop = int(self._offset[index]), int(self._offset[index + 1])
        try:
            data = {name: f["particles"][name][index] for name in PARTICLE_FIELDS}
            for field, (name, _unit) in _CONTACT_LAYOUT.items():
                data[field] = f["contacts"][name][start:stop]
            for name, value in data.items():  # float32 storage is read back as float64
                if value.dtype == np.float32:
                    data[name] = value.astype(np.float64)
        except (OSError, KeyError, ValueError) as exc:
            raise RunFileError(f"{self.path}: frame {index} cannot be read ({exc})") from None
        try:
            return _make_snapshot(
                self.validate, time=self._time[index], step=self._step[index], meta=self._meta, **data
            )
        except ValidationError as exc:
            raise exc.located(self.path, index) from None

    def info(self) -> dict:
        """Summary of what the file holds (for ``granalytics info``)."""
        times = self._time
        out = {
            "path": self.path,
            "format_version": int(self._file.attrs.get("format_version", 0)),
            "created_by": str(self._file.attrs.get("created_by", "")),
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

    def __init__(self, run: Run, indices):
        self._run = run
        self._indices = np.asarray(indices, dtype=np.int64)

    def __repr__(self):
        return f"RunSlice({self._run.path!r}, frames={len(self)})"


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


def _open_h5(path) -> h5py.File:
    """Open for reading. A file whose SWMR writer is still running or was killed is flagged
    'open for write' and opens only in SWMR read mode; every other file opens normally, which
    also lets HDF5 detect truncation."""
    try:
        return h5py.File(path, "r", rdcc_nbytes=_CHUNK_CACHE_BYTES)
    except OSError as exc:
        if "already open for write" not in str(exc):
            raise RunFileError(f"{path}: cannot read as HDF5 ({exc})") from None
    try:
        return h5py.File(path, "r", swmr=True, rdcc_nbytes=_CHUNK_CACHE_BYTES)
    except OSError as exc:
        raise RunFileError(f"{path}: cannot read as HDF5 ({exc})") from None


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

    Raises
    ------
    RunFileError
        The file is missing, not HDF5, truncated, or not a granalytics run.
    ValidationError
        Metadata or frame index data are invalid.
    """
    return Run(path, validate=validate)


def subset_run(src, dst, frames, *, float_dtype="float64", overwrite=False, progress=False) -> str:
    """Copy some frames of a run into a new run file, optionally stored as float32.

    For bundling and archiving long runs: e.g. every frame of the steady-state window and every
    fifth frame before it. The metadata is copied; ``provenance["subset_of"]`` records the source
    file name, its frame count, the frames kept and the storage type.

    Parameters
    ----------
    src, dst : path
        Source run and file to write (refused if it exists, unless ``overwrite``).
    frames : sequence of int
        Frame indices of ``src`` to keep, increasing.
    float_dtype : {"float64", "float32"}
    progress : bool
        Progress bar over frames.

    Returns
    -------
    str : ``dst``
    """
    from tqdm.auto import tqdm

    frames = np.asarray(frames, dtype=np.int64)
    with open_run(src) as run:
        if frames.size == 0 or (np.diff(frames) <= 0).any() or frames[0] < 0 or frames[-1] >= len(run):
            raise ValidationError("frames", f"must be increasing indices in [0, {len(run)}) of {src}")
        meta = RunMeta.from_dict(run.meta.to_dict())
        meta.provenance = {**meta.provenance, "subset_of": {
            "file": os.path.basename(os.fspath(src)), "frames_in_source": len(run),
            "frames_kept": frames.tolist(), "float_dtype": float_dtype}}
        with RunWriter(dst, meta, overwrite=overwrite, float_dtype=float_dtype) as writer:
            for k in tqdm(frames, disable=not progress, unit="frame", desc="subset"):
                writer.append(run[int(k)])
    return os.fspath(dst)
