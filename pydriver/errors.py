"""The two exceptions a run can raise: bad input, or a valid deck whose run failed."""

from __future__ import annotations


class DeckError(ValueError):
    """A deck that cannot be run: names the deck, the namelist group, the key and the reason."""

    def __init__(self, deck: str, group: str, key: str, reason: str):
        self.deck, self.group, self.key, self.reason = deck, group, key, reason
        where = f"&{group}" if group else ""
        if key:
            where += f" key '{key}'"
        super().__init__(f"deck '{deck}': {where.strip() or 'file'}: {reason}")

    def __reduce__(self):
        # Picklable across process pools (the default would call __init__ with one argument).
        return (DeckError, (self.deck, self.group, self.key, self.reason))


class RunError(RuntimeError):
    """A valid deck whose run failed (solver did not converge, singular system, ...)."""


class OutputError(OSError):
    """An output path a run refuses to write to (a foreign directory, a file, a link, the
    working directory): raised before anything is computed (:mod:`pydriver.run_directory`)."""

    def __str__(self):
        return self.strerror or super().__str__()
