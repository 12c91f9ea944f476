"""Reading results back for post-processing: ``load_results(DIR)``.

A sweep directory (``python -m pydriver sweep``) holds ``sweep.json`` (the manifest: base
deck, swept parameters and grid), ``decks/<id>.nml`` and one record per finished deck in
``runs/<id>/``: the files of ``python -m pydriver run`` (``summary.json``, ``table.csv``,
``modes.csv``, ``timeseries.csv``) or ``error.json`` for a deck that failed.  The table is
built from those records exactly as ``sweep.csv`` is (:mod:`pydriver.sweep.table`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from pydriver.output_columns import bare_name

# The table of a sweep and its records are the sweep package's; their names stay importable
# from here, where they were first defined.
from pydriver.sweep.columns import (
    DYNAMIC_COLUMNS,
    REACTION_COLUMNS,
    RESULT_COLUMNS,
    SOLVER_COLUMNS,
    SOLVER_KEYS_DYNAMIC,
    SOLVER_KEYS_STATIC,
    TEXT_COLUMNS,
)
from pydriver.sweep.records import MANIFEST, read_manifest, read_record
from pydriver.sweep.table import (
    TABLE,
    rows_to_table,
    summary_row,
    sweep_rows,
    table_csv_text,
)

__all__ = ["DYNAMIC_COLUMNS", "MANIFEST", "REACTION_COLUMNS", "RESULT_COLUMNS", "SOLVER_COLUMNS",
           "SOLVER_KEYS_DYNAMIC", "SOLVER_KEYS_STATIC", "TABLE", "TEXT_COLUMNS", "RunResult",
           "SweepResults", "load_results", "load_run", "read_manifest", "read_record",
           "rows_to_table", "summary_row", "sweep_rows", "table_csv_text"]


def _read_columns(path: Path, ints=()) -> dict | None:
    if not path.is_file():
        return None
    with path.open() as fh:
        names = [bare_name(c) for c in fh.readline().strip().split(",")]
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    return {n: (data[:, i].astype(int) if n in ints else data[:, i]) for i, n in enumerate(names)}


@dataclass
class RunResult:
    """One run of a sweep, read back from ``runs/<id>/``.

    Attributes
    ----------
    id : str
        Run id (``0000``, ``0001``, ...).
    path : Path
        The run directory.
    params : dict
        Swept parameter -> namelist value text of this run.
    summary : dict or None
        ``summary.json``; None for a failed run.
    error : str or None
        Error message of a failed run (``DeckError: ...``, ``RunError: ...``).
    table : dict of numpy arrays or None
        ``table.csv`` (equilibrium shape), as in ``pydriver.Result``.
    timeseries : dict of numpy arrays or None
        ``timeseries.csv`` (dynamic runs).
    modes : dict of numpy arrays or None
        ``modes.csv`` (modal runs: frequencies, damping ratios, CM mode shapes).
    """

    id: str
    path: Path
    params: dict
    summary: dict | None = None
    error: str | None = None
    table: dict | None = None
    timeseries: dict | None = None
    modes: dict | None = None

    @property
    def ok(self) -> bool:
        """True when the run finished without error."""
        return self.error is None


def load_run(run_dir, id: str | None = None, params: dict | None = None) -> RunResult | None:
    """Read one run directory (a sweep's ``runs/<id>/`` or a ``pydriver run --out`` one).

    Returns None when the run has no record yet.
    """
    run_dir = Path(run_dir)
    rec = read_record(run_dir)
    if rec is None:
        return None
    run = RunResult(id=id or run_dir.name, path=run_dir, params=dict(params or {}),
                    summary=rec.get("summary"), error=rec.get("error"))
    if run.ok:
        run.table = _read_columns(run_dir / "table.csv", ints=("body",))
        run.timeseries = _read_columns(run_dir / "timeseries.csv")
        if run.timeseries is None and (run_dir / "timeseries.h5").is_file():
            # A large run streamed its time series to HDF5 (&solver output_format).
            from pydriver.output import read_timeseries
            run.timeseries = read_timeseries(run_dir / "timeseries.h5")
        run.modes = _read_columns(run_dir / "modes.csv", ints=("mode",))
    return run


class _Runs(Mapping):
    """id -> RunResult, read from disk on first access (a sweep may hold thousands of runs
    with long time series; reading them all up front would be slow and memory hungry)."""

    def __init__(self, out: Path, ids: list[str], params: dict):
        self._out, self._ids, self._params, self._cache = out, ids, params, {}

    def __getitem__(self, id_):
        if id_ not in self._cache:
            if id_ not in self._params:
                raise KeyError(id_)
            run = load_run(self._out / "runs" / id_, id_, self._params[id_])
            if run is None:
                raise KeyError(id_)
            self._cache[id_] = run
        return self._cache[id_]

    def __iter__(self):
        return iter(self._ids)

    def __len__(self):
        return len(self._ids)


@dataclass
class SweepResults:
    """What ``load_results`` returns.

    Attributes
    ----------
    path : Path
        The sweep (or single run) directory.
    params : list of str
        Swept parameters (``group.key``), the table's parameter columns.
    table : dict of numpy arrays
        The ``sweep.csv`` columns, one entry per finished run, sorted by id: ``id``,
        ``analysis`` and ``error`` as str arrays (``error`` empty when ok), parameters as
        float (str if not numeric), results as float with NaN where a run has no value.
    runs : Mapping of str to RunResult
        Every finished run by id, its files read when first accessed.
    missing : list of str
        Ids of the grid that have no record yet (interrupted or still running).
    manifest : dict
        ``sweep.json`` (empty for a single run directory).
    """

    path: Path
    params: list
    table: dict
    runs: Mapping
    missing: list = field(default_factory=list)
    manifest: dict = field(default_factory=dict)


def load_results(path) -> SweepResults:
    """Load a sweep directory (or a single run directory) for post-processing.

    Parameters
    ----------
    path : str or Path
        Output directory of ``python -m pydriver sweep`` / ``pydriver.run_sweep``; a
        directory written by ``pydriver run --out`` (one ``summary.json``) also works and
        gives a one-row table without parameter columns.

    Returns
    -------
    SweepResults
        ``.table`` (the ``sweep.csv`` columns as numpy arrays) and ``.runs`` (id ->
        ``RunResult`` with ``.summary``, ``.table``, ``.timeseries``, ``.modes``).

    Raises
    ------
    FileNotFoundError
        If ``path`` is neither a sweep nor a run directory.

    Notes
    -----
    The table is rebuilt from the per-run records, exactly as ``sweep.csv`` is, so it is
    complete even when ``sweep.csv`` has not been written yet (e.g. while a Slurm array is
    still running).

    Examples
    --------
    >>> res = pydriver.load_results("results/cy_sweep")
    >>> res.table["springs.c_beta"], res.table["f1_damped_hz"]
    >>> res.runs["0003"].modes["f_damped_hz"]
    """
    path = Path(path)
    if not (path / MANIFEST).is_file():
        run = load_run(path)
        if run is None:
            raise FileNotFoundError(f"{path}: neither a sweep directory ({MANIFEST}) nor a run "
                                    f"directory (summary.json / error.json)")
        row = {"id": run.id, "error": run.error or ""}
        if run.ok:
            row.update(summary_row(run.summary))
        columns = ["id"] + RESULT_COLUMNS + [c for c in DYNAMIC_COLUMNS + SOLVER_COLUMNS
                                             if c in row] + ["error"]
        return SweepResults(path=path, params=[], table=rows_to_table(columns, [row]),
                            runs={run.id: run})
    manifest = read_manifest(path)
    params = manifest["params"]
    columns, rows = sweep_rows(path, manifest)
    values = {p["id"]: dict(zip(params, p["values"])) for p in manifest["points"]}
    done = [r["id"] for r in rows]
    missing = sorted(set(values) - set(done))
    return SweepResults(path=path, params=list(params), table=rows_to_table(columns, rows, params),
                        runs=_Runs(path, done, values), missing=missing, manifest=manifest)
