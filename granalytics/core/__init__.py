"""The run-file contract: everything the simulator (``sim``) needs from granalytics, and nothing
that analyses granules.

- the data model: :class:`Snapshot` (one frame: particles and contacts, SI units),
  :class:`RunMeta` (the run's metadata);
- run files: :class:`RunWriter` (atomic frames, the writer lock), :func:`open_run`,
  :class:`WriterLock`;
- the bed's geometry: :func:`bed_structure` (is a bed three-dimensional), :func:`drum_confinement`
  (D/d, L/d, bed depth), :data:`PLANAR_FRACTION`, :data:`FILL_PACKING`;
- file helpers (:func:`check_output_folder`, :func:`one_line`, :func:`warnings_as_lines`,
  :func:`regular_input`) and the sweep manifest's schema (:data:`MANIFEST_COLUMNS`, ...);
- errors and :func:`configure_threading`.

It imports numpy and h5py only (no pandas, NetworkX, SciPy or scikit-learn), so that ``import
sim.run`` stays light; ``tests/test_architecture.py`` checks both that sim imports granalytics
through this module alone and what ``import sim.run`` loads.
"""

from .._version import __version__
from .._threading import configure_threading
from ..bed import FILL_PACKING, PLANAR_FRACTION, bed_structure, drum_confinement
from ..errors import GranalyticsError, ParameterError, RunFileError, RunLockedError, ValidationError
from ..files import WriterLock, check_output_folder, one_line, regular_input, warnings_as_lines
from ..io import RunWriter, open_run
from ..manifest import (MANIFEST_COLUMNS, NAMED_PARAMETERS, manifest_path, manifest_rows, read_manifest,
                        write_manifest)
from ..snapshot import RunMeta, Snapshot

__all__ = [
    "__version__", "configure_threading",
    "Snapshot", "RunMeta", "RunWriter", "open_run", "WriterLock",
    "bed_structure", "drum_confinement", "PLANAR_FRACTION", "FILL_PACKING",
    "check_output_folder", "one_line", "regular_input", "warnings_as_lines",
    "MANIFEST_COLUMNS", "NAMED_PARAMETERS", "manifest_path", "manifest_rows", "read_manifest", "write_manifest",
    "GranalyticsError", "ParameterError", "RunFileError", "RunLockedError", "ValidationError",
]
