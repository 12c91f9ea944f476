"""One sweep at a time in a sweep directory: ``DIR/.sweep.lock``, held with ``flock``.

The lock is held from before the first file of a sweep is written until its run ends, and by
``sweep-collect`` while it writes the table, plots and report: whatever rewrites the sweep's
own files (and the list of them in its marker) holds it.  The kernel drops the lock when its
process dies, so a killed sweep never blocks its resume.
"""

from __future__ import annotations

import contextlib
import errno
import os
from pathlib import Path

from pydriver.sweep.errors import SweepError
from pydriver.sweep.faults import writing

LOCK = ".sweep.lock"


@contextlib.contextmanager
def hold_lock(out: Path):
    """Hold ``out/.sweep.lock`` for the block; refuse at once if another process holds it.

    Raises
    ------
    SweepError
        Another sweep is running (or being prepared, or collected) in ``out``.
    """
    try:
        import fcntl
    except ImportError:          # not POSIX: no locking
        yield
        return
    # O_CLOEXEC: no child may inherit the lock (pool workers come from the forkserver, which
    # gets no descriptors of this process, and Dask and Slurm workers are other processes).
    # O_NOFOLLOW: a link put in its place is not followed to create or open another file.
    with writing(out / LOCK):
        fd = os.open(out / LOCK, os.O_RDWR | os.O_CREAT | getattr(os, "O_CLOEXEC", 0)
                     | getattr(os, "O_NOFOLLOW", 0), 0o666)
    with os.fdopen(fd, "rb") as fh:
        try:
            fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as exc:
            if exc.errno in (errno.EAGAIN, errno.EACCES):
                raise SweepError(f"{out}: another sweep is running in this directory (it holds "
                                 f"{LOCK}); wait for it to end, or choose another --out") from None
            # A file system without locks (some NFS set-ups): run unprotected rather than
            # refuse; the records stay consistent, only concurrent sweeps are not caught.
        yield
