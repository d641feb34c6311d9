"""Native run file: one HDF5 file per run (layout in ``docs/format.md``).

The writer works in HDF5's single-writer/multiple-reader (SWMR) mode: the library orders its
metadata flushes so that the file on disk is always a consistent HDF5 file, even when the writer
is killed. On top of that, every frame is committed by writing the frame's ``/frames/time`` entry
*last*; a reader counts only the frames that every dataset holds completely, so a frame is either
entirely in the file or absent.

One writer at a time: :class:`RunWriter` holds an exclusive lock file ``PATH.lock`` from before it
creates the file until it has closed (and compacted) it. Every dataset carries a Fletcher-32
checksum per chunk, and :func:`open_run` checks the frame index (lengths, contact counts, time and
step order, particle count) before any frame is read.
"""

from __future__ import annotations

import contextlib
import ctypes
import json
import math
import os
import socket
import struct
import time as _time
import warnings
from collections.abc import Sequence

import h5py
import numpy as np

from .. import __version__
from .._atomic import replaced_atomically
from .._windows import window_mask
from ..errors import GranalyticsError, RunFileError, RunLockedError, ValidationError
from ..snapshot import CONTACT_FIELDS, PARTICLE_FIELDS, RunMeta, Snapshot, json_problem

__all__ = ["RunWriter", "open_run", "Run", "RunSlice", "subset_run", "replacing_run", "WriterLock", "FORMAT_NAME", "FORMAT_VERSION"]

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
_INDEX_DATASETS = ("frames/time", "frames/step", "contacts/count")
_PER_FRAME_DATASETS = _INDEX_DATASETS + tuple(f"particles/{name}" for name in PARTICLE_FIELDS)
_CONTACT_DATASETS = tuple(f"contacts/{name}" for name, _unit in _CONTACT_LAYOUT.values())
# HDF5 retries a metadata read that fails its checksum in SWMR read mode (the writer may be
# updating it), doubling the wait each time from 1 ns: its default of 100 attempts sleeps for
# hours on a file that was cut short. 30 attempts wait about 1 s in all.
_SWMR_READ_ATTEMPTS = 30
_LOCK_SUFFIX = ".lock"


def _one_line(exc) -> str:
    """An exception's message on one line."""
    return " ".join(str(exc).split()) or type(exc).__name__


class WriterLock:
    """Exclusive lock of an output: the file ``target + ".lock"``, created with O_EXCL and
    holding the owner's pid and host as one JSON line.

    :class:`RunWriter` holds one on its run file while it is open; anything else that writes
    (e.g. a sweep folder's manifest) can hold one the same way, as a context manager::

        with WriterLock("study/manifest.csv"):
            ...

    A lock file whose owner is no longer running on this host (a killed writer) is taken over
    with a warning; any other existing lock raises
    :class:`~granalytics.errors.RunLockedError`, naming the lock file and its owner.
    """

    def __init__(self, target):
        self.target = os.fspath(target)
        self.path = self.target + _LOCK_SUFFIX
        self._record = None

    def __enter__(self) -> "WriterLock":
        return self.acquire()

    def __exit__(self, *exc_info) -> None:
        self.release()

    def acquire(self) -> "WriterLock":
        record = json.dumps({"pid": os.getpid(), "host": socket.gethostname(),
                             "since": _time.strftime("%Y-%m-%dT%H:%M:%S%z")}) + "\n"
        for _attempt in range(5):
            try:
                fd = os.open(self.path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644)
            except FileExistsError:
                text = _read_text(self.path)
                if text is None:  # released in the meantime
                    continue
                owner = _parse_lock(text)
                if owner is not None and _owner_is_dead(owner):
                    if self._take_over(text):
                        warnings.warn(
                            f"{self.target}: took over the stale lock file {self.path} "
                            f"(pid {owner['pid']} on host {owner['host']} is no longer running)",
                            stacklevel=4,
                        )
                    continue
                raise RunLockedError(f"{self.target}: another writer holds the lock file {self.path} "
                                     f"({_describe_owner(owner, text)}); delete the lock file only if "
                                     "no writer is running") from None
            except OSError as exc:
                raise RunFileError(f"{self.target}: cannot create the lock file {self.path} "
                                   f"({exc.strerror or _one_line(exc)})") from None
            try:
                os.write(fd, record.encode())
            finally:
                os.close(fd)
            self._record = record
            return self
        raise RunLockedError(f"{self.target}: the lock file {self.path} keeps changing hands; "
                             "another writer is starting on the same file")

    def _take_over(self, seen) -> bool:
        """Remove a stale lock file whose content is ``seen``; False if it changed meanwhile."""
        aside = f"{self.path}.stale.{os.getpid()}"
        try:
            os.rename(self.path, aside)
        except FileNotFoundError:
            return False
        except OSError as exc:
            raise RunFileError(f"{self.target}: cannot remove the stale lock file {self.path} "
                               f"({exc.strerror or _one_line(exc)})") from None
        if _read_text(aside) == seen:
            os.unlink(aside)
            return True
        try:  # another process took it over first: put its lock back
            os.link(aside, self.path)
        except OSError:
            pass
        os.unlink(aside)
        return False

    def release(self) -> None:
        """Remove the lock file if it is still this holder's (idempotent)."""
        if self._record is None:
            return
        record, self._record = self._record, None
        text = _read_text(self.path)
        if text == record:
            try:
                os.unlink(self.path)
            except FileNotFoundError:
                pass
        elif text is not None:
            warnings.warn(f"{self.target}: the lock file {self.path} was replaced while this writer "
                          "held it; left in place", stacklevel=3)


