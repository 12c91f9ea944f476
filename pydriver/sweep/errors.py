"""The one exception of the sweep layer (a deck that fails is a record, not an exception)."""


class SweepError(ValueError):
    """A sweep that cannot start or cannot write its files: bad ``--set`` option, first deck
    invalid, directory mismatch, a refused path, a full disk."""
