"""Parameter sweeps: a grid of decks from one base deck, run locally or on a cluster.

Layout of a sweep directory ``DIR``::

    DIR/sweep.json         manifest: base deck (and its SHA-256), the --set specs, the grid
    DIR/.rotorcable-run.json  marker (kind "sweep"): the files the sweep wrote itself
    DIR/.sweep.lock        held by the sweep writing, running or collecting in DIR (flock)
    DIR/decks/<id>.nml     one plain deck per grid point (re-runnable alone)
    DIR/runs/<id>/         the record of a finished deck: the files of `pydriver run`
                           (summary.json, table.csv, modes.csv, ...) or error.json
    DIR/sweep.csv          one row per record, sorted by id (rebuilt from runs/ every time)
    DIR/plots/             <result>_vs_<parameter>.png

A record appears in one step (the run writes into a hidden temporary directory that is
renamed to ``runs/<id>`` when complete), so a sweep killed at any moment leaves either a
whole record or none; a rerun skips the ids that have a record and ``sweep.csv`` is rebuilt
from the records, so no row can be lost or duplicated.

Execution engines: a local process pool (default, one deck per task), a running Dask
scheduler (``dask=ADDRESS``, e.g. started with dask-jobqueue on Slurm/PBS), or a Slurm job
array script (``write_slurm``).  All three call the same per-deck function, ``run_task``.

A deck that fails is a record (``error.json``); a failure of the machine (a full disk, no
memory) is not: the point stays without a record, is reported as not run with the reason, and
the next run of the sweep runs it.  Paths with a control character are refused before anything
is written.

A sweep writes only into a new or empty directory or its own (:mod:`~pydriver.sweep.layout`,
the rule of :mod:`pydriver.ownership`); anything else is refused before anything is written.

Modules: :mod:`~pydriver.sweep.grid` (the ``--set`` syntax and grid, checked by the deck
schema), :mod:`~pydriver.sweep.layout` (what a sweep directory may hold, the marker),
:mod:`~pydriver.sweep.lock` (one sweep at a time), :mod:`~pydriver.sweep.directory` (manifest,
decks), :mod:`~pydriver.sweep.records`
(one deck's record), :mod:`~pydriver.sweep.table` (``sweep.csv``), :mod:`~pydriver.sweep.plots`,
:mod:`~pydriver.sweep.engines` (pool, Dask, Slurm), :mod:`~pydriver.sweep.lifeline` (pool
processes die with the sweep),
:mod:`~pydriver.sweep.faults` (failures of the machine), :mod:`~pydriver.sweep.given_paths`
(paths refused), :mod:`~pydriver.sweep.files` (files written whole),
:mod:`~pydriver.sweep.run` (``run_sweep``), :mod:`~pydriver.sweep.spectrum` (a usage spectrum's
regimes as the points of a sweep directory, ``rotorcable spectrum``).
"""

from pydriver.sweep.directory import open_sweep, prepare
from pydriver.sweep.engines import default_jobs, write_slurm
from pydriver.sweep.errors import SweepError
from pydriver.sweep.grid import GRID_HELP, expand_grid, parse_set
from pydriver.sweep.records import (
    MANIFEST,
    read_manifest,
    read_record,
    run_point,
    run_task,
)
from pydriver.sweep.run import run_sweep
from pydriver.sweep.table import TABLE, SweepStatus, collect

__all__ = ["GRID_HELP", "MANIFEST", "TABLE", "SweepError", "SweepStatus", "collect", "default_jobs",
           "expand_grid", "open_sweep", "parse_set", "prepare", "read_manifest", "read_record",
           "run_point", "run_sweep", "run_task", "write_slurm"]