def _read_text(path):
    try:
        with open(path, encoding="utf-8", errors="replace") as f:
            return f.read()
    except FileNotFoundError:
        return None
    except OSError:
        return ""


def _parse_lock(text):
    try:
        owner = json.loads(text)
        if isinstance(owner, dict) and isinstance(owner.get("pid"), int) and isinstance(owner.get("host"), str):
            return owner
    except ValueError:
        pass
    return None


def _owner_is_dead(owner) -> bool:
    """True only when the owner ran on this host and its pid is gone."""
    if owner["host"] != socket.gethostname() or owner["pid"] <= 0:
        return False
    if owner["pid"] == os.getpid():
        return False
    try:
        os.kill(owner["pid"], 0)
    except ProcessLookupError:
        return True
    except OSError:  # exists, owned by another user
        return False
    return False


def _describe_owner(owner, text):
    if owner is None:
        return f"unreadable content {text.strip()[:60]!r}"
    since = f", since {owner['since']}" if owner.get("since") else ""
    return f"pid {owner['pid']} on host {owner['host']}{since}"


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

    The writer holds an exclusive lock file ``PATH.lock`` (pid and host of the writer) from
    before it creates the file until :meth:`close` has finished; a second writer on the same
    path raises :class:`~granalytics.errors.RunLockedError`. A lock left by a writer that is no
    longer running on this host is taken over with a warning.

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

    Raises
    ------
    RunLockedError
        Another writer holds ``PATH.lock``.
    RunFileError
        The file exists (without ``overwrite``) or cannot be created.

    Examples
    --------
    >>> with RunWriter("run.h5", meta) as writer:       # doctest: +SKIP
    ...     for snapshot in frames:
    ...         writer.append(snapshot)
    """

    _file = None
    _lock = None

    def __init__(self, path, meta, *, compression="gzip", compression_level=4, overwrite=False, float_dtype="float64",
                 _lock=None):
        if not isinstance(meta, RunMeta):
            raise ValidationError("meta", f"must be a RunMeta, got {type(meta).__name__}")
        meta.validate()  # fields may have been changed since construction
        self.path = os.fspath(path)
        self.meta = meta
        if float_dtype not in ("float64", "float32"):
            raise ValidationError("float_dtype", f"must be 'float64' or 'float32', got {float_dtype!r}")
        self._float = np.dtype(float_dtype)
        if compression not in ("gzip", "lzf", None):
            raise ValidationError("compression", f"must be 'gzip', 'lzf' or None, got {compression!r}")
        # every dataset gets a Fletcher-32 checksum per chunk: HDF5 refuses a damaged chunk on read
        self._filter = {"fletcher32": True}
        if compression is not None:
            self._filter.update(compression=compression, shuffle=True)
            if compression == "gzip":
                self._filter["compression_opts"] = int(compression_level)
        # the lock exists before the file is created or truncated, and until close() is done
        lock = _lock if _lock is not None else WriterLock(self.path).acquire()
        try:
            if os.path.exists(self.path) and not overwrite:
                raise RunFileError(f"{self.path}: file exists (pass overwrite=True to replace it)")
            try:
                self._file = h5py.File(self.path, "w", libver="latest")
            except OSError as exc:
                raise RunFileError(f"{self.path}: cannot create run file ({_one_line(exc)})") from None
            self._file.attrs["format"] = FORMAT_NAME
            self._file.attrs["format_version"] = FORMAT_VERSION
            self._file.attrs["created_by"] = f"granalytics {__version__}"
            _write_meta(self._file.create_group("meta"), meta)
            self._file.flush()
        except BaseException:
            self._discard()
            if _lock is None:
                lock.release()
            raise
        self._lock = lock
        self._n_particles = None
        self._n_frames = 0
        self._n_contact_rows = 0
        self._last_time = -math.inf
        self._last_step = None
        self._constant_steps = False  # every frame has the same step: the producer did not record steps
        self._provenance_update = {}

    @property
    def n_frames(self) -> int:
        """Number of frames committed so far."""
        return self._n_frames

    @property
    def lock_path(self) -> str:
        """The lock file this writer holds while it is open."""
        return self.path + _LOCK_SUFFIX

    @classmethod
    def continue_from(cls, path, n_frames, **kwargs) -> "RunWriter":
        """Reopen a run for appending after its first ``n_frames`` complete frames.

        Used to resume a killed writer (e.g. a simulation restarted from a checkpoint): under
        the run's lock, the first ``n_frames`` frames and the metadata are copied into a new file,
        checked against the original, and the new file then atomically replaces ``path``; later
        frames of the old file are dropped. The storage (compression, float type) and the
        metadata attributes are kept as they were unless ``kwargs`` (as for :class:`RunWriter`)
        say otherwise. On any error ``path`` is left untouched.

        Raises
        ------
        ValidationError
            ``n_frames`` is not an integer >= 0.
        RunFileError
            ``path`` does not exist, cannot be read, or holds fewer than ``n_frames`` complete
            frames; :class:`~granalytics.errors.RunLockedError` if another writer holds its lock.
        """
        path = os.fspath(path)
        if isinstance(n_frames, (bool, np.bool_)) or not isinstance(n_frames, (int, np.integer)) or n_frames < 0:
            raise ValidationError("n_frames", f"must be an integer >= 0, got {n_frames!r}")
        n_frames = int(n_frames)
        if kwargs.pop("overwrite", True) is not True:
            raise ValidationError("overwrite", "continue_from always replaces the file it continues")
        if not os.path.exists(path):
            raise RunFileError(f"{path}: no such file: nothing to continue")
        lock = WriterLock(path).acquire()
        tmp = path + ".continue.tmp"
        writer = None
        try:
            with open_run(path) as run:
                if len(run) < n_frames:
                    raise RunFileError(
                        f"{path}: holds {len(run)} complete frames, cannot continue after frame {n_frames}")
                settings = {**_storage_settings(run._file), **kwargs}
                writer = cls(tmp, run.meta, overwrite=True, _lock=lock, **settings)
                # keep the metadata and file attributes exactly as stored
                for key, value in run._file.attrs.items():
                    writer._file.attrs[key] = value
                dst_meta = writer._file["meta"].attrs
                for key in list(dst_meta):
                    del dst_meta[key]
                for key, value in run._file["meta"].attrs.items():
                    dst_meta[key] = value
                for k in range(n_frames):
                    writer.append(run[k])
                writer._file.flush()
                _check_continued(run, writer, n_frames, path)
            os.replace(tmp, path)  # the open handle follows the file to its new name
        except BaseException:
            if writer is not None:
                writer._discard()
            try:
                os.remove(tmp)
            except OSError:
                pass
            lock.release()
            raise
        writer.path = path
        return writer

    def append(self, snapshot: Snapshot) -> None:
        """Write one frame and commit it.

        Raises
        ------
        ValidationError
            If the snapshot is invalid, has a different particle count than earlier frames or
            than ``meta.n_particles``, or its time or step does not increase.
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
        if self._last_step is not None and not (
            snapshot.step > self._last_step and not self._constant_steps
            or snapshot.step == self._last_step and (self._constant_steps or frame == 1)
        ):
            raise ValidationError(
                "step", f"must increase from frame to frame: {snapshot.step} after {self._last_step}"
                + (" (or stay the same in every frame when steps are not recorded)"
                   if frame == 1 or self._constant_steps else ""),
                frame=frame, path=self.path,
            )
        if self._n_particles is None:
            self._create_datasets(n)
        f = self._file
        m = snapshot.n_contacts
        start, stop = self._n_contact_rows, self._n_contact_rows + m
        try:
            for name in PARTICLE_FIELDS:
                ds = f["particles"][name]
                ds.resize(frame + 1, axis=0)
                ds[frame] = getattr(snapshot, name)
                ds.flush()
            for field, (name, _unit) in _CONTACT_LAYOUT.items():
                ds = f["contacts"][name]
                ds.resize(stop, axis=0)
                if m:
                    ds[start:stop] = getattr(snapshot, field)
                ds.flush()
            self._append_scalar(f["contacts/count"], frame, m)
            self._append_scalar(f["frames/step"], frame, snapshot.step)
            self._append_scalar(f["frames/time"], frame, snapshot.time)  # commit point: written last
        except BaseException:  # e.g. Ctrl-C or a full disk: drop the partial frame
            self._trim()
            raise
        self._n_contact_rows = stop
        self._n_frames += 1
        self._last_time = snapshot.time
        self._constant_steps = frame >= 1 and snapshot.step == self._last_step
        self._last_step = snapshot.step

    def update_provenance(self, **items) -> None:
        """Merge ``items`` into the run's ``provenance`` metadata when the writer closes.

        For facts known only at the end of a run, e.g. the producing code's wall time
        (``wall_time_s``). Values must be JSON-serialisable (else :class:`ValidationError`). A
        killed writer loses them; its frames are unaffected.
        """
        problem = json_problem(items)  # refuse what cannot be stored, now rather than at close
        if problem:
            raise ValidationError("provenance", f"update_provenance: must be JSON-serialisable: {problem}",
                                  path=self.path)
        self._provenance_update.update(items)

    @staticmethod
    def _append_scalar(ds, frame, value):
        ds.resize(frame + 1, axis=0)
        ds[frame] = value
        ds.flush()

    def _trim(self) -> None:
        """Cut every dataset back to the committed frames (drops a partially written frame)."""
        f = self._file
        if f is None or self._n_particles is None:
            return
        try:
            for name in _INDEX_DATASETS[::-1] + _PER_FRAME_DATASETS[3:]:  # time first: un-commit
                if f[name].shape[0] != self._n_frames:
                    f[name].resize(self._n_frames, axis=0)
                    f[name].flush()
            for name in _CONTACT_DATASETS:
                if f[name].shape[0] != self._n_contact_rows:
                    f[name].resize(self._n_contact_rows, axis=0)
                    f[name].flush()
        except Exception:  # the file stays readable: a reader ignores a partial frame
            pass

    def _discard(self) -> None:
        """Close the HDF5 file without compacting it; the lock is not touched."""
        if self._file is not None:
            try:
                self._file.close()
            except Exception:
                pass
            self._file = None

    def close(self, compact=True) -> None:
        """Close the file (idempotent) and release the lock file.

        With ``compact`` (default), the datasets are then copied into a fresh file that replaces
        the original: appending in SWMR mode leaves the space of every rewritten partial chunk
        unused, and the copy drops it (and HDF5's "open for write" flag). A killed writer skips
        this step; its file stays valid, only larger. The lock is held until the copy is done.
        """
        if self._file is None:
            return
        try:
            self._trim()
            super().close()
            if compact:
                self._compact()
            elif self._provenance_update:
                try:
                    with h5py.File(self.path, "r+") as f:
                        self._write_provenance_update(f)
                except OSError as exc:
                    raise RunFileError(f"{self.path}: cannot record the provenance ({_one_line(exc)})") from None
        finally:
            if self._lock is not None:
                self._lock.release()

    def _compact(self) -> None:
        tmp = self.path + ".compact.tmp"
        try:
            with h5py.File(self.path, "r") as src, h5py.File(tmp, "w", libver="latest") as dst:
                for key, value in src.attrs.items():
                    dst.attrs[key] = value
                for name in src:
                    src.copy(src[name], dst, name=name)
                self._write_provenance_update(dst)
            os.replace(tmp, self.path)
        except BaseException as exc:
            try:
                os.remove(tmp)
            except OSError:
                pass
            if isinstance(exc, OSError) and not isinstance(exc, GranalyticsError):
                raise RunFileError(f"{self.path}: all frames are written, but compacting the file failed "
                                   f"({_one_line(exc)})") from None
            raise

    def __del__(self):
        # a writer dropped without close(): free the file and the lock (no compaction)
        try:
            self._discard()
            if self._lock is not None:
                self._lock.release()
        except Exception:
            pass

    def _write_provenance_update(self, f) -> None:
        if self._provenance_update:
            provenance = json.loads(f["meta"].attrs["provenance"])
            provenance.update(self._provenance_update)
            f["meta"].attrs["provenance"] = json.dumps(provenance, sort_keys=True)

    def _create_datasets(self, n):
        f = self._file
        checksum = {"fletcher32": True}
        frames = f.create_group("frames")
        frames.create_dataset("time", shape=(0,), maxshape=(None,), dtype=np.float64, chunks=(4096,), **checksum)
        frames["time"].attrs["unit"] = "s"
        frames.create_dataset("step", shape=(0,), maxshape=(None,), dtype=np.int64, chunks=(4096,), **checksum)
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
        contacts.create_dataset("count", shape=(0,), maxshape=(None,), dtype=np.int64, chunks=(4096,), **checksum)
        self._n_particles = n
        f.swmr_mode = True


