"""``python -m flows``: the ``fleet-health`` command line."""
import sys

from flows.cli import main

sys.exit(main())
