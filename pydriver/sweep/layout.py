"""What a sweep directory may hold, and the one way the sweep's own files get into it.

A sweep directory is an output of the kind ``sweep`` under the rule of
:mod:`pydriver.ownership`: a sweep writes only into a new or empty directory or one holding
this sweep, and refuses anything else (a run, a study, a user's files, unknown entries) before
anything is computed or written, naming what is there.

What is the sweep's:

* the files it wrote itself, each listed in its marker ``.rotorcable-run.json`` (kind
  ``sweep``) before it is written (:func:`write_file`, under the sweep's lock): the manifest
  ``sweep.json``, ``decks/<id>.nml``, ``sweep.csv``, ``plots/*.png``, ``report.html``,
  ``sweep.slurm``;
* what others write for it, recognised by its place and form: one record per grid point of
  the manifest in ``runs/<id>/`` (a run's directory, or a failed deck's ``error.json``, each with
  its own marker; :func:`is_record`), the hidden temporaries of records still being made,
  Slurm's logs ``slurm/<job>_<task>.out``, the lock ``.sweep.lock`` (an empty file) and the
  hidden temporaries of :func:`pydriver.sweep.files.write_atomic`.

A sweep of an earlier version has a manifest but no marker; its files of the names above are
the sweep's, and the first file written lists them in a new marker.  What the sweep removes:
records of failed decks on ``--retry-failed`` and what killed tasks left in ``runs/``, each only
as :mod:`pydriver.ownership` allows (the files a record's marker lists, a verified temporary).
"""

from __future__ import annotations

import json
import os
import re
from collections.abc import Callable
from pathlib import Path

from pydriver.errors import OutputError
from pydriver.ownership import (
    DESCEND,
    MARKER,
    OURS,
    RUN,
    SWEEP,
    SWEEP_ERROR,
    check_output_directory,
    clean_stale_temporaries,
    foreign_entries,
    marker_text,
    pid_alive,
    read_marker,
    read_small_file,
    remove_output,
    unlink_plain_file,
)
from pydriver.sweep.errors import SweepError
from pydriver.sweep.files import HIDDEN_TAIL, write_atomic
from pydriver.sweep.lock import LOCK

MANIFEST = "sweep.json"
FORMAT = "rotorcable-sweep/1"
ERROR_FILE = "error.json"
#: Files the sweep writes at the top of its directory, and its subdirectories.
TOP_FILES = (MANIFEST, "sweep.csv", "report.html", "sweep.slurm")
#: A usage spectrum's own files at the top of its directory (pydriver/sweep/spectrum.py; always
#: listed in its marker: a spectrum directory has no earlier version).
SPECTRUM_FILES = ("spectrum.csv", "summary.json", "refinement.csv")
SUBDIRS = ("decks", "runs", "plots", "slurm")

_TOP_TEMPORARY = re.compile(r"\.(" + "|".join(map(re.escape, (*TOP_FILES, *SPECTRUM_FILES, MARKER))) + ")"
                            + HIDDEN_TAIL)
_DECK_TEMPORARY = re.compile(r"\.\d+\.nml" + HIDDEN_TAIL)
_PLOT_TEMPORARY = re.compile(r"\..+\.png" + HIDDEN_TAIL)
_LOOKS = 5                  # looks at a directory another sweep may be writing (check_sweep_directory)
_SLURM_LOG = re.compile(r"\d+_\d+\.out")
#: A record being made: files.make_hidden_dir(runs, id), and the run's temporary beside it.
_HIDDEN_RECORD = re.compile(r"\.(?P<id>\d+)\.(?P<pid>\d+)\.[0-9a-f]{16}")
#: A run's temporary (RunDirectory), or the earlier output it moved aside while swapping.
_RUN_TEMPORARY = re.compile(r"\..+\.(tmp-\d+-[^/]*|old-\d+(-\d+)?)")


