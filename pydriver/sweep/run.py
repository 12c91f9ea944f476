"""``run_sweep``: prepare a sweep directory, run its missing decks on an engine, collect."""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

from pydriver.sweep.directory import open_sweep
from pydriver.sweep.engines import default_jobs, run_dask, run_pool
from pydriver.sweep.records import read_record
from pydriver.sweep.table import SweepStatus, collect


def _progress(total, initial, enabled):
    if enabled and sys.stderr.isatty():
        try:
            from tqdm import tqdm
            return tqdm(total=total, initial=initial, unit="run", desc="sweep", smoothing=0.1)
        except ImportError:
            pass
    return None


def _tasks(out: Path, manifest: dict, retry_failed: bool) -> tuple[list, list]:
    """``(id, deck, run_dir)`` of the points without a record, and the ids that have one."""
    runs = out / "runs"
    for stale in runs.glob(".*"):
        # Temporary directories of runs killed before finishing; under the lock nothing of
        # this sweep is running (pool workers die with their sweep: lifeline), so they are dead.
        shutil.rmtree(stale, ignore_errors=True)
    tasks, skipped = [], []
    for p in manifest["points"]:
        id_ = p["id"]
        rec = read_record(runs / id_)
        if rec is not None and "error" in rec and retry_failed:
            shutil.rmtree(runs / id_)
            rec = None
        if rec is None:
            tasks.append((id_, out / "decks" / f"{id_}.nml", runs / id_))
        else:
            skipped.append(id_)
    return tasks, skipped


def run_sweep(base, sets: list[str], out, *, jobs: int | None = None, dask: str | None = None,
              progress: bool = True, plots: bool = True, retry_failed: bool = False,
              report: bool = False) -> SweepStatus:
    """Run a grid of decks and aggregate their results into ``DIR/sweep.csv``.

    Parameters
    ----------
    base : str or Path
        Base deck.
    sets : list of str
        ``GROUP.KEY=VALUES`` specs (``GRID_HELP``); several span the Cartesian product.
    out : str or Path
        Sweep directory.  Rerunning into the same directory with the same base deck and
        options resumes: decks with a record are not run again.
    jobs : int, optional
        Worker processes of the local pool (default: the cores this process may use).
    dask : str, optional
        Address of a running Dask scheduler (``tcp://host:8786``): the decks run as Dask
        tasks instead of a local pool.  ``out`` must be on a file system the workers share.
    progress : bool
        Show a tqdm progress bar (only on a terminal).
    plots : bool
        Draw ``DIR/plots/`` after the runs.
    retry_failed : bool
        Run the decks whose record is an error again (e.g. after fixing the cause).
    report : bool
        Also write ``DIR/report.html``.

    Returns
    -------
    SweepStatus

    Raises
    ------
    SweepError
        Bad option, invalid first grid point, another sweep running in ``out``, or ``out``
        holding another sweep.

    Notes
    -----
    Ctrl-C stops the sweep cleanly: decks not started are cancelled, the ones running
    finish, ``sweep.csv`` is written for what finished and ``interrupted`` is set.  A hard
    kill loses at most the decks in flight (the pool's workers die with the sweep); their
    records are simply missing and the next run makes them.
    """
    out = Path(out).resolve()
    with open_sweep(base, sets, out) as manifest:
        tasks, skipped = _tasks(out, manifest, retry_failed)
        lost = {}
        bar = _progress(len(manifest["points"]), len(skipped), progress)

        def done(id_, exc, fut):
            if exc is not None:
                lost[id_] = f"{type(exc).__name__}: {exc}"
            if bar is not None:
                bar.update(1)
        interrupted = False
        try:
            if tasks and dask:
                run_dask(tasks, dask, done)
            elif tasks:
                run_pool(tasks, jobs or default_jobs(), done)
        except KeyboardInterrupt:
            interrupted = True
        finally:
            if bar is not None:
                bar.close()
        status = collect(out, plots=plots, report=report)
    # From the records, not the callbacks: decks that finish while an interrupted pool shuts
    # down count too.
    have = set(skipped) | set(status.missing)
    status.ran = [p["id"] for p in manifest["points"] if p["id"] not in have]
    status.skipped = skipped
    status.interrupted, status.lost = interrupted, lost
    return status
