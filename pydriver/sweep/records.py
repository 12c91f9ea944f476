"""Per-deck records of a sweep: ``DIR/runs/<id>/`` and the manifest ``DIR/sweep.json``.

A record is the directory of one finished deck: the files of ``python -m pydriver run``
(``summary.json`` last), or ``error.json`` for a deck that failed.  It is made in a hidden
temporary directory and renamed to ``runs/<id>`` when complete, so a sweep killed at any
moment leaves either a whole record or none, and a rerun skips the ids that have one.
:func:`run_task` makes one record; it is the task of every engine (local pool, Dask, Slurm).
A failure of the machine (a full disk, :mod:`pydriver.sweep.faults`) makes no record: the
point is run again by the next run of the sweep.  Both kinds of record carry a marker
(:mod:`pydriver.ownership`): kind ``run``, or ``sweep error`` listing ``error.json``.
"""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

from pydriver.ownership import MARKER, SWEEP_ERROR, marker_text
from pydriver.run import run_deck
from pydriver.sweep.errors import SweepError
from pydriver.sweep.faults import is_environmental, not_run_reason
from pydriver.sweep.files import make_hidden_dir, write_atomic
from pydriver.sweep.given_paths import checked_path
from pydriver.sweep.layout import (
    ERROR_FILE,
    MANIFEST,
    check_sweep_directory,
    existing_manifest,
)

__all__ = ["MAKERS", "MANIFEST", "read_manifest", "read_record", "run_point", "run_task"]


def read_manifest(out) -> dict:
    """The manifest ``DIR/sweep.json`` of a sweep directory.

    Raises
    ------
    FileNotFoundError
        ``out`` holds no manifest (none, a link, not one of rotorcable).
    """
    manifest = existing_manifest(out)
    if manifest is None:
        raise FileNotFoundError(f"{out}: not a sweep directory (no {MANIFEST} of rotorcable)")
    return manifest


def read_record(run_dir) -> dict | None:
    """The record of one finished run: ``{"summary": dict}`` or ``{"error": str}``.

    Returns None when the run has not finished (no ``summary.json`` nor ``error.json``).
    Records appear atomically (the run directory is renamed into place complete), so a
    record that exists is whole.
    """
    run_dir = Path(run_dir)
    if (run_dir / "summary.json").is_file():
        return {"summary": json.loads((run_dir / "summary.json").read_text())}
    if (run_dir / "error.json").is_file():
        return {"error": json.loads((run_dir / "error.json").read_text())["error"]}
    return None


#: What makes a record of a deck, by the name a manifest gives (``"maker"``; a sweep's is
#: ``"run"``): ``"module:function"``, called as ``function(deck, out)`` with ``out`` a new empty
#: directory to fill (all or nothing).  A usage spectrum's regimes keep only what its life needs
#: (:mod:`pydriver.analyses.spectrum_records`).
MAKERS = {"run": "pydriver.run:run_deck", "spectrum": "pydriver.analyses.spectrum_records:write_record"}


def _make_record(maker: str, deck: Path, out: Path) -> None:
    if maker == "run":
        run_deck(deck, out=out)          # by this module's name (a test replaces it)
        return
    import importlib
    module, function = MAKERS[maker].split(":")
    getattr(importlib.import_module(module), function)(deck, out)


def run_task(deck, run_dir, maker: str = "run") -> dict:
    """Run one deck and store its record in ``run_dir``: the task of every engine.

    Parameters
    ----------
    deck : str or Path
        The deck (absolute path when run on a cluster).
    run_dir : str or Path
        Record directory ``DIR/runs/<id>``; it appears complete or not at all.
    maker : str
        What the record holds (:data:`MAKERS`): ``"run"``, the files of ``pydriver run`` (a
        sweep); ``"spectrum"``, a usage spectrum's regime.

    Returns
    -------
    dict
        ``{"id", "error", "skipped"}``: ``error`` is None or ``"DeckError: ..."`` /
        ``"RunError: ..."``; ``skipped`` is True when a record already existed.

    Raises
    ------
    OSError, MemoryError
        A failure of the machine (:func:`pydriver.sweep.faults.is_environmental`: a full
        disk, a read-only file system, ...), or the record directory cannot be made or
        renamed.  No record is left, so the next run of the sweep runs the deck again.

    Notes
    -----
    Any other exception of the run is recorded in ``error.json`` instead of raised, so one
    failed deck does not stop the others.  If two tasks finish the same id (a requeued Slurm
    task), the first record stays and the second is discarded.
    """
    deck, run_dir = Path(deck), Path(run_dir)
    done = read_record(run_dir)
    if done is not None:
        return {"id": run_dir.name, "error": done.get("error"), "skipped": True}
    run_dir.parent.mkdir(parents=True, exist_ok=True)
    tmp = make_hidden_dir(run_dir.parent, run_dir.name)
    try:
        try:
            _make_record(maker, deck, tmp)
            error = None
        except Exception as exc:  # noqa: BLE001 (recorded, not raised: see Notes)
            if is_environmental(exc):
                raise           # the machine failed, not the deck: no record (faults module)
            error = f"{type(exc).__name__}: {exc}"
            write_atomic(tmp / ERROR_FILE, json.dumps(
                {"id": run_dir.name, "deck": str(deck), "error": error}, indent=1) + "\n")
            write_atomic(tmp / MARKER, marker_text(SWEEP_ERROR, [ERROR_FILE], deck.name, tmp))
        try:
            # rename() onto an existing non-empty directory fails: the first record stays.
            os.rename(tmp, run_dir)
        except OSError:
            if read_record(run_dir) is None:
                raise
    finally:
        shutil.rmtree(tmp, ignore_errors=True)      # made above; gone already after the rename
    return {"id": run_dir.name, "error": error, "skipped": False}


def run_point(out, index: int) -> dict:
    """Run grid point ``index`` of the sweep in ``out`` (a Slurm array task).

    Skips the point if it has a record already, so a requeued or repeated task is harmless.

    Parameters
    ----------
    out : str or Path
        A prepared sweep directory.
    index : int
        Grid point index (``$SLURM_ARRAY_TASK_ID``).

    Returns
    -------
    dict
        As :func:`run_task`.

    Raises
    ------
    SweepError
        ``index`` outside the grid, ``out`` with a control character, ``out`` a link or holding
        anything but its sweep (named: :mod:`pydriver.sweep.layout`), or the point not run for
        a failure of the machine (it has no record then, so running the task again runs it).
    FileNotFoundError
        ``out`` holds no sweep.
    """
    out = checked_path(out, "sweep directory", link_ok=False)
    check_sweep_directory(out, existing_manifest(out), "sweep directory")
    manifest = read_manifest(out)
    points = manifest["points"]
    if not 0 <= index < len(points):
        raise SweepError(f"{out}: task index {index} outside the grid 0-{len(points) - 1}")
    id_ = points[index]["id"]
    try:
        return run_task(out / "decks" / f"{id_}.nml", out / "runs" / id_, manifest.get("maker", "run"))
    except Exception as exc:
        # run_task raises only failures of the machine and record directories it cannot
        # make: either way the point has no record.
        if not (isinstance(exc, OSError) or is_environmental(exc)):
            raise
        raise SweepError(f"{id_} not run: {not_run_reason(exc)}; it has no record, so running "
                         "this task (or the sweep) again runs it") from exc
