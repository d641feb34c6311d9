"""``python -m granalytics.datasets …``: the same as ``granalytics datasets …``."""

import sys

from granalytics.cli.datasets import main

sys.exit(main())
