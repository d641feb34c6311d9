"""Reading and writing runs."""

from .hdf5 import Run, RunSlice, RunWriter, WriterLock, open_run, replacing_run, subset_run, thinned_frames

__all__ = ["Run", "RunSlice", "RunWriter", "WriterLock", "open_run", "replacing_run", "subset_run", "thinned_frames"]