def _storage_settings(f) -> dict:
    """``compression``, ``compression_level`` and ``float_dtype`` of an existing run file."""
    if "particles/radius" not in f:
        return {}
    ds = f["particles/radius"]
    out = {"float_dtype": "float32" if ds.dtype == np.float32 else "float64"}
    if ds.compression in ("gzip", "lzf"):
        out["compression"] = ds.compression
        if ds.compression == "gzip" and ds.compression_opts is not None:
            out["compression_level"] = int(ds.compression_opts)
    else:
        out["compression"] = None
    return out


def _check_continued(run, writer, n_frames, path) -> None:
    """The continued file holds exactly the first ``n_frames`` frames' index and the metadata."""
    f = writer._file
    same_meta = dict(f["meta"].attrs.items()).keys() == dict(run._file["meta"].attrs.items()).keys() and all(
        np.array_equal(np.asarray(value), np.asarray(run._file["meta"].attrs[key]))
        for key, value in f["meta"].attrs.items()
    )
    if n_frames:
        index_same = (np.array_equal(f["frames/time"][:], run.times[:n_frames])
                      and np.array_equal(f["frames/step"][:], run.steps[:n_frames])
                      and np.array_equal(f["contacts/count"][:], run.n_contacts[:n_frames])
                      and f["contacts/i"].shape[0] == int(run.n_contacts[:n_frames].sum()))
    else:
        index_same = "frames" not in f
    if not (same_meta and index_same):
        raise RunFileError(f"{path}: the copy of its first {n_frames} frames differs from the original; "
                           "the file was left unchanged")


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
        lo, hi = time if time is not None else revolutions
        values = self.times if time is not None else self.revolutions
        if not lo <= hi:
            raise ValidationError("select", f"empty interval [{lo}, {hi}]")
        return RunSlice(self._run, self._indices[window_mask(values, lo, hi)])

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

    def __init__(self, path, *, validate=True):
        self.path = os.fspath(path)
        self.validate = validate
        if not os.path.exists(self.path):
            raise RunFileError(f"{self.path}: no such file")
        self._file, self._writer_open = _open_h5(self.path)
        try:
            self._load_index()
        except GranalyticsError:
            self._file.close()
            raise
        except Exception as exc:  # h5py raises OSError, KeyError, ValueError, ... on a damaged file
            self._file.close()
            raise RunFileError(f"{self.path}: broken run file ({_one_line(exc)})") from None

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
        for name in _PER_FRAME_DATASETS + _CONTACT_DATASETS:
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
        if n_particles != self._meta.n_particles:
            raise ValidationError(
                "/meta", f"attribute n_particles is {self._meta.n_particles}, but /particles/radius holds "
                f"{n_particles} particles per frame", path=path,
            )
        lengths = {name: f[name].shape[0] for name in _PER_FRAME_DATASETS}
        rows = {name: f[name].shape[0] for name in _CONTACT_DATASETS}
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
            n_rows = rows[_CONTACT_DATASETS[0]]
            for name, n in rows.items():
                if n != n_rows:
                    raise RunFileError(f"{path}: dataset /{name}, index {min(n, n_rows)}: holds {n} contact rows, "
                                       f"but /{_CONTACT_DATASETS[0]} holds {n_rows}")
        count = _read_index(f, "contacts/count", n_frames, path).astype(np.int64)
        if (count < 0).any():
            k = int(np.flatnonzero(count < 0)[0])
            raise ValidationError("/contacts/count", f"negative count {count[k]}", index=k, path=path)
        offset = np.zeros(n_frames + 1, dtype=np.int64)
        np.cumsum(count, out=offset[1:])
        if self._writer_open:
            n_frames = int(np.searchsorted(offset, min(rows.values()), side="right")) - 1
        elif offset[-1] != n_rows:
            raise ValidationError(
                "/contacts/count", f"the counts of the {n_frames} frames add up to {offset[-1]} contact rows, "
                f"but the contact datasets hold {n_rows}: an entry was changed or contact rows are missing",
                path=path,
            )
        time = _read_index(f, "frames/time", n_frames, path).astype(np.float64)
        step = _read_index(f, "frames/step", n_frames, path).astype(np.int64)
        _check_index(time, step, path)
        self.n_particles = int(n_particles)
        self._time = time
        self._step = step
        self._count = count[:n_frames]
        self._offset = offset[: n_frames + 1]
        self._indices = np.arange(n_frames, dtype=np.int64)
        if self._writer_open:
            _check_inside_file(f, path, n_frames, int(self._offset[-1]))

    def _read(self, name, selection, frame):
        try:
            return self._file[name][selection]
        except Exception as exc:
            raise RunFileError(f"{self.path}: dataset /{name}, frame {frame}: cannot be read "
                               f"({_one_line(exc)}); the file is damaged or was cut short") from None

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
        for field, (name, _unit) in _CONTACT_LAYOUT.items():
            data[field] = self._read(f"contacts/{name}", slice(start, stop), index)
        for name, value in data.items():  # float32 storage is read back as float64
            if value.dtype == np.float32:
                data[name] = value.astype(np.float64)
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


