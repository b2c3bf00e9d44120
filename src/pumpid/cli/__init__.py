"""The command line: a thin shell over the public Python API (``pumpid --help``).

One module per command (``fit``, ``demo``, ``reproduce``, ``simulate``, ``flow``), each with
a ``register(subparsers)`` function; shared exit codes and option parsing in
:mod:`~pumpid.cli.common`, what ``fit`` prints in :mod:`~pumpid.cli.render`, and every write
through :mod:`pumpid.report.output`.
"""

from .main import build_parser, main

__all__ = ["build_parser", "main"]
