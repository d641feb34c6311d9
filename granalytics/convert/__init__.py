"""Readers of other codes' output (LIGGGHTS/LAMMPS dumps: :mod:`.lammps`; YADE exports:
:mod:`.yade`), behind one registry, :data:`READERS` (:mod:`.registry`); shared text helpers in
:mod:`._text`. ``granalytics convert --from NAME`` turns their files into a native run file
(:mod:`granalytics.core`). Above the core layer, below the analysis."""

from granalytics.convert.registry import READERS, Reader, read_run_files

__all__ = ["READERS", "Reader", "read_run_files"]
