"""The core layer: the run-file contract, everything the simulator (``sim``) needs from
granalytics to write runs and nothing that analyses granules.

Modules: :mod:`.snapshot` (:class:`Snapshot`, :class:`RunMeta`), :mod:`.format` (the HDF5 layout,
``docs/format.md``), :mod:`.writer` (:class:`RunWriter`), :mod:`.reader` (:func:`open_run`,
:class:`Run`, :class:`RunSlice`), :mod:`.native` (opening a file for reading), :mod:`.subset`
(:func:`subset_run`), :mod:`.files` (atomic writes, the writer lock, one-line errors, Ctrl-C),
:mod:`.errors`, :mod:`.validation` (the argument constraints of every public function, this
layer's and those above); and the reader's helpers :mod:`.windows` (revolution windows) and
:mod:`.resources` (memory and disk checks).

The writer works in HDF5's single-writer/multiple-reader (SWMR) mode: the library orders its
metadata flushes so that the file on disk is always a consistent HDF5 file, even when the writer
is killed. On top of that, every frame is committed by writing the frame's ``/frames/time`` entry
*last*; a reader counts only the frames that every dataset holds completely, so a frame is either
entirely in the file or absent. Every dataset carries a Fletcher-32 checksum per chunk, and
:func:`open_run` checks the frame index (lengths, contact counts, time and step order, particle
count) before any frame is read.

What this package exports:

- the data model: :class:`Snapshot` (one frame: particles and contacts, SI units),
  :class:`RunMeta` (the run's metadata);
- run files: :class:`RunWriter` (atomic frames, the writer lock), :func:`open_run`, :class:`Run`,
  :class:`RunSlice`, :class:`WriterLock`, :func:`subset_run`;
- file helpers (:func:`check_output_folder`, :func:`one_line`, :func:`warnings_as_lines`,
  :func:`regular_input`) and errors.

Two more modules of this layer are shared by the simulator and the analyses, and so live here
(``sim`` imports ``granalytics.core`` only), imported from their own paths (``import
granalytics.core`` loads neither): :mod:`.manifest` (the sweep manifest's schema: ``sim sweep``
writes it, studies read it) and :mod:`.cluster` (:func:`~granalytics.core.cluster.dask_client`,
for sweeps and frame loops).

It imports numpy and h5py only (no pandas, NetworkX, SciPy or scikit-learn), so that ``import
sim.run`` stays light; ``tests/test_architecture.py`` checks that sim imports granalytics
through this package alone, and what ``import sim.run`` loads.
"""

from granalytics._version import __version__
from granalytics.core.errors import (GranalyticsError, ParameterError, RunFileError, RunLockedError, RunWriteError,
                                     ValidationError, exit_after_write_failure)
from granalytics.core.files import (WriterLock, check_not_open_elsewhere, check_output_folder, interrupted, one_line,
                                    regular_input, terminate_as_interrupt, warnings_as_lines)
from granalytics.core.format import FORMAT_NAME, FORMAT_VERSION
from granalytics.core.reader import Run, RunSlice, open_run
from granalytics.core.snapshot import RunMeta, Snapshot
from granalytics.core.subset import replacing_run, subset_run, thinned_frames
from granalytics.core.writer import RunWriter

__all__ = [
    "__version__",
    "Snapshot", "RunMeta", "RunWriter", "open_run", "Run", "RunSlice", "WriterLock",
    "subset_run", "replacing_run", "thinned_frames", "FORMAT_NAME", "FORMAT_VERSION",
    "check_output_folder", "check_not_open_elsewhere", "interrupted", "terminate_as_interrupt", "one_line",
    "regular_input", "warnings_as_lines",
    "GranalyticsError", "ParameterError", "RunFileError", "RunLockedError", "ValidationError", "RunWriteError",
    "exit_after_write_failure",
]
