"""Files of a sweep directory: each appears whole, with the permissions of a plain ``open()``.

Every file is written under a hidden temporary name beside its final one and renamed into
place, so a reader (a resume, ``sweep-collect`` while a Slurm array runs, a person) never sees
half of one.  ``tempfile.mkstemp``/``mkdtemp`` would create them 0600/0700; a sweep's results
are for others to read, so here files are created 0666 and directories 0777, less the umask,
as ``open()`` and ``mkdir`` do.  (Reading the umask would need ``os.umask``, which changes it
for every thread of the process for a moment; creating with the mode lets the kernel apply it.)
"""

from __future__ import annotations

import contextlib
import os
import secrets
from pathlib import Path

# Random temporary names: 64 bits make a collision with a concurrent writer negligible; the
# O_EXCL create refuses one anyway and the next name is tried.
_ATTEMPTS = 16
_CLOEXEC = getattr(os, "O_CLOEXEC", 0)        # POSIX; Windows handles are not inherited anyway


#: The tail of a hidden temporary name after ``.<name>``: ``.<pid>.<16 hex digits>``.
HIDDEN_TAIL = r"\.\d+\.[0-9a-f]{16}"


def _hidden_name(directory: Path, name: str) -> Path:
    return directory / f".{name}.{os.getpid()}.{secrets.token_hex(8)}"


def write_atomic(path, data, mode: int = 0o666) -> None:
    """Write ``data`` (str as UTF-8, or bytes) to ``path``, replacing it in one step.

    On any failure (a full disk in the middle of the data, say) the temporary file is removed
    and ``path`` is left as it was: whole and old, or absent.

    Parameters
    ----------
    path : str or Path
        Final file name; its directory must exist.
    data : str or bytes
        The whole content.
    mode : int
        Permissions before the umask (0o777 for a script).

    Raises
    ------
    OSError
        The file cannot be written; its ``filename`` is ``path``, not the hidden temporary
        name, so that a message names the file the user knows.
    """
    path = Path(path)
    raw = data.encode("utf-8") if isinstance(data, str) else data
    tmp = None
    try:
        for _ in range(_ATTEMPTS):
            candidate = _hidden_name(path.parent, path.name)
            try:
                fd = os.open(candidate, os.O_WRONLY | os.O_CREAT | os.O_EXCL | _CLOEXEC, mode)
            except FileExistsError:
                continue
            tmp = candidate
            break
        else:
            raise FileExistsError(f"{path.parent}: no free temporary name for {path.name}")
        with os.fdopen(fd, "wb") as fh:
            fh.write(raw)
        os.replace(tmp, path)
    except BaseException as exc:
        if tmp is not None:
            with contextlib.suppress(OSError):      # the disk may refuse this too (EROFS, EIO)
                tmp.unlink(missing_ok=True)
        if isinstance(exc, OSError) and exc.errno is not None:
            raise OSError(exc.errno, exc.strerror or os.strerror(exc.errno), str(path)) from exc
        raise


def make_hidden_dir(parent, name: str) -> Path:
    """A new hidden directory ``parent/.name.<pid>.<random>`` (mode 0777 less the umask)."""
    parent = Path(parent)
    for _ in range(_ATTEMPTS):
        path = _hidden_name(parent, name)
        try:
            os.mkdir(path, 0o777)
        except FileExistsError:
            continue
        return path
    raise FileExistsError(f"{parent}: no free temporary name for {name}")
