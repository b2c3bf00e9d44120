"""``python -m pumpid``: the ``pumpid`` command without an installed entry point."""

import sys

from .cli.main import main

sys.exit(main())
