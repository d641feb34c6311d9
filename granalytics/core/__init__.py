"""The core layer: the run-file contract, the part of granalytics the simulator (``sim``) writes
runs and sweeps through, and nothing that analyses granules.

Modules: :mod:`.snapshot` (:class:`Snapshot`, :class:`RunMeta`), :mod:`.format` (the HDF5 layout,
``docs/format.md``), :mod:`.writer` (:class:`RunWriter`), :mod:`.reader` (:func:`open_run`,
:class:`Run`, :class:`RunSlice`), :mod:`.native` (opening a file for reading), :mod:`.windows`
(which frames lie in a window of revolutions), :mod:`.subset` (:func:`subset_run`) and
:mod:`.manifest` (the sweep folder's ``manifest.csv``: ``sim sweep`` writes it, studies read it;
imported from its own path, ``import granalytics.core`` does not load it).

The writer works in HDF5's single-writer/multiple-reader (SWMR) mode: the library orders its
metadata flushes so that the file on disk is always a consistent HDF5 file, even when the writer
is killed. On top of that, every frame is committed by writing the frame's ``/frames/time`` entry
*last*; a reader counts only the frames that every dataset holds completely, so a frame is either
entirely in the file or absent. Every dataset carries a Fletcher-32 checksum per chunk, and
:func:`open_run` checks the frame index (lengths, contact counts, time and step order, particle
count) before any frame is read.

The core stands on :mod:`granalytics.base` (errors, argument validation, output files and the
writer lock) and imports numpy and h5py only (no pandas, NetworkX, SciPy or scikit-learn), so that
``import sim.run`` stays light; ``tests/test_architecture.py`` checks that sim imports granalytics
through these two packages alone, and what ``import sim.run`` loads.
"""

from granalytics._version import __version__
from granalytics.core.format import FORMAT_NAME, FORMAT_VERSION
from granalytics.core.reader import Run, RunSlice, open_run
from granalytics.core.snapshot import RunMeta, Snapshot
from granalytics.core.subset import replacing_run, subset_run, thinned_frames
from granalytics.core.writer import RunWriter

__all__ = ["__version__", "Snapshot", "RunMeta", "RunWriter", "open_run", "Run", "RunSlice", "subset_run",
           "replacing_run", "thinned_frames", "FORMAT_NAME", "FORMAT_VERSION"]
