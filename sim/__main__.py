"""``python -m sim`` and the ``granalytics-sim`` console script: the simulator's command line
(:func:`sim.cli.main`).

Its modules take a fraction of a second to import (numba); a Ctrl-C meanwhile is held and then
ends the program in one line with exit status 130 (never a traceback or a death by SIGINT).
"""

import sys

from granalytics.base.interrupts import interrupts_held
from granalytics.base.progress import throttle_bars_off_terminal

throttle_bars_off_terminal()  # before anything imports tqdm


def main(argv=None) -> int:
    """Run the simulator's command line; returns the exit status."""
    with interrupts_held() as held:
        from sim.cli import main as run
    if held:
        print("sim: interrupted before any work; nothing was written", file=sys.stderr)
        return 130
    return run(argv)


if __name__ == "__main__":
    sys.exit(main())
