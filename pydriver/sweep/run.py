"""``run_sweep``: prepare a sweep directory, run its missing decks on an engine, collect."""

from __future__ import annotations

import sys
from pathlib import Path

from pydriver.sweep.directory import open_sweep
from pydriver.sweep.engines import default_jobs, run_dask, run_pool
from pydriver.sweep.errors import SweepError
from pydriver.sweep.faults import not_run_reason
from pydriver.sweep.given_paths import checked_path
from pydriver.sweep.layout import remove_record, remove_stale_records
from pydriver.sweep.records import read_record
from pydriver.sweep.table import SweepStatus, collect_locked

_LOST_SHOWN = 3          # points named in an error message; the rest are counted


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
    # What runs killed before finishing left (pool workers die with their sweep: lifeline);
    # only what is provably theirs goes (pydriver.sweep.layout).
    remove_stale_records(runs, {p["id"] for p in manifest["points"]})
    tasks, skipped = [], []
    for p in manifest["points"]:
        id_ = p["id"]
        rec = read_record(runs / id_)
        if rec is not None and "error" in rec and retry_failed:
            if not remove_record(runs / id_):
                raise SweepError(f"{runs / id_}: cannot remove the record of the failed deck to run it "
                                 "again: it holds files this sweep did not write")
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
        Bad option, invalid first grid point, another sweep running in ``out``, ``out``
        holding another sweep, a path with a control character, or a file of the sweep that
        cannot be written (named, with the reason: e.g. no space left on device).

    Notes
    -----
    Ctrl-C stops the sweep cleanly: decks not started are cancelled, the ones running
    finish, ``sweep.csv`` is written for what finished and ``interrupted`` is set.  A hard
    kill loses at most the decks in flight (the pool's workers die with the sweep); their
    records are simply missing and the next run makes them.  So are those of decks stopped
    by a failure of the machine (a full disk): they are in ``lost`` with the reason.
    """
    out = checked_path(out, "--out", link_ok=False)
    with open_sweep(base, sets, out) as manifest:
        tasks, skipped = _tasks(out, manifest, retry_failed)
        lost = {}
        bar = _progress(len(manifest["points"]), len(skipped), progress)

        def done(id_, exc, fut):
            if exc is not None:
                lost[id_] = not_run_reason(exc)
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
        try:
            status = collect_locked(out, manifest, plots=plots, report=report)
        except SweepError as exc:
            if not lost:
                raise
            # The table could not be written either (the same full disk, usually): say which
            # points did not run, since no status line will.
            shown = "; ".join(f"{i}: {m}" for i, m in list(lost.items())[:_LOST_SHOWN])
            more = f"; ... ({len(lost)} in all)" if len(lost) > _LOST_SHOWN else ""
            raise SweepError(f"{exc}; grid points not run: {shown}{more}") from exc
    # From the records, not the callbacks: decks that finish while an interrupted pool shuts
    # down count too.
    have = set(skipped) | set(status.missing)
    status.ran = [p["id"] for p in manifest["points"] if p["id"] not in have]
    status.skipped = skipped
    status.interrupted, status.lost = interrupted, lost
    return status
