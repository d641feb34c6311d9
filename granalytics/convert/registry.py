"""Readers of other codes' output behind one interface: ``READERS[name].read(...)``.

Each :class:`Reader` turns particle files, contact files and a mapping file (TOML: what the files
cannot say, such as units, columns and material data) into snapshots and run metadata;
``granalytics convert --from NAME`` and the shared reader tests (``tests/test_readers.py``) go
through this registry. Adding a reader: write ``read_<code>`` in a module of its own under
``granalytics/convert/`` (the shared text helpers are in ``convert/_text.py``), register it here, and add
its example files to the shared tests.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

__all__ = ["Reader", "READERS", "read_run_files"]


@dataclass(frozen=True)
class Reader:
    """One code's reader.

    Attributes
    ----------
    name : str
        The name of ``convert --from``.
    description : str
        What it reads (one line, for ``--help``).
    read : callable
        ``read(particle_files, contact_files, mapping_path, dt_s)`` → ``(snapshots, meta)``.
    needs_dt : bool
        Whether its files lack the time (``dt_s`` [s] then converts timesteps to seconds).
    """

    name: str
    description: str
    read: Callable
    needs_dt: bool = False


def _liggghts(particle_files, contact_files, mapping_path, dt_s):
    from granalytics.convert.lammps import DumpMapping, read_liggghts

    return read_liggghts(particle_files, contact_files, DumpMapping.from_toml(mapping_path), dt=dt_s)


def _yade(particle_files, contact_files, mapping_path, dt_s):
    from granalytics.convert.yade import read_yade_csv

    return read_yade_csv(particle_files, contact_files, mapping_path)


#: reader name -> :class:`Reader`
READERS = {r.name: r for r in (
    Reader("liggghts", "LIGGGHTS/LAMMPS dumps (dump custom + compute pair/gran/local)", _liggghts, needs_dt=True),
    Reader("yade", "CSVs of scripts/yade_export.py", _yade),
)}


def read_run_files(source, particle_files, contact_files, mapping_path, dt_s=None):
    """``(snapshots, meta)`` of the files of code ``source`` (a :data:`READERS` key)."""
    from granalytics.base.errors import ParameterError

    try:
        reader = READERS[source]
    except KeyError:
        raise ParameterError(f"unknown reader {source!r}; available: {', '.join(READERS)}") from None
    return reader.read(list(particle_files), list(contact_files), mapping_path, dt_s)
