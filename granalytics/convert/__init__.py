"""Readers of other codes' output (LIGGGHTS/LAMMPS dumps, text: :mod:`.lammps`, VTK:
:mod:`.liggghts_vtk`; YADE's CSV export: :mod:`.yade`; YADE's VTKRecorder: :mod:`.yade_vtk`),
read frame by frame (:func:`open_run_files`; :mod:`.prefetch` reads ahead), behind one registry, :data:`READERS` (:mod:`.registry`); shared text helpers in
:mod:`._text`. ``granalytics convert --from NAME`` turns their files into a native run file
(:mod:`granalytics.core`). Above the core layer, below the analysis."""

from granalytics.convert.registry import READERS, FrameSource, Reader, open_run_files, read_run_files

__all__ = ["READERS", "Reader", "FrameSource", "open_run_files", "read_run_files"]