def _read_index(f, name, n, path) -> np.ndarray:
    """The first ``n`` entries of an index dataset; a damaged chunk names its frames."""
    ds = f[name]
    try:
        return ds[:n]
    except Exception as exc:
        reason = _one_line(exc)
    chunk = ds.chunks[0] if ds.chunks else max(n, 1)
    for start in range(0, n, chunk):
        stop = min(start + chunk, n)
        try:
            ds[start:stop]
        except Exception:
            raise RunFileError(f"{path}: dataset /{name}, frames {start}-{stop - 1}: cannot be read ({reason}); "
                               "the file is damaged or was cut short") from None
    raise RunFileError(f"{path}: dataset /{name} cannot be read ({reason}); the file is damaged or was cut short")


def _check_index(time, step, path) -> None:
    """Times finite and strictly increasing; steps >= 0 and strictly increasing (or all equal:
    the producer did not record steps)."""
    bad = np.flatnonzero(~np.isfinite(time))
    if bad.size:
        k = int(bad[0])
        raise ValidationError("/frames/time", f"non-finite value {time[k]}", index=k, path=path)
    bad = np.flatnonzero(np.diff(time) <= 0)
    if bad.size:
        k = int(bad[0]) + 1
        raise ValidationError("/frames/time", f"must increase from frame to frame: {time[k]!r} after "
                              f"{time[k - 1]!r}", index=k, path=path)
    bad = np.flatnonzero(step < 0)
    if bad.size:
        k = int(bad[0])
        raise ValidationError("/frames/step", f"must be >= 0, got {step[k]}", index=k, path=path)
    if step.size > 1 and not (step == step[0]).all():
        bad = np.flatnonzero(np.diff(step) <= 0)
        if bad.size:
            k = int(bad[0]) + 1
            raise ValidationError("/frames/step", f"must increase from frame to frame: {step[k]} after "
                                  f"{step[k - 1]}", index=k, path=path)


