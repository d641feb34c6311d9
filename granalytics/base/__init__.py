"""The base layer: what every layer of granalytics and the simulator share that is not the run-file
contract, each imported from its own module (this package imports none of them).

- :mod:`.errors`: the exceptions, one-line errors and warnings as a command line prints them;
- :mod:`.validation`: one way to check a public function's arguments (``validate_params``);
- :mod:`.files`: outputs written whole or not at all, the writer lock, output and input checks;
- :mod:`.interrupts`: Ctrl-C and SIGTERM, never dropped;
- :mod:`.resources`: memory and disk needs refused up front;
- :mod:`.cluster`: a dask cluster for sweeps and frame loops;
- :mod:`.threads`: numba's kernels on OpenMP threads, for the programs (never the library);
- :mod:`.sorting`: the stable counting sort (numba) of the simulator's cell lists and of the
  granules' ranking by size.

It imports nothing of granalytics above it, and its modules load NumPy at most (:mod:`.sorting`
also numba; h5py, filelock and dask inside the functions that need them); :mod:`.interrupts` loads the standard library
only, so that a program can hold a Ctrl-C from its first line
(:func:`~granalytics.base.interrupts.interrupts_held`).
"""
