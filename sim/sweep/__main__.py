"""``python -m sim.sweep …``: the same as ``python -m sim sweep …``."""

import sys

from ..cli import sweep_main

sys.exit(sweep_main())
