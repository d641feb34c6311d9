"""Run files and readers of other codes' output.

The native run file (one HDF5 file per run; layout in ``docs/format.md``): :mod:`.format` (the
layout), :mod:`.writer` (:class:`RunWriter`), :mod:`.reader` (:func:`open_run`, :class:`Run`,
:class:`RunSlice`), :mod:`.native` (the HDF5 library underneath), :mod:`.subset`
(:func:`subset_run`). The writer lock is :class:`granalytics.files.WriterLock`. Readers of other
codes (LIGGGHTS/LAMMPS dumps, YADE exports) are registered in :data:`READERS`.

The writer works in HDF5's single-writer/multiple-reader (SWMR) mode: the library orders its
metadata flushes so that the file on disk is always a consistent HDF5 file, even when the writer
is killed. On top of that, every frame is committed by writing the frame's ``/frames/time`` entry
*last*; a reader counts only the frames that every dataset holds completely, so a frame is either
entirely in the file or absent. Every dataset carries a Fletcher-32 checksum per chunk, and
:func:`open_run` checks the frame index (lengths, contact counts, time and step order, particle
count) before any frame is read.
"""

from ..files import WriterLock
from .format import FORMAT_NAME, FORMAT_VERSION
from .reader import Run, RunSlice, open_run
from .subset import replacing_run, subset_run, thinned_frames
from .writer import RunWriter

__all__ = ["Run", "RunSlice", "RunWriter", "WriterLock", "open_run", "replacing_run", "subset_run", "thinned_frames",
           "FORMAT_NAME", "FORMAT_VERSION"]
