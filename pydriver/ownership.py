"""Which files are rotorcable's: the one rule every command that writes obeys.

**The rule.**  A command that writes a directory (``run``, ``run --restart``, ``--vtk`` and
``--report`` with it, ``study``, ``sweep``, ``sweep-task``, ``sweep-collect``) writes into

* a directory that does not exist yet, or an empty one, or
* a directory holding one earlier output of the *same kind* of this program and nothing else,
  recognised by its marker ``.rotorcable-run.json``: the program, the kind (``run``,
  ``study <name>``, ``sweep``, ``sweep error``), where it was written and the files it wrote;

anything else (a file, a symbolic link, the working directory or one of its parents, a
directory holding a user's file, a look-alike, an output of another kind) is refused before
anything is computed or written, and the message names what is there.  A command that writes
single files (``examples``, ``init``) creates each one new (``O_EXCL``, never through a link)
and leaves whatever is already there as it is.

**What may be deleted.**  Only what is provably rotorcable's, and never through a link:

* of an earlier output that a new one replaces, the plain files its marker lists directly in
  its directory, then the marker and the directory if nothing else is left in it;
* a temporary directory (``.<out>.tmp-<pid>-*``) whose marker ``.rotorcable-tmp`` says it is
  rotorcable's, of process ``<pid>`` on this host, for the output ``<out>`` beside it, once that
  process is gone;
* an earlier output moved aside (``.<out>.old-<pid>``, where the swap cannot exchange two
  directories at once) when its marker names ``<out>`` as where it was written and that
  process is gone: again only the files the marker lists.

A marker is input like any other: its listed names are refused unless relative, normalised,
without ``..`` and, for any kind but a sweep, directly inside the directory; a listed name
counts only where the directory holds a regular file under it (not a link, not through one).
An old marker without a kind is a run's (run directories of earlier versions keep working).

Never overwrite or delete what you cannot prove is yours: the rule of the tools users trust
with their files (git, rsync, OpenFAST's output writers).  :mod:`pydriver.run_directory` writes
runs and studies through this module, :mod:`pydriver.sweep.layout` sweeps,
:mod:`pydriver.examples` the example decks.
"""

from __future__ import annotations

import errno
import json
import os
import re
import shutil
import socket
import stat
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from pydriver.errors import OutputError
from pydriver.paths import PathError, reject_control_characters

#: The file that marks a directory as one output of rotorcable and lists the files it wrote.
MARKER = ".rotorcable-run.json"
#: The file that marks a temporary directory of rotorcable (removable once its process is gone).
TMP_MARKER = ".rotorcable-tmp"
PROGRAM = "rotorcable"

#: Kinds of output (a study's is ``study <name>``).
RUN = "run"
SWEEP = "sweep"
SWEEP_ERROR = "sweep error"          # the record of a sweep's grid point whose deck failed

#: What a layout function (``also_ours``) says of an entry the marker does not list.
OURS = "ours"              # the entry and everything below it belong to the output
DESCEND = "descend"        # a directory of the output: judge its entries one by one

_SHOWN = 5                 # entries named in a refusal; the rest are counted
_MARKER_LIMIT = 64 << 20   # bytes; a marker lists file names, a larger one is not ours
_CLOEXEC = getattr(os, "O_CLOEXEC", 0)
_NOFOLLOW = getattr(os, "O_NOFOLLOW", 0)
_TEMPORARY = re.compile(r"\.(?P<name>.+)\.tmp-(?P<pid>\d+)-[^/]*")
_MOVED_ASIDE = re.compile(r"\.(?P<name>.+)\.old-(?P<pid>\d+)(-\d+)?")


def study_kind(name: str) -> str:
    """The kind of output of the study ``name`` (``study cy-sweep``)."""
    return f"study {name}"


@dataclass(frozen=True)
class Marker:
    """A verified marker: what kind of output a directory holds and which files it wrote.

    Attributes
    ----------
    kind : str
        ``run``, ``study <name>``, ``sweep`` or ``sweep error``.
    files : frozenset of str
        The listed names that passed the checks of the module doc (relative to the directory).
    deck : str
        The deck (or base deck) it was made from, for messages.
    written_to : str or None
        The absolute path it was written to (None in markers of earlier versions).
    """

    kind: str
    files: frozenset
    deck: str = ""
    written_to: str | None = None


