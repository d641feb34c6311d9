"""Writing run files: :class:`RunWriter` appends complete frames in SWMR mode under a writer lock."""

from __future__ import annotations

import contextlib
import json
import math
import os
from numbers import Integral

import h5py
import numpy as np

from granalytics._version import __version__
from granalytics.base.errors import GranalyticsError, RunFileError, RunWriteError, ValidationError, one_line
from granalytics.base.files import WriterLock, check_not_open_elsewhere, check_replaceable
from granalytics.base.interrupts import raise_dropped_interrupt
from granalytics.core.format import (CONTACT_CHUNK_ROWS, CONTACT_DATASETS, CONTACT_LAYOUT, FORMAT_NAME, FORMAT_VERSION,
                                     INDEX_DATASETS, PARTICLE_LAYOUT, PER_FRAME_DATASETS)
from granalytics.core.hdf5_file import HDF5Handle
from granalytics.core.reader import open_run
from granalytics.core.snapshot import META, PARTICLE_FIELDS, RunMeta, Snapshot, json_problem
from granalytics.base.validation import FLAG, PATH, Instance, Interval, Options, validate_params


def _write_failure(exc) -> str:
    """HDF5's reason for a failed write, in a few words (its message spans lines)."""
    import re

    found = re.search(r"error message = '([^']*)'", str(exc))
    return found.group(1) if found else one_line(exc)[:120]