def _check_inside_file(f, path, n_frames, n_rows) -> None:
    """Every chunk of the committed frames lies inside the file. A file whose writer did not
    close it records no reliable end-of-file address, so a copy cut short is found here.

    The file size is taken after the chunk index is read: a running writer writes a chunk before
    the index entry that points to it, so only a cut file has chunks beyond its end."""
    for name in _PER_FRAME_DATASETS + _CONTACT_DATASETS:
        ds = f[name]
        limit = n_frames if name in _PER_FRAME_DATASETS else n_rows
        if ds.chunks is None or not hasattr(ds.id, "chunk_iter"):
            continue
        chunks = []
        ds.id.chunk_iter(lambda info, chunks=chunks: chunks.append(
            (info.chunk_offset[0], info.byte_offset + info.size)))
        size = os.path.getsize(path)
        beyond = [start for start, end in chunks if start < limit and end > size]
        if beyond:
            first = min(beyond)
            where = f"frame {first}" if name in _PER_FRAME_DATASETS else f"contact row {first}"
            raise RunFileError(f"{path}: dataset /{name}, {where}: stored beyond the end of the file "
                               f"({size} bytes); the file was cut short")


def _superblock(path):
    """``(flags, end_of_file)`` from an HDF5 superblock, or None if none is found."""
    try:
        size = os.path.getsize(path)
        with open(path, "rb") as f:
            offset = 0
            while offset + 8 <= size:
                f.seek(offset)
                if f.read(8) == b"\x89HDF\r\n\x1a\n":
                    break
                offset = 512 if offset == 0 else 2 * offset
            else:
                return None
            head = f.read(64)
    except OSError:
        return None
    try:
        version = head[0]
        if version in (2, 3):
            width, flags, first = head[1], head[3], 4
        elif version in (0, 1):
            width, flags, first = head[5], struct.unpack_from("<I", head, 12)[0], 16 + 4 * version
        else:
            return None
        code = {2: "<H", 4: "<I", 8: "<Q"}[width]
        # base address, extension / free-space address, end-of-file address; HDF5 compares the
        # last with the size of the whole file (a user block included)
        _base, _, eof = (struct.unpack_from(code, head, first + k * width)[0] for k in range(3))
    except (IndexError, KeyError, struct.error):
        return None
    if eof == (1 << 8 * width) - 1:  # undefined address
        return None
    return flags, eof


