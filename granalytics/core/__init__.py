"""The core layer and the run-file contract: the data model, run files, file helpers and errors;
everything the simulator (``sim``) needs from granalytics, and nothing that analyses granules.

Modules: :mod:`.snapshot` (:class:`Snapshot`, :class:`RunMeta`), :mod:`.format` (the HDF5 layout,
``docs/format.md``), :mod:`.writer` (:class:`RunWriter`), :mod:`.reader` (:func:`open_run`,
:class:`Run`, :class:`RunSlice`), :mod:`.native` (the HDF5 library underneath), :mod:`.subset`
(:func:`subset_run`), :mod:`.files` (atomic writes, the writer lock, one-line errors),
:mod:`.manifest` (the sweep manifest's schema), :mod:`.bed` (the bed's geometry), :mod:`.errors`.

The writer works in HDF5's single-writer/multiple-reader (SWMR) mode: the library orders its
metadata flushes so that the file on disk is always a consistent HDF5 file, even when the writer
is killed. On top of that, every frame is committed by writing the frame's ``/frames/time`` entry
*last*; a reader counts only the frames that every dataset holds completely, so a frame is either
entirely in the file or absent. Every dataset carries a Fletcher-32 checksum per chunk, and
:func:`open_run` checks the frame index (lengths, contact counts, time and step order, particle
count) before any frame is read.

What it exports:

- the data model: :class:`Snapshot` (one frame: particles and contacts, SI units),
  :class:`RunMeta` (the run's metadata);
- run files: :class:`RunWriter` (atomic frames, the writer lock), :func:`open_run`, :class:`Run`,
  :class:`RunSlice`, :class:`WriterLock`, :func:`subset_run`;
- the bed's geometry: :func:`bed_structure` (is a bed three-dimensional), :func:`drum_confinement`
  (D/d, L/d, bed depth), :data:`PLANAR_FRACTION`, :data:`FILL_PACKING`;
- file helpers (:func:`check_output_folder`, :func:`one_line`, :func:`warnings_as_lines`,
  :func:`regular_input`) and the sweep manifest's schema (:data:`MANIFEST_COLUMNS`, ...);
- errors, :func:`configure_threading` and :func:`dask_client` (a dask cluster for sweeps and frame
  loops; dask imported only when asked for).

It imports numpy and h5py only (no pandas, NetworkX, SciPy or scikit-learn), so that ``import
sim.run`` stays light; ``tests/test_architecture.py`` checks both that sim imports granalytics
through this module alone and what ``import sim.run`` loads.
"""

from granalytics._version import __version__
from granalytics.core._threading import configure_threading
from granalytics.core._resources import check_disk, check_memory
from granalytics.core.cluster import dask_client
from granalytics.core.bed import FILL_PACKING, PLANAR_FRACTION, bed_structure, drum_confinement
from granalytics.core.errors import (GranalyticsError, ParameterError, RunFileError, RunLockedError, RunWriteError,
                                     ValidationError, exit_after_write_failure)
from granalytics.core.files import WriterLock, check_not_open_elsewhere, check_output_folder, interrupted, terminate_as_interrupt, one_line, regular_input, warnings_as_lines
from granalytics.core.format import FORMAT_NAME, FORMAT_VERSION
from granalytics.core.manifest import (MANIFEST_COLUMNS, NAMED_PARAMETERS, file_sha256, manifest_path, manifest_rows, read_manifest,
                                       write_manifest)
from granalytics.core.reader import Run, RunSlice, open_run
from granalytics.core.snapshot import RunMeta, Snapshot
from granalytics.core.subset import replacing_run, subset_run, thinned_frames
from granalytics.core.writer import RunWriter

__all__ = [
    "RunWriteError", "exit_after_write_failure",
    "__version__", "configure_threading", "dask_client", "check_disk", "check_memory",
    "Snapshot", "RunMeta", "RunWriter", "open_run", "Run", "RunSlice", "WriterLock",
    "subset_run", "replacing_run", "thinned_frames", "FORMAT_NAME", "FORMAT_VERSION",
    "bed_structure", "drum_confinement", "PLANAR_FRACTION", "FILL_PACKING",
    "check_output_folder", "check_not_open_elsewhere", "interrupted", "terminate_as_interrupt", "one_line", "regular_input", "warnings_as_lines",
    "MANIFEST_COLUMNS", "NAMED_PARAMETERS", "file_sha256", "manifest_path", "manifest_rows", "read_manifest", "write_manifest",
    "GranalyticsError", "ParameterError", "RunFileError", "RunLockedError", "ValidationError",
]
