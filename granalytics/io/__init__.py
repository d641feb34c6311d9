"""Deprecated: the run-file API moved to :mod:`granalytics.core` (``open_run``, ``RunWriter``,
``subset_run``, ...) and the readers of other codes to :mod:`granalytics.convert`. This package
forwards to them, with a DeprecationWarning, for one release; its old submodules
(``granalytics.io.reader``, ``granalytics.io.lammps``, ...) resolve through
:mod:`granalytics._moved`."""

import warnings

from granalytics.core import (FORMAT_NAME, FORMAT_VERSION, Run, RunSlice, RunWriter, WriterLock, open_run,
                              replacing_run, subset_run, thinned_frames)
from granalytics.convert import READERS

__all__ = ["Run", "RunSlice", "RunWriter", "WriterLock", "open_run", "replacing_run", "subset_run", "thinned_frames",
           "FORMAT_NAME", "FORMAT_VERSION", "READERS"]

warnings.warn("granalytics.io moved: the run-file API to granalytics.core, the readers of other codes to "
              "granalytics.convert; the old path goes in the next release", DeprecationWarning, stacklevel=2)
