"""Opening a run file for reading, and the file handle base class.

Hand-written because h5py does not expose ``H5Pset_metadata_read_attempts``: the file of a writer
that was killed is flagged 'open for write' and opens only in SWMR mode, where HDF5's default
metadata retry loop waits for hours on a file that was cut short; the setting is reached through
ctypes in the HDF5 library h5py loaded."""

from __future__ import annotations

import ctypes
import os
import re

import h5py

from granalytics.base.errors import RunFileError, one_line
from granalytics.core.format import CHUNK_CACHE_BYTES, SWMR_READ_ATTEMPTS

#: how a message tells the user what to do with another code's output
CONVERT_HINT = ("; output of LIGGGHTS/LAMMPS or YADE is read by `granalytics convert` into a run file "
                "(docs/readers.md)")


class HDF5Handle:
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
    cache[2] = CHUNK_CACHE_BYTES
    fapl.set_cache(*cache)
    if lib.H5Pset_metadata_read_attempts(fapl.id, SWMR_READ_ATTEMPTS) < 0:
        return None
    return fapl


def open_h5(path):
    """Open for reading; returns ``(file, writer_open)``.

    A file whose SWMR writer is still running or was killed is flagged 'open for write' and opens
    only in SWMR read mode, with HDF5's metadata retry loop bounded to about a second. Every other
    file opens normally (HDF5 checks that it is as long as its superblock says)."""
    try:
        return h5py.File(path, "r", rdcc_nbytes=CHUNK_CACHE_BYTES), False
    except OSError as exc:
        sizes = re.search(r"truncated file: eof = (\d+).*stored_eof = (\d+)", str(exc))
        if sizes:
            raise RunFileError(f"{path}: the file was cut short: {sizes[1]} bytes, but its HDF5 superblock "
                               f"records {sizes[2]}") from None
        if "already open for write" not in str(exc):
            raise RunFileError(f"{path}: cannot read as HDF5 ({one_line(exc)}){CONVERT_HINT}") from None
    try:
        fapl = _swmr_fapl()
        if fapl is None:
            return h5py.File(path, "r", swmr=True, rdcc_nbytes=CHUNK_CACHE_BYTES), True
        fid = h5py.h5f.open(os.fsencode(path), h5py.h5f.ACC_RDONLY | h5py.h5f.ACC_SWMR_READ, fapl=fapl)
        return h5py.File(fid), True
    except Exception as exc:
        raise RunFileError(f"{path}: cannot read as HDF5 ({one_line(exc)}){CONVERT_HINT}") from None
