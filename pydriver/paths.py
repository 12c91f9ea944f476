"""Paths a user gives: refused when they cannot be written safely into a file or a script.

A path is written into scripts (``sweep.slurm``), CSV cells and log lines.  A control
character in it (a newline above all) would become a new line of a shell script, so such a
path is refused before anything is written (issue 20: a newline in ``--out`` became a command
of ``sweep.slurm``).
"""

from __future__ import annotations

import os
import re
import unicodedata

_CONTROL = re.compile(r"[\x00-\x1f\x7f]")      # C0 and DEL; C1 (NEL ...) by category Cc


class PathError(ValueError):
    """A path given by the user that rotorcable refuses to use."""


def reject_control_characters(path, what: str) -> None:
    """Raise :class:`PathError` when ``path`` holds a control character (newline, tab, ...).

    Parameters
    ----------
    path : str or os.PathLike
        The path as the user gave it.
    what : str
        How the user gave it, for the message (e.g. ``"--out"``).
    """
    text = os.fspath(path)
    bad = [c for c in text if _CONTROL.match(c) or unicodedata.category(c) in ("Cc", "Zl", "Zp")]
    if bad:
        raise PathError(f"{what} {text!r}: a path with a control character ({bad[0]!r}) is refused; "
                        "it could not be written safely into scripts and tables")
