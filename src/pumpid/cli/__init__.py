"""The command line: a thin shell over the public Python API (``pumpid --help``)."""

from .main import build_parser, main

__all__ = ["build_parser", "main"]
