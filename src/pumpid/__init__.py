"""pumpid: identify small physical models from measured input/output data."""
