import sys

from granalytics.cli import main

sys.exit(main())
