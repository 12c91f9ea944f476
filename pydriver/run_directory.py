"""A run's output directory: all of one run's files or none, and never a file it did not write.

A run writes into a temporary sibling directory and swaps it into place when everything is
written: a failure, an interrupt or a kill never leaves a partial or mixed directory, and files
of an earlier run (another analysis, another deck) never survive beside the new ones.

What may be replaced (issue 20: ``--out DIR`` deleted every file of an existing DIR, a user's
``thesis.tex`` included):

* a directory that does not exist yet, or an empty one;
* a directory holding one earlier run of rotorcable and nothing else: the run marker
  ``.rotorcable-run.json`` lists every file that run wrote, and a directory with any other
  file is refused.

Anything else (a foreign directory, a file, a symbolic link, the working directory or one
of its ancestors, a path with a control character) is refused before the computation starts,
with a message saying why.  This is the rule git, rsync and OpenFAST's writers follow: never
delete what you cannot prove is yours (``../shared/STYLE.md``).

Temporaries carry a marker of their own (``.rotorcable-tmp``) and their process id in their
name; the next run into the same parent removes those of processes that are gone (a run killed
with SIGKILL cannot clean up after itself).  Parent directories a run had to create are
removed again when the run fails.
"""

from __future__ import annotations

import ctypes
import errno
import json
import os
import shutil
import tempfile
from pathlib import Path

from pydriver.errors import OutputError
from pydriver.paths import PathError, reject_control_characters

#: The file that marks a directory as one run of rotorcable and lists the files it wrote.
MARKER = ".rotorcable-run.json"
#: The file that marks a temporary run directory (safe to remove once its process is gone).
TMP_MARKER = ".rotorcable-tmp"
_FOREIGN_SHOWN = 5


def _renameat2_exchange(a: Path, b: Path) -> bool:
    """Atomically exchange two paths (Linux renameat2 RENAME_EXCHANGE); False if unsupported."""
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        fn = libc.renameat2
    except (OSError, AttributeError):
        return False
    at_fdcwd, rename_exchange = -100, 2
    rc = fn(at_fdcwd, os.fsencode(str(a)), at_fdcwd, os.fsencode(str(b)), rename_exchange)
    if rc == 0:
        return True
    err = ctypes.get_errno()
    if err in (errno.ENOSYS, errno.EINVAL, errno.ENOTSUP):
        return False
    raise OSError(err, os.strerror(err), str(b))


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _relative_files(root: Path) -> tuple[list[str], list[str]]:
    """Every file (and symbolic link) below ``root`` as a relative path, and every directory."""
    files, dirs = [], []
    for here, subdirs, names in os.walk(root):
        rel = Path(here).relative_to(root)
        for d in subdirs:
            p = Path(here) / d
            (files if p.is_symlink() else dirs).append(str(rel / d))
        files.extend(str(rel / n) for n in names)
    return sorted(files), sorted(dirs)