def existing_manifest(out) -> dict | None:
    """The manifest of the sweep in ``out``, or None when ``out`` holds none (no
    ``sweep.json``, a link, not a manifest of this program)."""
    data = read_small_file(Path(out) / MANIFEST)
    try:
        manifest = json.loads(data.decode("utf-8")) if data is not None else None
    except (UnicodeDecodeError, ValueError):
        return None
    if not isinstance(manifest, dict) or manifest.get("format") != FORMAT:
        return None
    points, params = manifest.get("points"), manifest.get("params")
    if not (isinstance(points, list) and isinstance(params, list)
            and all(isinstance(p, dict) and isinstance(p.get("id"), str) and p["id"].isdigit() for p in points)):
        return None
    return manifest


def _plot_names(manifest: dict) -> set[str]:
    # pydriver.sweep.plots names its files <result>_vs_<parameter>.png, with [^\w.-] as _.
    return {re.sub(r"[^\w.-]", "_", str(p)) for p in manifest.get("params", [])}


def _is_plot_name(name: str, params: set[str]) -> bool:
    stem, dot_png = name[:-4], name[-4:]
    return dot_png == ".png" and any(stem.endswith(f"_vs_{p}") and re.fullmatch(r"[\w.-]+", stem) for p in params)


def is_record(path) -> bool:
    """Whether ``path`` is the record of a grid point: a run's directory (marker of kind
    ``run``) or a failed deck's (kind ``sweep error``), holding nothing else; or ``error.json``
    alone (a record of an earlier version)."""
    marker = read_marker(path)
    try:
        if marker is not None:
            return marker.kind in (RUN, SWEEP_ERROR) and not foreign_entries(path, marker.kind)
        with os.scandir(path) as it:
            entries = [(e.name, e.is_file(follow_symlinks=False)) for e in it]
    except OSError:
        return False
    return entries == [(ERROR_FILE, True)]


def remove_record(path) -> bool:
    """Delete a grid point's record or a record being made (an empty one included), only as
    :func:`pydriver.ownership.remove_output` allows; True when it is gone."""
    marker = read_marker(path)
    if marker is not None:
        return remove_output(path, marker.kind)
    if is_record(path):
        unlink_plain_file(path, ERROR_FILE)
    try:
        os.rmdir(path)
    except OSError:
        return False
    return True


def remove_stale_records(runs: Path, ids: set[str]) -> None:
    """Remove what killed tasks left in ``runs/``: verified temporaries of runs whose process
    is gone, and records being made by a process of this host that is gone (only their own
    files).  Called under the sweep's lock; anything else stays."""
    if not runs.is_dir() or runs.is_symlink():
        return
    clean_stale_temporaries(runs)
    try:
        with os.scandir(runs) as it:
            hidden = [(e.path, _HIDDEN_RECORD.fullmatch(e.name)) for e in it if e.is_dir(follow_symlinks=False)]
    except OSError:
        return                       # unreadable: the records' own reads will say why
    for path, match in hidden:
        if match is not None and match["id"] in ids and not pid_alive(int(match["pid"])):
            remove_record(path)


