"""Defaults of the fleet batch that the command line shows without loading the fleet."""

#: Cards per partition unless asked otherwise.
PARTITION_SIZE = 256