def read_small_file(path) -> bytes | None:
    """The bytes of ``path`` if it is a regular file (not a link, not a FIFO) of at most 64 MiB,
    else None: how rotorcable reads a file it finds in an output directory."""
    try:
        fd = os.open(path, os.O_RDONLY | _NOFOLLOW | _CLOEXEC | getattr(os, "O_NONBLOCK", 0))
    except OSError:
        return None
    with os.fdopen(fd, "rb") as fh:
        try:
            if not stat.S_ISREG(os.fstat(fd).st_mode):
                return None
            data = fh.read(_MARKER_LIMIT + 1)
        except OSError:
            return None
    return data if len(data) <= _MARKER_LIMIT else None


def _read_json(path) -> dict | None:
    data = read_small_file(path)
    if data is None:
        return None
    try:
        content = json.loads(data.decode("utf-8"))
    except (UnicodeDecodeError, ValueError):
        return None
    return content if isinstance(content, dict) and content.get("program") == PROGRAM else None


def safe_name(name, nested: bool = False) -> str | None:
    """``name`` if a marker may list it (module doc), else None.

    Parameters
    ----------
    name : object
        One entry of a marker's ``files`` (anything: the marker is input).
    nested : bool
        Whether names in subdirectories are allowed (a sweep's ``decks/0000.nml``).
    """
    if not isinstance(name, str) or not name or "\x00" in name or name.startswith("/"):
        return None
    parts = name.split("/")
    if any(p in ("", ".", "..") for p in parts) or (len(parts) > 1 and not nested):
        return None
    return None if name in (MARKER, TMP_MARKER) else name


def read_marker(directory) -> Marker | None:
    """The verified marker of ``directory``, or None when it holds no readable marker of
    rotorcable (none, a link, not JSON, another program's, a malformed file list)."""
    data = _read_json(Path(directory) / MARKER)
    if data is None or not isinstance(data.get("files"), list):
        return None
    kind = data.get("kind", RUN)                   # markers of earlier versions: runs
    if not isinstance(kind, str) or not kind:
        return None
    names = {safe_name(f, nested=kind == SWEEP) for f in data["files"]}
    written_to = data.get("out")
    return Marker(kind=kind, files=frozenset(names - {None}), deck=str(data.get("deck", "")),
                  written_to=written_to if isinstance(written_to, str) else None)


def written_to(out) -> str:
    """Where ``out`` is, as markers record it: its parent's real path joined with its name."""
    out = Path(out)
    return os.path.join(os.path.realpath(out.parent), out.name)


def marker_text(kind: str, files, deck: str = "", out=None) -> str:
    """The content of a marker for an output of ``kind`` that wrote ``files``."""
    marker = {"program": PROGRAM, "kind": kind, "deck": deck}
    if out is not None:
        marker["out"] = written_to(out)
    marker["files"] = sorted(files)
    return json.dumps(marker, indent=1) + "\n"


def foreign_entries(directory, kind: str = RUN,
                    also_ours: Callable[[str, os.DirEntry], str | None] | None = None) -> list[str]:
    """What in ``directory`` is not part of one earlier output of ``kind`` (empty when the
    directory is empty or holds exactly such an output).

    Parameters
    ----------
    directory : str or Path
        An existing directory.
    kind : str
        The kind of output the directory may hold; a marker of another kind lists nothing.
    also_ours : callable, optional
        ``also_ours(relative_path, entry)`` for entries the marker does not list: :data:`OURS`,
        :data:`DESCEND` or None (a sweep's records, written by its tasks, are not listed).

    Returns
    -------
    list of str
        Relative paths, sorted by directory; a directory is named with a trailing ``/`` when
        nothing in it is the output's.
    """
    directory = Path(directory)
    marker = read_marker(directory)
    listed = marker.files if marker is not None and marker.kind == kind else frozenset()
    holding = {"/".join(f.split("/")[:k]) for f in listed for k in range(1, f.count("/") + 1)}
    foreign: list[str] = []

    def visit(rel_dir: str):
        try:
            with os.scandir(directory / rel_dir if rel_dir else directory) as it:
                entries = sorted(it, key=lambda e: e.name)
        except OSError:
            if not rel_dir:
                raise
            foreign.append(rel_dir + "/")          # unreadable: nothing in it is provably ours
            return
        for e in entries:
            rel = f"{rel_dir}/{e.name}" if rel_dir else e.name
            if rel == MARKER and marker is not None:
                continue
            if rel in listed and e.is_file(follow_symlinks=False):
                continue
            verdict = also_ours(rel, e) if also_ours is not None else None
            if verdict == OURS:
                continue
            is_dir = e.is_dir(follow_symlinks=False)
            if is_dir and (verdict == DESCEND or rel in holding):
                visit(rel)
            else:
                foreign.append(rel + "/" if is_dir else rel)

    visit("")
    return foreign


