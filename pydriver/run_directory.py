"""An output directory written whole: all of one run's (or study's) files or none.

A run writes into a temporary sibling directory and swaps it into place when everything is
written: a failure, an interrupt or a kill never leaves a partial or mixed directory, and files
of an earlier run (another analysis, another deck) never survive beside the new ones.

Which directories may be replaced and what may be deleted is the rule of
:mod:`pydriver.ownership` (issue 20: ``--out DIR`` deleted every file of an existing DIR, a
user's ``thesis.tex`` included; issue 35: a crafted marker deleted ``../victim.txt``, and a
user's look-alike temporaries beside ``--out`` were removed).  In short: a new or empty
directory, or one earlier output of the same kind (marked by ``.rotorcable-run.json``, which
lists its files); anything else is refused before the computation starts.

Temporaries carry a marker of their own (``.rotorcable-tmp``: the program, the process id and
host, the output they belong to); the next output written into the same parent removes those
of processes that are gone (a run killed with SIGKILL cannot clean up after itself).  Parent
directories a run had to create are removed again when the run fails.
"""

from __future__ import annotations

import ctypes
import errno
import os
import shutil
import tempfile
from pathlib import Path

from pydriver.ownership import (
    MARKER,
    RUN,
    TMP_MARKER,
    check_output_directory,
    clean_stale_temporaries,
    foreign_entries,
    marker_text,
    read_marker,
    remove_output,
    write_tmp_marker,
)

__all__ = ["MARKER", "TMP_MARKER", "RunDirectory", "check_output_directory", "clean_stale_temporaries",
           "foreign_entries", "marked_files"]

_RENAME_NOREPLACE, _RENAME_EXCHANGE = 1, 2


def _renameat2(a: Path, b: Path, flags: int) -> bool:
    """Linux renameat2 with ``flags``; False where the kernel or file system lacks it."""
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        fn = libc.renameat2
    except (OSError, AttributeError):
        return False
    at_fdcwd = -100
    rc = fn(at_fdcwd, os.fsencode(str(a)), at_fdcwd, os.fsencode(str(b)), flags)
    if rc == 0:
        return True
    err = ctypes.get_errno()
    if err in (errno.ENOSYS, errno.EINVAL, errno.ENOTSUP):
        return False
    raise OSError(err, os.strerror(err), str(b))


def _rename_noreplace(a: Path, b: Path) -> None:
    """Rename ``a`` to ``b`` unless something is at ``b`` (FileExistsError then)."""
    if not _renameat2(a, b, _RENAME_NOREPLACE):
        if b.exists() or b.is_symlink():        # no atomic way here: check, then rename
            raise FileExistsError(errno.EEXIST, os.strerror(errno.EEXIST), str(b))
        os.rename(a, b)


def _free_sibling(out: Path, label: str) -> Path:
    """A name ``.<out>.<label>-<pid>[-k]`` (or ``<out>.<label>-...`` for ``kept``) beside ``out``
    that nothing uses."""
    stem = f"{out.name}.{label}-{os.getpid()}" if label == "kept" else f".{out.name}.{label}-{os.getpid()}"
    for k in range(1000):
        candidate = out.parent / (stem if k == 0 else f"{stem}-{k}")
        if not (candidate.exists() or candidate.is_symlink()):
            return candidate
    raise FileExistsError(errno.EEXIST, "no free name beside the output", str(out))


def marked_files(directory: Path) -> set[str] | None:
    """The files an earlier output lists in its verified marker, or None when ``directory``
    holds no readable marker of rotorcable (:func:`pydriver.ownership.read_marker`)."""
    marker = read_marker(directory)
    return None if marker is None else set(marker.files)


class RunDirectory:
    """An output directory, written in a temporary sibling and swapped in at the end.

    Use as a context manager: on success ``commit`` swaps it in; on any exception the
    temporary directory (and any parent directory this run created) is removed and the old
    output stays as it was.

    Parameters
    ----------
    out : str or Path
        The output directory (:func:`pydriver.ownership.check_output_directory` decides
        whether it may be written).
    deck : str
        The deck's name, recorded in the marker.
    kind : str
        The kind of output (``run``, ``study <name>``): it replaces only an earlier output of
        the same kind.

    Raises
    ------
    OutputError
        ``out`` must not be replaced (see :func:`check_output_directory`).
    OSError
        The parent directory cannot be created or written.
    """

    def __init__(self, out, deck: str = "", kind: str = RUN):
        self.out = Path(out)
        self.deck = deck
        self.kind = kind
        self.committed = False
        check_output_directory(self.out, kind)
        parent = self.out.parent
        self._made_parents = []                 # deepest first: removed again on failure
        p = parent
        while not p.exists() and not p.is_symlink() and p != p.parent:
            self._made_parents.append(p)
            p = p.parent
        parent.mkdir(parents=True, exist_ok=True)
        clean_stale_temporaries(parent)
        try:
            self.tmp = Path(tempfile.mkdtemp(prefix=f".{self.out.name}.tmp-{os.getpid()}-", dir=parent))
        except OSError:
            self._remove_made_parents()
            raise
        try:
            write_tmp_marker(self.tmp, self.out)
            umask = os.umask(0)
            os.umask(umask)
            os.chmod(self.tmp, 0o777 & ~umask)        # mkdtemp makes 0700; a result is for others too
        except BaseException:
            self.abort()
            raise

    def path(self, name: str) -> Path:
        """Where to write the file ``name`` of this output."""
        return self.tmp / name

    def _write_marker(self):
        # Every file sits directly in the directory (the marker of a run or study lists no
        # subdirectory, ownership.safe_name).  The temporary's own marker goes last, so that a
        # process killed in between leaves a temporary that is still recognisably its own.
        with os.scandir(self.tmp) as it:
            files = [e.name for e in it if e.is_file(follow_symlinks=False) and e.name != TMP_MARKER]
        (self.tmp / MARKER).write_text(marker_text(self.kind, files, self.deck, self.out), encoding="utf-8")
        (self.tmp / TMP_MARKER).unlink()

    def commit(self) -> Path:
        """Put the finished directory in place of ``out`` (atomically where Linux allows)."""
        self._write_marker()
        check_output_directory(self.out, self.kind)   # again: the directory may have changed meanwhile
        if self.out.exists():
            if _renameat2(self.tmp, self.out, _RENAME_EXCHANGE):
                _remove_earlier(self.tmp, self.out, self.kind)     # self.tmp now holds the earlier output
            else:
                old = _free_sibling(self.out, "old")
                os.rename(self.out, old)
                os.rename(self.tmp, self.out)
                _remove_earlier(old, self.out, self.kind)
        else:
            os.rename(self.tmp, self.out)
        self.committed = True
        return self.out

    def _remove_made_parents(self):
        for p in self._made_parents:
            try:
                p.rmdir()
            except OSError:
                break

    def abort(self):
        """Remove the temporary directory (ours: made by this object) and the parents it made."""
        shutil.rmtree(self.tmp, ignore_errors=True)
        self._remove_made_parents()

    def __enter__(self):
        return self

    def __exit__(self, exc_type, exc, tb):
        if exc_type is not None or not self.committed:
            self.abort()
        return False


def _remove_earlier(old: Path, out: Path, kind: str) -> None:
    """Delete an earlier output moved aside, but only the files its marker lists
    (:func:`pydriver.ownership.remove_output`): a file that appeared in it while this run
    computed stays, moved to a visible sibling of ``out``."""
    if not remove_output(old, kind):
        _rename_noreplace(old, _free_sibling(out, "kept"))
