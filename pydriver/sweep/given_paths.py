"""Paths the user gives a sweep (``--out``, the base deck): refused with a control character.

A sweep writes its paths into a Slurm script, deck headers, CSV cells and messages; a newline
in one became a command of ``sweep.slurm`` (issue 20).  Every sweep command checks the path as
given and as made absolute (a relative ``--out`` takes the working directory's name, and a
symbolic link its target's) before it writes anything.
"""

from __future__ import annotations

from pathlib import Path

from pydriver.paths import PathError, reject_control_characters
from pydriver.sweep.errors import SweepError


def refuse_control_characters(path, what: str) -> None:
    """Raise :class:`SweepError` when ``path`` holds a control character (as given, not resolved).

    Parameters
    ----------
    path : str or os.PathLike
        A path written into the sweep's files (``sys.executable``, say: resolving it would
        leave its virtual environment).
    what : str
        What the path is, for the message.
    """
    try:
        reject_control_characters(path, what)
    except PathError as exc:
        raise SweepError(str(exc)) from None


def checked_path(path, what: str, link_ok: bool = True) -> Path:
    """``path`` made absolute, after refusing it when it holds a control character.

    Parameters
    ----------
    path : str or os.PathLike
        The path as the user gave it.
    what : str
        How the user gave it, for the message (``"--out"``, ``"base deck"``).
    link_ok : bool
        False for a directory the sweep writes into: a symbolic link there is refused, as for
        any output of rotorcable (:mod:`pydriver.ownership`), rather than written through.

    Returns
    -------
    Path
        ``Path(path).resolve()``.

    Raises
    ------
    SweepError
        The path, or its absolute form, holds a control character (newline, tab, NUL, ...), or
        it is a symbolic link where ``link_ok`` is False.
    """
    refuse_control_characters(path, what)      # first: resolve() itself fails on a NUL byte
    if not link_ok and Path(path).is_symlink():
        raise SweepError(f"{what} {path} is a symbolic link; give a directory (rotorcable does not "
                         "write through links)")
    resolved = Path(path).resolve()
    refuse_control_characters(resolved, f"{what} (as an absolute path)")
    return resolved