def _shown(entries: list[str]) -> str:
    return ", ".join(entries[:_SHOWN]) + (" ..." if len(entries) > _SHOWN else "")


def check_output_directory(out, kind: str = RUN, what: str = "--out",
                           also_ours: Callable[[str, os.DirEntry], str | None] | None = None,
                           replaces: bool = True) -> None:
    """Refuse an output path that a command writing an output of ``kind`` must not use (the
    rule of the module doc).

    Parameters
    ----------
    out : str or Path
        The output directory as the user gave it.
    kind : str
        ``run``, ``study <name>``, ``sweep``, ...
    what : str
        How the user gave it, for the message (``--out``).
    also_ours : callable, optional
        As for :func:`foreign_entries`.
    replaces : bool
        Whether the output replaces the directory as a whole (a run, a study), so that the
        working directory and its parents are refused; a sweep adds to its directory.

    Raises
    ------
    OutputError
        With the reason and what is there, before anything is computed or written.
    """
    out = Path(out)
    try:
        reject_control_characters(out, what)
    except PathError as exc:
        raise OutputError(errno.EINVAL, str(exc), str(out)) from None
    if out.is_symlink():
        raise OutputError(errno.EEXIST, f"{what} {out} is a symbolic link; give a directory "
                                        "(rotorcable does not replace links)", str(out))
    resolved = out.resolve()
    cwd = Path.cwd().resolve()
    if replaces and (resolved == cwd or resolved in cwd.parents):
        raise OutputError(errno.EBUSY, f"{what} {out} is the working directory or one of its "
                                       f"parents; a {kind} replaces its --out as a whole, so give "
                                       "a new directory below it (e.g. --out results/case)", str(out))
    if not out.exists():
        return
    if not out.is_dir():
        raise OutputError(errno.ENOTDIR, f"{what} {out} exists and is not a directory; "
                                         "rotorcable does not replace files", str(out))
    rule = (f"a {kind} writes only into a new or empty directory or one earlier {kind} of its own "
            f"(marked by {MARKER}): choose a new or empty directory")
    marker = read_marker(out)
    if marker is not None and marker.kind != kind:
        try:
            with os.scandir(out) as it:
                there = sorted(e.name + ("/" if e.is_dir(follow_symlinks=False) else "") for e in it)
        except OSError:
            there = [MARKER]
        raise OutputError(errno.EEXIST, f"{what} {out} holds a {marker.kind} of rotorcable"
                                        f"{' of ' + marker.deck if marker.deck else ''} ({len(there)}: "
                                        f"{_shown(there)}), not a {kind}; {rule}", str(out))
    try:
        foreign = foreign_entries(out, kind, also_ours)
    except OSError as exc:
        raise OutputError(exc.errno or errno.EACCES, f"{what} {out} cannot be read "
                                                     f"({exc.strerror or exc}); {rule}", str(out)) from None
    if foreign:
        raise OutputError(errno.EEXIST, f"{what} {out} holds files rotorcable did not write "
                                        f"({len(foreign)}: {_shown(foreign)}); {rule}", str(out))


