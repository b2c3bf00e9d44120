"""Defaults of the fleet batch that the command line shows without loading the fleet."""

#: Cards per partition unless asked otherwise.
PARTITION_SIZE = 256
#: Cards per partition when each card's pump is identified (about 0.1-0.3 s a card): a
#: partition is also the unit of progress and of what a Ctrl-C keeps, and 256 such cards
#: showed no progress for minutes.
IDENTIFY_PARTITION_SIZE = 32
