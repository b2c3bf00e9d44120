"""``python -m pumpid.cli``: the ``pumpid`` command without an installed entry point."""

import sys

from .main import main

sys.exit(main())
