"""Readers of other codes' output behind one interface: ``READERS[name].open(...)``.

Each :class:`Reader` turns particle files, contact files and a mapping file (TOML: what the files
cannot say, such as units, columns and material data) into a :class:`FrameSource`: the snapshots,
read one at a time where the format allows, and the run metadata;
``granalytics convert --from NAME`` and the shared reader tests (``tests/test_readers.py``) go
through this registry. Adding a reader: write ``read_<code>`` in a module of its own under
``granalytics/convert/`` (the shared text helpers are in ``convert/_text.py``), register it here, and add
its example files to the shared tests.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Iterator, Protocol

__all__ = ["Reader", "READERS", "FrameSource", "StreamedSource", "open_run_files", "read_run_files"]


class FrameSource(Protocol):
    """What a reader's ``open`` returns: the frames of a run from other codes' files.

    Iterating yields the snapshots in time order (one at a time for a streaming reader);
    ``first()`` is the first snapshot (read once, iteration starts with it), after which ``meta``
    is the run's metadata; ``start_after(step)``, called before reading, leaves out the frames
    up to timestep ``step``; ``bytes_read`` and ``total_bytes`` measure the reading over all its
    files (as stored); ``frame_bytes()`` estimates the memory one frame needs while it is read.
    """

    meta: object
    total_bytes: int

    @property
    def bytes_read(self) -> int: ...

    def first(self): ...

    def start_after(self, step) -> None: ...

    def frame_bytes(self) -> int: ...

    def __iter__(self) -> Iterator: ...

    def close(self) -> None: ...


class StreamedSource:
    """What the streaming readers share: ``first()`` reads the first frame of the generator
    ``_read()`` (a subclass's, which honours ``self._after``), iteration goes on from it, and
    ``close()`` stops the reading. A subclass gives ``_read()`` and ``_nothing_read()`` (the error
    when there is no frame to read)."""

    _after = None
    _first = None
    _frames = None

    def start_after(self, step) -> None:
        """Leave out the timesteps up to ``step`` (read past, not parsed where the format allows).
        Call before reading."""
        if self._first is not None:
            raise RuntimeError("start_after: frames were read already")
        self._after = int(step)

    def first(self):
        """The first frame (read once; iteration starts with it)."""
        if self._first is None:
            self._frames = self._read()
            self._first = next(self._frames, None)
            if self._first is None:
                raise self._nothing_read()
        return self._first

    def __iter__(self):
        yield self.first()
        yield from self._frames

    def close(self) -> None:
        """Stop reading (the file being read is closed)."""
        if self._frames is not None:
            self._frames.close()


@dataclass(frozen=True)
class Reader:
    """One code's reader.

    Attributes
    ----------
    name : str
        The name of ``convert --from``.
    description : str
        What it reads (one line, for ``--help``).
    open : callable
        ``open(particle_files, contact_files, mapping_path, dt_s)`` → :class:`FrameSource`.
    needs_dt : bool
        Whether its files lack the time (``dt_s`` [s] then converts timesteps to seconds).
    needs_contacts : bool
        Whether contact files are given apart from the particle files (a VTKRecorder folder
        holds both).
    """

    name: str
    description: str
    open: Callable
    needs_dt: bool = False
    needs_contacts: bool = True


def _liggghts(particle_files, contact_files, mapping_path, dt_s):
    from granalytics.convert.lammps import DumpMapping, open_liggghts

    return open_liggghts(particle_files, contact_files, DumpMapping.from_toml(mapping_path), dt=dt_s)


def _yade(particle_files, contact_files, mapping_path, dt_s):
    from granalytics.convert.yade import open_yade_csv

    return open_yade_csv(particle_files, contact_files, mapping_path)


def _yade_vtk(particle_files, contact_files, mapping_path, dt_s):
    from granalytics.convert.yade_vtk import open_yade_vtk

    return open_yade_vtk([*particle_files, *contact_files], mapping_path, dt_s)


#: reader name -> :class:`Reader`
READERS = {r.name: r for r in (
    Reader("liggghts", "LIGGGHTS/LAMMPS dumps (dump custom + compute pair/gran/local; text, or the VTK files of "
                       "dump custom/vtk and dump local/gran/vtk)", _liggghts, needs_dt=True),
    Reader("yade", "CSVs of scripts/yade_export.py", _yade),
    Reader("yade-vtk", "a YADE VTKRecorder folder (recorders spheres, velocity, id, intr)", _yade_vtk, needs_dt=True,
           needs_contacts=False),
)}


def open_run_files(source, particle_files, contact_files, mapping_path, dt_s=None) -> FrameSource:
    """The frames of the files of code ``source`` (a :data:`READERS` key), as a :class:`FrameSource`."""
    from granalytics.base.errors import ParameterError

    try:
        reader = READERS[source]
    except KeyError:
        raise ParameterError(f"unknown reader {source!r}; available: {', '.join(READERS)}") from None
    return reader.open(list(particle_files), list(contact_files), mapping_path, dt_s)


def read_run_files(source, particle_files, contact_files, mapping_path, dt_s=None):
    """``(snapshots, meta)`` of the files of code ``source``, every frame in memory
    (:func:`open_run_files` reads them one at a time)."""
    frames = open_run_files(source, particle_files, contact_files, mapping_path, dt_s)
    snapshots = list(frames)
    return snapshots, frames.meta