_HDF5_LIB = []


def _hdf5_library():
    """The HDF5 library h5py uses, through ctypes (for the settings h5py does not expose), or None."""
    if not _HDF5_LIB:
        lib = None
        candidates = []
        try:
            with open("/proc/self/maps") as maps:
                candidates = sorted({line.split(None, 5)[-1].strip() for line in maps if "libhdf5" in line})
        except OSError:
            folder = os.path.dirname(os.path.dirname(h5py.__file__))
            for sub in ("h5py.libs", os.path.join("h5py", ".dylibs")):
                try:
                    candidates += [os.path.join(folder, sub, n) for n in sorted(os.listdir(os.path.join(folder, sub)))]
                except OSError:
                    pass
        for candidate in candidates:
            name = os.path.basename(candidate)
            if not name.startswith("libhdf5") or name.startswith("libhdf5_hl"):
                continue
            try:
                found = ctypes.CDLL(candidate)
                setter = found.H5Pset_metadata_read_attempts
            except (OSError, AttributeError):
                continue
            setter.argtypes = [ctypes.c_int64, ctypes.c_uint]
            setter.restype = ctypes.c_int
            lib = found
            break
        _HDF5_LIB.append(lib)
    return _HDF5_LIB[0]


def _swmr_fapl():
    """File access properties for SWMR reading with a bounded metadata retry loop (None when the
    library cannot be reached)."""
    lib = _hdf5_library()
    if lib is None:
        return None
    fapl = h5py.h5p.create(h5py.h5p.FILE_ACCESS)
    cache = list(fapl.get_cache())
    cache[2] = _CHUNK_CACHE_BYTES
    fapl.set_cache(*cache)
    if lib.H5Pset_metadata_read_attempts(fapl.id, _SWMR_READ_ATTEMPTS) < 0:
        return None
    return fapl


