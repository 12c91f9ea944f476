"""Failures of the machine, not of a deck: a full disk, a file system gone read-only, no memory.

A deck that fails gets a record, ``runs/<id>/error.json``, and a rerun skips it: the same deck
would fail the same way.  A full disk says nothing about the deck, and freeing space fixes it;
recorded, it would become a permanent failure that no resume runs again.  So an environmental
error leaves its grid point without a record (the next run of the sweep runs it) and the
sweep reports the point as not run, with the reason.

Writing the sweep's own files (manifest, decks, ``sweep.csv``, plots, report) fails with a
:class:`~pydriver.sweep.errors.SweepError` naming the file and the reason, not a traceback.
"""

from __future__ import annotations

import contextlib
import errno
import os

from pydriver.sweep.errors import SweepError


def _errnos(*names: str) -> frozenset:
    return frozenset(getattr(errno, n) for n in names if hasattr(errno, n))   # EDQUOT: not on Windows


#: OSError numbers that describe the machine, not the deck: the same deck runs once they are
#: fixed.  Full disk or quota; a file system remounted read-only after errors; permissions
#: changed under the sweep (its directories are its own, so a refusal is not the deck's
#: doing); a failing disk or a stale NFS handle; descriptor and memory exhaustion, which depend
#: on what else runs (other pool workers among them).
ENVIRONMENTAL_ERRNOS = _errnos("ENOSPC", "EDQUOT", "EROFS", "EACCES", "EPERM", "EIO", "ESTALE",
                               "EMFILE", "ENFILE", "ENOMEM")

# How far along __cause__/__context__ to look: a DeckError raised while reading a deck hit
# EIO is one step from it; a longer chain is not one failure.
_CHAIN_DEPTH = 4


def _environmental_itself(exc: BaseException) -> bool:
    # MemoryError: a deck that needs more memory than the machine has fails on every run, but
    # one that failed because the other workers held the memory runs alone; unrecorded, the
    # first is reported at each rerun, while a record would hide the second for good.
    if isinstance(exc, MemoryError):
        return True
    return isinstance(exc, OSError) and exc.errno in ENVIRONMENTAL_ERRNOS


def environmental_cause(exc: BaseException) -> BaseException | None:
    """The failure of the machine behind ``exc``: ``exc`` itself, the error it was raised
    from, or None when there is none.

    Parameters
    ----------
    exc : BaseException
        An exception of one deck's run.

    Returns
    -------
    BaseException or None
        A :class:`MemoryError`, or an :class:`OSError` whose ``errno`` is in
        :data:`ENVIRONMENTAL_ERRNOS`: ``exc`` or its cause or context (``read_deck`` turns an
        unreadable deck file into a DeckError ``from None``, which keeps the OSError as its
        context).
    """
    seen = exc
    for _ in range(_CHAIN_DEPTH):
        if seen is None or _environmental_itself(seen):
            return seen
        seen = seen.__cause__ or seen.__context__
    return None


def is_environmental(exc: BaseException) -> bool:
    """True when ``exc`` is a failure of the machine, not of the deck (:func:`environmental_cause`)."""
    return environmental_cause(exc) is not None


def reason(exc: BaseException) -> str:
    """The reason of a failure in words: ``"no space left on device"``, ``"out of memory"``.

    Other exceptions read ``"TypeName: message"``.
    """
    if isinstance(exc, MemoryError):
        return "out of memory"
    if isinstance(exc, OSError) and exc.errno is not None:
        text = exc.strerror or os.strerror(exc.errno)
        return text[:1].lower() + text[1:]
    return f"{type(exc).__name__}: {exc}"


def not_run_reason(exc: BaseException) -> str:
    """Why a grid point was not run, for the ``not run`` lines of a sweep.

    The reason (:func:`reason`) and the file it concerns, when known; for an exception that
    is not environmental (a pool worker that died), ``"TypeName: message"``.
    """
    cause = environmental_cause(exc)
    if cause is None:
        return f"{type(exc).__name__}: {exc}"
    where = getattr(cause, "filename", None)
    return reason(cause) + (f": {where}" if where else "")


@contextlib.contextmanager
def writing(path, hint: str = ""):
    """Turn an OSError of the block into a SweepError naming the file and the reason.

    Parameters
    ----------
    path : str or Path
        What the block writes; the OSError's own file name is named instead when it has one.
    hint : str
        Appended to the message (what to do about it).

    Raises
    ------
    SweepError
        ``cannot write FILE: REASON`` (e.g. ``no space left on device``).
    """
    try:
        yield
    except OSError as exc:
        where = exc.filename or path
        raise SweepError(f"cannot write {where}: {reason(exc)}{hint}") from exc