def unlink_plain_file(directory, name: str) -> bool:
    """Delete ``directory/name`` if it is a regular file directly inside ``directory``, reached
    through no link; True if it was deleted."""
    if safe_name(name) is None and name != MARKER:
        return False
    try:
        fd = os.open(directory, os.O_RDONLY | os.O_DIRECTORY | _NOFOLLOW | _CLOEXEC)
    except OSError:
        return False
    try:
        if not stat.S_ISREG(os.lstat(name, dir_fd=fd).st_mode):
            return False
        os.unlink(name, dir_fd=fd)
        return True
    except OSError:                  # gone already, or not ours to delete after all: it stays
        return False
    finally:
        os.close(fd)


def remove_output(directory, kind: str) -> bool:
    """Delete an earlier output of ``kind`` (module doc): the plain files its marker lists
    directly in it, then the marker and the directory if nothing else is left.

    Returns
    -------
    bool
        True when the directory is gone (an empty directory is removed too).
    """
    marker = read_marker(directory)
    if marker is not None and marker.kind == kind:
        for name in sorted(marker.files):
            if "/" not in name:
                unlink_plain_file(directory, name)
        # The marker goes only with the last of its files: what stays is still described.
        try:
            with os.scandir(directory) as it:
                left = [e.name for e in it]
        except OSError:
            return False
        if left == [MARKER]:
            unlink_plain_file(directory, MARKER)
    try:
        os.rmdir(directory)
    except OSError:
        return False
    return True


def pid_alive(pid: int) -> bool:
    """Whether process ``pid`` exists on this host (a zombie counts as gone)."""
    if pid <= 0:
        return True                 # not a process id (0 and -1 would signal groups)
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError):
        return pid > 0
    try:
        state = Path(f"/proc/{pid}/stat").read_text()
        return state[state.rindex(")") + 2] not in "ZX"
    except (OSError, ValueError, IndexError):
        return True


def write_tmp_marker(tmp, out) -> None:
    """Mark the temporary directory ``tmp`` of the output ``out`` as this process's."""
    text = json.dumps({"program": PROGRAM, "pid": os.getpid(), "host": socket.gethostname(),
                       "out": written_to(out)}) + "\n"
    with open(Path(tmp) / TMP_MARKER, "x", encoding="utf-8") as fh:
        fh.write(text)


def _temporary_of_dead_process(path: Path, name: str, pid: int) -> bool:
    """``path`` is a temporary of rotorcable for the output ``name`` beside it, made by the
    process ``pid`` of this host, which is gone (its marker says so: module doc)."""
    data = _read_json(path / TMP_MARKER)
    return (data is not None and data.get("pid") == pid and data.get("host") == socket.gethostname()
            and data.get("out") == os.path.join(os.path.realpath(path.parent), name)
            and not pid_alive(pid))


def clean_stale_temporaries(parent) -> None:
    """Remove what processes now gone left in ``parent`` (the module doc says which).

    A directory that only looks like one (a user's ``.o.tmp-999999-mine/`` or ``.o.old-1/``
    without a marker of rotorcable naming ``o``) is never touched.
    """
    parent = Path(parent)
    try:
        with os.scandir(parent) as it:
            entries = [e for e in it if e.is_dir(follow_symlinks=False)]
    except OSError:
        return
    for e in entries:
        match = _TEMPORARY.fullmatch(e.name) or _MOVED_ASIDE.fullmatch(e.name)
        if match is None:
            continue
        path, name, pid = Path(e.path), match["name"], int(match["pid"])
        if match.re is _TEMPORARY and _temporary_of_dead_process(path, name, pid):
            shutil.rmtree(path, ignore_errors=True)          # never follows a link inside
            continue
        if match.re is _MOVED_ASIDE:
            marker = read_marker(path)
            if marker is not None and marker.written_to == os.path.join(os.path.realpath(parent), name) \
                    and not pid_alive(pid):
                remove_output(path, marker.kind)


def create_new_file(path, data) -> Path:
    """Write ``data`` (str as UTF-8, or bytes) to ``path``, which must not exist: never replaces
    a file, never writes through a link (a dangling one included).

    Raises
    ------
    FileExistsError
        Something (a file, a directory, a link) is at ``path``.
    """
    path = Path(path)
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL | _NOFOLLOW | _CLOEXEC, 0o666)
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data.encode("utf-8") if isinstance(data, str) else data)
    except BaseException:
        os.unlink(path)          # ours: created above
        raise
    return path