def _open_h5(path):
    """Open for reading; returns ``(file, writer_open)``.

    A file whose SWMR writer is still running or was killed is flagged 'open for write' and opens
    only in SWMR read mode, with HDF5's metadata retry loop bounded to about a second (its default
    waits for hours on a file that was cut short). Every other file opens normally, after checking
    that it is as long as its superblock says."""
    found = _superblock(path)
    if found is not None:
        flags, eof = found
        size = os.path.getsize(path)
        if not flags & 0b101 and size < eof:
            raise RunFileError(f"{path}: the file was cut short: {size} bytes, but its HDF5 superblock records "
                               f"{eof}")
    try:
        return h5py.File(path, "r", rdcc_nbytes=_CHUNK_CACHE_BYTES), False
    except OSError as exc:
        if "already open for write" not in str(exc):
            raise RunFileError(f"{path}: cannot read as HDF5 ({_one_line(exc)})") from None
    try:
        fapl = _swmr_fapl()
        if fapl is None:
            return h5py.File(path, "r", swmr=True, rdcc_nbytes=_CHUNK_CACHE_BYTES), True
        fid = h5py.h5f.open(os.fsencode(path), h5py.h5f.ACC_RDONLY | h5py.h5f.ACC_SWMR_READ, fapl=fapl)
        return h5py.File(fid), True
    except Exception as exc:
        raise RunFileError(f"{path}: cannot read as HDF5 ({_one_line(exc)})") from None


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