def marked_files(directory: Path) -> set[str] | None:
    """The files an earlier run listed in its marker, or None when ``directory`` holds no
    readable marker of rotorcable."""
    marker = directory / MARKER
    if marker.is_symlink() or not marker.is_file():
        return None
    try:
        data = json.loads(marker.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if not isinstance(data, dict) or data.get("program") != "rotorcable" or \
            not isinstance(data.get("files"), list):
        return None
    return {str(f) for f in data["files"]}


def foreign_entries(directory: Path) -> list[str]:
    """What in an existing directory was not written by one earlier run of rotorcable
    (empty when the directory is empty or holds exactly such a run)."""
    files, dirs = _relative_files(directory)
    if not files and not dirs:
        return []
    listed = marked_files(directory)
    if listed is None:
        return files + [d + "/" for d in dirs if not any(f.startswith(d + "/") for f in files)]
    foreign = [f for f in files if f not in listed and f != MARKER]
    foreign += [d + "/" for d in dirs if not any(f.startswith(d + "/") for f in listed)]
    return foreign


def check_output_directory(out: Path, what: str = "--out") -> None:
    """Refuse an output path that a run must not replace (see the module's doc).

    Raises
    ------
    OutputError
        With the reason, before anything is computed or written.
    """
    try:
        reject_control_characters(out, what)
    except PathError as exc:
        raise OutputError(errno.EINVAL, str(exc), str(out)) from None
    if out.is_symlink():
        raise OutputError(errno.EEXIST, f"{what} {out} is a symbolic link; give a directory "
                                        "(rotorcable does not replace links)", str(out))
    resolved = out.resolve()
    cwd = Path.cwd().resolve()
    if resolved == cwd or resolved in cwd.parents:
        raise OutputError(errno.EBUSY, f"{what} {out} is the working directory or one of its "
                                       "parents; a run replaces its --out as a whole, so give a "
                                       "new directory below it (e.g. --out results/case)", str(out))
    if not out.exists():
        return
    if not out.is_dir():
        raise OutputError(errno.ENOTDIR, f"{what} {out} exists and is not a directory; "
                                         "rotorcable does not replace files", str(out))
    foreign = foreign_entries(out)
    if foreign:
        shown = ", ".join(foreign[:_FOREIGN_SHOWN]) + (" ..." if len(foreign) > _FOREIGN_SHOWN else "")
        raise OutputError(errno.EEXIST, f"{what} {out} holds files rotorcable did not write "
                                        f"({len(foreign)}: {shown}); a run replaces only an empty "
                                        "directory or one earlier run of its own: choose a new "
                                        "or empty directory", str(out))


class RunDirectory:
    """A run's output directory, written in a temporary sibling and swapped in at the end.

    Use as a context manager: on success ``commit`` swaps it in; on any exception the
    temporary directory (and any parent directory this run created) is removed and the old
    output stays as it was.

    Raises
    ------
    OutputError
        ``out`` must not be replaced (see :func:`check_output_directory`).
    OSError
        The parent directory cannot be created or written.
    """

    def __init__(self, out, deck: str = ""):
        self.out = Path(out)
        self.deck = deck
        self.committed = False
        check_output_directory(self.out)
        parent = self.out.parent
        self._made_parents = []                 # deepest first: removed again on failure
        p = parent
        while not p.exists() and not p.is_symlink() and p != p.parent:
            self._made_parents.append(p)
            p = p.parent
        parent.mkdir(parents=True, exist_ok=True)
        clean_stale_temporaries(parent, self.out.name)
        try:
            self.tmp = Path(tempfile.mkdtemp(prefix=f".{self.out.name}.tmp-{os.getpid()}-", dir=parent))
        except OSError:
            self._remove_made_parents()
            raise
        (self.tmp / TMP_MARKER).write_text(f"{os.getpid()}\n", encoding="utf-8")
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(self.tmp, 0o777 & ~umask)        # mkdtemp makes 0700; a result is for others too

    def path(self, name: str) -> Path:
        """Where to write the file ``name`` of this run."""
        return self.tmp / name

    def _write_marker(self):
        (self.tmp / TMP_MARKER).unlink()
        files, _ = _relative_files(self.tmp)
        marker = {"program": "rotorcable", "deck": self.deck, "files": files}
        (self.tmp / MARKER).write_text(json.dumps(marker, indent=1) + "\n", encoding="utf-8")

    def commit(self) -> Path:
        """Put the finished directory in place of ``out`` (atomically where Linux allows)."""
        self._write_marker()
        check_output_directory(self.out)      # again: the directory may have changed meanwhile
        if self.out.exists():
            if _renameat2_exchange(self.tmp, self.out):
                _remove_run(self.tmp, self.out)     # self.tmp now holds the earlier run
            else:
                old = self.out.parent / f".{self.out.name}.old-{os.getpid()}"
                os.rename(self.out, old)
                os.rename(self.tmp, self.out)
                _remove_run(old, self.out)
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
        shutil.rmtree(self.tmp, ignore_errors=True)
        self._remove_made_parents()

    def __enter__(self):
        return self

    def __exit__(self, exc_type, exc, tb):
        if exc_type is not None or not self.committed:
            self.abort()
        return False


def _remove_run(old: Path, out: Path) -> None:
    """Delete an earlier run moved aside, but only the files its marker lists: a file that
    appeared in it while this run computed stays, moved to a visible sibling of ``out``."""
    listed = marked_files(old)
    if listed is None:                           # an empty directory replaced
        listed = set()
    for rel in sorted(listed | {MARKER}, reverse=True):
        p = old / rel
        if p.is_file() or p.is_symlink():
            p.unlink()
    for here, _, _ in os.walk(old, topdown=False):           # children before parents
        try:
            os.rmdir(here)
        except OSError:
            pass
    if old.exists():
        keep = out.parent / f"{out.name}.kept-{os.getpid()}"
        os.rename(old, keep)


def clean_stale_temporaries(parent: Path, name: str) -> None:
    """Remove temporary run directories in ``parent`` whose process is gone.

    A candidate is a hidden directory named ``.<name>.tmp-<pid>-*`` (this output's) or any
    ``.*.tmp-<pid>-*`` holding :data:`TMP_MARKER` (another output's in the same parent); it is
    removed when no process ``pid`` exists.  A directory without the marker and not of this
    output is never touched: it may be a user's.
    """
    for p in parent.glob(".*.tmp-*"):
        try:
            pid = int(p.name.rsplit(".tmp-", 1)[1].split("-")[0])
        except (IndexError, ValueError):
            continue
        ours = p.name.startswith(f".{name}.tmp-") or (p / TMP_MARKER).is_file()
        if ours and p.is_dir() and not p.is_symlink() and not _pid_alive(pid):
            shutil.rmtree(p, ignore_errors=True)
    for p in parent.glob(f".{name}.old-*"):
        try:
            pid = int(p.name.rsplit(".old-", 1)[1])
        except (IndexError, ValueError):
            continue
        if p.is_dir() and not p.is_symlink() and not _pid_alive(pid):
            shutil.rmtree(p, ignore_errors=True)
