"""``python -m granalytics`` and the ``granalytics`` console script (``pyproject.toml``).

The commands' modules take a second or two to import (pandas, numba, h5py); Ctrl-C is handled
from the first instant, also while they load: one line and exit status 130, never a traceback.
"""

import sys


def main(argv=None) -> int:
    """Run the command line (:func:`granalytics.cli.main`); returns the exit status."""
    try:
        from granalytics.cli import main as run

        return run(argv)
    except KeyboardInterrupt:  # before a command started (it handles its own): nothing was written
        print("granalytics: interrupted before any work; nothing was written", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