def thinned_frames(revolutions, every=1, full_window=None) -> np.ndarray:
    """Indices of the frames to keep when thinning a run: every ``every``-th frame (the first
    included), and every frame whose time in revolutions lies in ``full_window`` = (r0, r1).

    Parameters
    ----------
    revolutions : array of float
        The run's frame times in drum revolutions (:attr:`Run.revolutions`); only their number
        matters without ``full_window`` (any per-frame array will do, e.g. the times of a run
        whose drum does not turn).
    every : int
        Keep one frame in ``every`` outside the window (>= 1; 1 keeps all).
    full_window : (float, float), optional
        Revolutions [r0, r1] in which every frame is kept.

    Raises
    ------
    ValidationError
        ``every`` below 1 or ``full_window`` not two increasing numbers.
    """
    if isinstance(every, bool) or not isinstance(every, (int, np.integer)) or every < 1:
        raise ValidationError("every", f"must be an integer >= 1, got {every!r}")
    revs = np.asarray(revolutions, dtype=float)
    index = np.arange(revs.size)
    keep = index % every == 0
    if full_window is not None:
        r0, r1 = full_window
        if not r0 <= r1:
            raise ValidationError("full_window", f"must be (r0, r1) with r0 <= r1, got {full_window!r}")
        keep |= (revs >= r0) & (revs <= r1)  # exact, as when the bundled datasets were thinned
    return index[keep]


@contextlib.contextmanager
def replacing_run(dst, overwrite=False):
    """Write a whole new run for ``dst`` into a temporary file beside it and rename it over
    ``dst`` only when the block inside succeeds; on any error (a bad input frame, a full disk,
    an interrupt) the temporary file is removed and an existing ``dst`` is left as it was. The
    lock of ``dst`` is held throughout. Yields the path to give :class:`RunWriter`.

    Raises
    ------
    RunFileError
        ``dst`` exists and not ``overwrite``; :class:`~granalytics.errors.RunLockedError` if
        another writer holds its lock.
    """
    dst = os.fspath(dst)
    with WriterLock(dst):
        if os.path.exists(dst) and not overwrite:
            raise RunFileError(f"{dst}: file exists (pass overwrite=True, or --overwrite, to replace it)")
        with replaced_atomically(dst, f"{dst}.partial") as tmp:
            yield tmp


def subset_run(src, dst, frames, *, float_dtype="float64", overwrite=False, progress=False) -> str:
    """Copy some frames of a run into a new run file, optionally stored as float32.

    For bundling and archiving long runs: e.g. every frame of the steady-state window and every
    fifth frame before it. The metadata is copied; ``provenance["subset_of"]`` records the source
    file name, its frame count, the frames kept and the storage type.

    Parameters
    ----------
    src, dst : path
        Source run and file to write (refused if it exists, unless ``overwrite``; written
        atomically, see :func:`replacing_run`).
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
        with replacing_run(dst, overwrite) as tmp, RunWriter(tmp, meta, overwrite=True, float_dtype=float_dtype) as writer:
            for k in tqdm(frames, disable=not progress, unit="frame", desc="subset"):
                writer.append(run[int(k)])
    return os.fspath(dst)
