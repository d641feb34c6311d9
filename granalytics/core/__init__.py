"""The core layer: the run-file contract, the part of granalytics the simulator (``sim``) writes
runs and sweeps through, and nothing that analyses granules.

Modules: :mod:`.snapshot` (:class:`Snapshot`, :class:`RunMeta`), :mod:`.format` (the HDF5 layout),
:mod:`.writer` (:class:`RunWriter`: single-writer/multiple-reader mode, a frame committed by writing
its time last), :mod:`.reader` (:func:`open_run`, :class:`Run`, :class:`RunSlice`: the frame index
checked before any frame is read), :mod:`.hdf5_file` (opening a file for reading), :mod:`.windows`
(which frames lie in a window of revolutions), :mod:`.subset` (:func:`subset_run`) and
:mod:`.manifest` (the sweep folder's ``manifest.csv``; imported from its own path).
``docs/format.md`` describes the file and what a reader may rely on.

The core stands on :mod:`granalytics.base` and imports numpy and h5py only, so that ``import
sim.run`` stays light (``tests/test_architecture.py``).
"""

from granalytics._version import __version__
from granalytics.core.format import FORMAT_NAME, FORMAT_VERSION
from granalytics.core.reader import Run, RunSlice, open_run
from granalytics.core.snapshot import RunMeta, Snapshot
from granalytics.core.subset import replacing_run, subset_run, thinned_frames
from granalytics.core.writer import RunWriter

__all__ = ["__version__", "Snapshot", "RunMeta", "RunWriter", "open_run", "Run", "RunSlice", "subset_run",
           "replacing_run", "thinned_frames", "FORMAT_NAME", "FORMAT_VERSION"]
