"""``python -m sim``: the simulator's command line (:func:`sim.cli.main`).

Its modules take a fraction of a second to import (numba); a Ctrl-C meanwhile is held and then
ends the program in one line with exit status 130 (never a traceback or a death by SIGINT).
"""

import sys

from granalytics.base.interrupts import interrupts_held

with interrupts_held() as held:
    from sim.cli import main
if held:
    print("sim: interrupted before any work; nothing was written", file=sys.stderr)
    sys.exit(130)
sys.exit(main())
