"""The base layer: what every layer of granalytics and the simulator share that is not the run-file
contract.

- :mod:`.errors`: the exceptions, one-line errors and warnings as a command line prints them;
- :mod:`.validation`: one way to check a public function's arguments (``validate_params``);
- :mod:`.files`: outputs written whole or not at all, the writer lock, output and input checks;
- :mod:`.interrupts`: Ctrl-C and SIGTERM, never dropped;
- :mod:`.resources`: memory and disk needs refused up front;
- :mod:`.cluster`: a dask cluster for sweeps and frame loops (imported from its own path,
  ``import granalytics.base`` does not load it).

It imports nothing of granalytics above it and nothing heavier than numpy (h5py, filelock, dask
inside the functions that need them).
"""

from granalytics.base.errors import (FrameKeyError, GranalyticsError, ParameterError, RunFileError, RunLockedError,
                                     RunWriteError, ValidationError, exit_after_write_failure, one_line,
                                     user_stacklevel, warnings_as_lines)
from granalytics.base.files import (WriterLock, check_apart, check_not_open_elsewhere, check_output_folder,
                                    check_replaceable, regular_input, replaced_atomically, write_atomically)
from granalytics.base.interrupts import (interrupted, interrupts_not_lost, raise_dropped_interrupt,
                                         terminate_as_interrupt)
from granalytics.base.resources import check_disk, check_memory
from granalytics.base.validation import validate, validate_params

__all__ = [
    "GranalyticsError", "ParameterError", "ValidationError", "RunFileError", "RunWriteError", "RunLockedError",
    "FrameKeyError", "exit_after_write_failure", "one_line", "warnings_as_lines", "user_stacklevel",
    "WriterLock", "replaced_atomically", "write_atomically", "check_output_folder", "check_replaceable", "check_apart",
    "check_not_open_elsewhere", "regular_input",
    "interrupted", "terminate_as_interrupt", "interrupts_not_lost", "raise_dropped_interrupt",
    "check_memory", "check_disk", "validate", "validate_params",
]