def sweep_layout(out, manifest: dict | None) -> Callable[[str, os.DirEntry], str | None]:
    """The ``also_ours`` of :func:`pydriver.ownership.foreign_entries` for the sweep in ``out``
    whose manifest is ``manifest`` (the module doc says what it accepts)."""
    marker = read_marker(out)
    current = existing_manifest(out)
    recognised = (marker is not None and marker.kind == SWEEP) or (marker is None and current is not None)
    legacy = marker is None and current is not None
    manifest = current or manifest or {"points": [], "params": []}
    ids = {p["id"] for p in manifest["points"]}
    params = _plot_names(manifest)

    def ours(rel: str, entry: os.DirEntry) -> str | None:
        parts = rel.split("/")
        regular = entry.is_file(follow_symlinks=False)
        real_dir = entry.is_dir(follow_symlinks=False)
        name = parts[-1]
        if len(parts) == 1:
            if name == LOCK:        # empty: flock never writes into it
                try:
                    return OURS if regular and entry.stat(follow_symlinks=False).st_size == 0 else None
                except OSError:
                    return None
            if regular and _TOP_TEMPORARY.fullmatch(name):
                return OURS
            if not recognised:
                return None
            if real_dir and name in SUBDIRS:
                return DESCEND
            return OURS if legacy and regular and name in TOP_FILES else None
        if len(parts) != 2:
            return None
        where = parts[0]
        if where == "decks":
            legacy_deck = legacy and name.endswith(".nml") and name[:-4] in ids
            return OURS if regular and (_DECK_TEMPORARY.fullmatch(name) or legacy_deck) else None
        if where == "plots":
            legacy_plot = legacy and _is_plot_name(name, params)
            return OURS if regular and (_PLOT_TEMPORARY.fullmatch(name) or legacy_plot) else None
        if where == "slurm":
            return OURS if regular and _SLURM_LOG.fullmatch(name) else None
        if where == "runs" and real_dir:
            if name in ids:
                return OURS if is_record(entry.path) else None
            hidden = _HIDDEN_RECORD.fullmatch(name)
            if (hidden is not None and hidden["id"] in ids) or _RUN_TEMPORARY.fullmatch(name):
                return OURS         # being made, or left by a killed task: never written again
        return None

    return ours


def check_sweep_directory(out, manifest: dict | None, what: str = "--out") -> None:
    """Refuse ``out`` unless it is new, empty or holds the sweep of ``manifest`` and nothing
    else (its own manifest, if it has one, says which grid points are the sweep's).

    A sweep that writes in ``out`` meanwhile lists each file in its marker before it writes it
    (:func:`claim`), so a file seen before the marker that lists it was read is seen again with
    a fresh marker: the directory is refused only when two looks in a row find the same.

    Raises
    ------
    SweepError
        Naming what is there, before anything is written.
    """
    refusal = None
    for _ in range(_LOOKS):
        try:
            check_output_directory(out, SWEEP, what, also_ours=sweep_layout(out, manifest), replaces=False)
            return
        except OutputError as exc:
            if str(exc) == refusal:
                break
            refusal = str(exc)
    raise SweepError(refusal)


def _legacy_files(out: Path) -> set[str]:
    """The files of a sweep of an earlier version (a manifest, no marker) that are its own."""
    manifest = existing_manifest(out)
    if manifest is None or read_marker(out) is not None:
        return set()
    layout = sweep_layout(out, manifest)
    found = set()
    for here in ("", "decks", "plots"):
        try:
            with os.scandir(out / here) as it:
                entries = list(it)
        except OSError:
            continue
        for e in entries:
            rel = f"{here}/{e.name}" if here else e.name
            if layout(rel, e) == OURS and e.is_file(follow_symlinks=False) and not e.name.startswith("."):
                found.add(rel)
    return found


def claim(out, names) -> None:
    """List ``names`` (relative to ``out``) in the sweep's marker before they are written.

    Call under the sweep's lock (:mod:`pydriver.sweep.lock`).

    Raises
    ------
    SweepError
        Something not listed is already at one of the names: the sweep did not write it.
    OSError
        The marker cannot be written.
    """
    out = Path(out)
    marker = read_marker(out)
    listed = set(marker.files) if marker is not None and marker.kind == SWEEP else _legacy_files(out)
    new = sorted(set(names) - listed)
    for rel in new:
        if os.path.lexists(out / rel):
            raise SweepError(f"{out} holds {rel}, which this sweep did not write; it is left as it "
                             "is: choose a new --out")
    if new or marker is None:
        base = (existing_manifest(out) or {}).get("base_deck")
        deck = Path(str(base)).name if base else marker.deck if marker is not None else ""
        write_atomic(out / MARKER, marker_text(SWEEP, listed | set(new), deck=deck, out=out))


def write_file(out, rel: str, data, mode: int = 0o666) -> Path:
    """Write one of the sweep's own files, ``out/rel``, whole (:func:`claim` first, then
    :func:`pydriver.sweep.files.write_atomic`); returns its path."""
    claim(out, [rel])
    path = Path(out) / rel
    write_atomic(path, data, mode)
    return path
