"""The HDF5 library underneath h5py: the file handle base class, the superblock probe, the
library's own version and the SWMR file-access settings, opening a run file for reading."""

from __future__ import annotations

import ctypes
import os
import struct

import h5py

from granalytics.core.files import one_line
from granalytics.core.format import _CHUNK_CACHE_BYTES, _SWMR_READ_ATTEMPTS
from granalytics.core.errors import RunFileError

#: how a message tells the user what to do with another code's output
CONVERT_HINT = ("; output of LIGGGHTS/LAMMPS or YADE is read by `granalytics convert` into a run file "
                "(docs/readers.md)")


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
            raise RunFileError(f"{path}: cannot read as HDF5 ({one_line(exc)}){CONVERT_HINT}") from None
    try:
        fapl = _swmr_fapl()
        if fapl is None:
            return h5py.File(path, "r", swmr=True, rdcc_nbytes=_CHUNK_CACHE_BYTES), True
        fid = h5py.h5f.open(os.fsencode(path), h5py.h5f.ACC_RDONLY | h5py.h5f.ACC_SWMR_READ, fapl=fapl)
        return h5py.File(fid), True
    except Exception as exc:
        raise RunFileError(f"{path}: cannot read as HDF5 ({one_line(exc)}){CONVERT_HINT}") from None