class RunWriter(HDF5Handle):
    """Append snapshots to a new run file, one complete frame at a time.

    The writer holds the lock file ``PATH.lock`` (:class:`~granalytics.base.files.WriterLock`:
    the operating system's lock, the file naming the writer's pid and host) from before it creates
    the file until :meth:`close` has finished; a second writer on the same path raises
    :class:`~granalytics.base.errors.RunLockedError`. A writer that is killed releases the lock
    with its process.

    Parameters
    ----------
    path : str or path-like
        File to create. An existing file is replaced only with ``overwrite=True``.
    meta : RunMeta
        Run metadata, stored once in the file.
    compression : {"gzip", "lzf", None}, default "gzip"
        HDF5 filter for every dataset (gzip is readable by every HDF5 tool).
    compression_level : int or None, default 4
        gzip level 0–9 (None: HDF5's default; not used by lzf).
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

    @validate_params({"path": [PATH], "meta": [META], "compression": [Options(("gzip", "lzf")), None],
                      "compression_level": [Interval(Integral, 0, 9), None], "overwrite": [FLAG],
                      "float_dtype": [Options(("float64", "float32"))]})
    def __init__(self, path, meta, *, compression="gzip", compression_level=4, overwrite=False, float_dtype="float64",
                 _lock=None):
        meta.validate()  # fields may have been changed since construction
        self.path = os.fspath(path)
        self.meta = meta
        self._float = np.dtype(float_dtype)
        # every dataset gets a Fletcher-32 checksum per chunk: HDF5 refuses a damaged chunk on read
        self._filter = {"fletcher32": True}
        if compression is not None:
            self._filter.update(compression=compression, shuffle=True)
            if compression == "gzip" and compression_level is not None:
                self._filter["compression_opts"] = int(compression_level)
        check_replaceable(self.path)  # a device such as /dev/null, or a folder: no lock file beside it either
        # the lock exists before the file is created or truncated, and until close() is done
        lock = _lock if _lock is not None else WriterLock(self.path).acquire()
        replacing, created = False, self.path
        try:
            replacing = os.path.exists(self.path)
            if replacing and not overwrite:
                raise RunFileError(f"{self.path}: file exists (pass overwrite=True to replace it)")
            # an existing file is never truncated: the new one is written beside it and swapped in
            # (a process that has the old one open keeps reading it whole)
            created = f"{self.path}.new-{os.getpid()}" if replacing else self.path
            try:
                self._file = h5py.File(created, "w", libver="latest")
            except OSError as exc:
                raise RunFileError(f"{self.path}: cannot create run file ({one_line(exc)})") from None
            self._file.attrs["format"] = FORMAT_NAME
            self._file.attrs["format_version"] = FORMAT_VERSION
            self._file.attrs["created_by"] = f"granalytics {__version__}"
            _write_meta(self._file.create_group("meta"), meta)
            self._file.flush()
            if replacing:
                check_not_open_elsewhere(self.path)
                os.replace(created, self.path)
        except BaseException:
            self._discard()
            if created != self.path:
                with contextlib.suppress(OSError):
                    os.unlink(created)
            if _lock is None:
                lock.release()
            raise
        self._lock = lock
        self._n_particles = None
        self._ids = None  # frame 0's particle ids, sorted: every later frame must hold the same ones
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
        return self._lock.path

    @classmethod
    @validate_params({"path": [PATH], "n_frames": [Interval(Integral, 0, None)]})
    def continue_from(cls, path, n_frames, **kwargs) -> "RunWriter":
        """Reopen a run for appending after its first ``n_frames`` complete frames.

        Used to resume a killed writer (e.g. a simulation restarted from a checkpoint): under
        the run's lock, the first ``n_frames`` frames and the metadata are copied into a new file,
        which then atomically replaces ``path``; later frames of the old file are dropped. The
        storage (compression, float type) and the metadata attributes are kept as they were unless
        ``kwargs`` (as for :class:`RunWriter`) say otherwise. On any error ``path`` is left untouched.

        Raises
        ------
        ParameterError
            ``n_frames`` is not a whole number >= 0.
        ValidationError
            ``overwrite`` other than True.
        RunFileError
            ``path`` does not exist, cannot be read, or holds fewer than ``n_frames`` complete
            frames; :class:`~granalytics.base.errors.RunLockedError` if another writer holds its lock.
        """
        path, n_frames = os.fspath(path), int(n_frames)
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
                    raise RunFileError(f"{path}: holds {len(run)} complete frames, cannot continue after frame "
                                       f"{n_frames}")
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
            raise_dropped_interrupt()  # a Ctrl-C that Python dropped meanwhile replaces nothing
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

    @validate_params({"snapshot": [Instance(Snapshot)]})
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
        frame = self._n_frames
        try:
            snapshot.validate()
        except ValidationError as exc:
            raise exc.located(self.path, frame) from None
        n = snapshot.n_particles
        if n != self.meta.n_particles:  # frame 0 holds meta.n_particles, and so does every later one
            raise ValidationError("radius", f"particle count changed from meta.n_particles = {self.meta.n_particles} "
                                  f"to {n}; a run holds a fixed particle set", frame=frame, path=self.path)
        ids = np.sort(snapshot.ids)
        if self._ids is not None and not np.array_equal(ids, self._ids):
            new = np.setdiff1d(ids, self._ids)
            raise ValidationError("ids", f"the particle set changed: id {int(new[0])} is not in frame 0 ({new.size} "
                                  "new ids); a run holds a fixed particle set (the same ids in every frame)",
                                  frame=frame, path=self.path)
        if not snapshot.time > self._last_time:
            raise ValidationError("time", f"must increase from frame to frame: {snapshot.time!r} after "
                                  f"{self._last_time!r}", frame=frame, path=self.path)
        if self._last_step is not None and not (
            snapshot.step > self._last_step and not self._constant_steps
            or snapshot.step == self._last_step and (self._constant_steps or frame == 1)
        ):
            raise ValidationError("step", f"must increase from frame to frame: {snapshot.step} after {self._last_step}"
                                  + (" (or stay the same in every frame when steps are not recorded)"
                                     if frame == 1 or self._constant_steps else ""), frame=frame, path=self.path)
        if self._n_particles is None:
            self._create_datasets(n)
            self._ids = ids
        f = self._file
        m = snapshot.n_contacts
        start, stop = self._n_contact_rows, self._n_contact_rows + m
        try:
            for name in PARTICLE_FIELDS:
                ds = f["particles"][name]
                ds.resize(frame + 1, axis=0)
                ds[frame] = getattr(snapshot, name)
                ds.flush()
            for field, (name, _unit) in CONTACT_LAYOUT.items():
                ds = f["contacts"][name]
                ds.resize(stop, axis=0)
                if m:
                    ds[start:stop] = getattr(snapshot, field)
                ds.flush()
            self._append_scalar(f["contacts/count"], frame, m)
            self._append_scalar(f["frames/step"], frame, snapshot.step)
            self._append_scalar(f["frames/time"], frame, snapshot.time)  # commit point: written last
        except RuntimeError as exc:  # HDF5 could not write: a full disk or a file-size limit
            if "write failed" not in str(exc) and "errno" not in str(exc):
                self._trim()
                raise
            self._abandon()
            raise RunWriteError(f"{self.path}: cannot write frame {frame} ({_write_failure(exc)}): the disk is full or "
                                "a file-size limit was reached; the file is incomplete") from None
        except BaseException:  # e.g. Ctrl-C: drop the partial frame
            self._trim()
            raise
        self._n_contact_rows = stop
        self._n_frames += 1
        self._last_time = snapshot.time
        self._constant_steps = frame >= 1 and snapshot.step == self._last_step
        self._last_step = snapshot.step

    def sync(self) -> None:
        """Make the committed frames durable: flush HDF5's buffers and ask the OS to write the file
        to disk (``fsync``), e.g. before a checkpoint that names them, so that after a power loss
        the file still holds every frame the checkpoint counts."""
        if self._file is None:
            raise RunFileError(f"{self.path}: writer is closed")
        self._file.flush()
        fd = os.open(self.path, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)

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
            for name in INDEX_DATASETS[::-1] + PER_FRAME_DATASETS[3:]:  # time first: un-commit
                if f[name].shape[0] != self._n_frames:
                    f[name].resize(self._n_frames, axis=0)
                    f[name].flush()
            for name in CONTACT_DATASETS:
                if f[name].shape[0] != self._n_contact_rows:
                    f[name].resize(self._n_contact_rows, axis=0)
                    f[name].flush()
        except Exception:  # the file stays readable: a reader ignores a partial frame
            pass

    def _abandon(self) -> None:
        """After a failed write: close the HDF5 file whatever it says (an HDF5 file left open in
        that state crashes the interpreter when it exits), release the lock; the file is not
        compacted or trimmed (writing is what failed)."""
        if self._file is not None:
            fid = self._file.id
            with contextlib.suppress(Exception):
                objects = fid.get_obj_ids()
            for oid in locals().get("objects", ()):  # every dataset and group, then the file itself
                with contextlib.suppress(Exception):
                    while oid.valid:
                        oid._close()
        self._file = None
        with contextlib.suppress(Exception):
            self._lock.release()

    def _discard(self) -> None:
        """Close the HDF5 file without compacting it; the lock is not touched."""
        if self._file is not None:
            try:
                self._file.close()
            except Exception:
                pass
            self._file = None

    def close(self) -> None:
        """Close the file (idempotent) and release the lock file.

        The datasets are then copied into a fresh file that replaces the original: appending in
        SWMR mode leaves the space of every rewritten partial chunk unused, and the copy drops it
        (and HDF5's "open for write" flag). A killed writer skips this step; its file stays valid,
        only larger. The lock is held until the copy is done.
        """
        if self._file is None:
            return
        try:
            self._trim()
            super().close()
            self._compact()
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
                                   f"({one_line(exc)})") from None
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
        for name, (trailing, dtype, unit) in PARTICLE_LAYOUT.items():
            ds = particles.create_dataset(
                name, shape=(0, n) + trailing, maxshape=(None, n) + trailing,
                dtype=self._float if dtype is np.float64 else dtype,
                chunks=(1, n) + trailing, **self._filter,
            )
            ds.attrs["unit"] = unit
        contacts = f.create_group("contacts")
        index_dtype = np.int32 if n < 2**31 else np.int64
        for field, (name, unit) in CONTACT_LAYOUT.items():
            dtype = index_dtype if field in ("contact_i", "contact_j") else self._float
            ds = contacts.create_dataset(
                name, shape=(0,), maxshape=(None,), dtype=dtype, chunks=(CONTACT_CHUNK_ROWS,),
                **self._filter,
            )
            ds.attrs["unit"] = unit
        count = contacts.create_dataset("count", shape=(0,), maxshape=(None,), dtype=np.int64, chunks=(4096,), **checksum)
        count.attrs["unit"] = "1"
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


def _write_meta(group, meta: RunMeta):
    for key, value in meta.to_dict().items():
        if key in ("sim_config", "provenance"):
            group.attrs[key] = json.dumps(value, sort_keys=True)
        else:
            group.attrs[key] = np.asarray(value)
