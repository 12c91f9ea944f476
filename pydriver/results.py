"""Reading results back: one row of scalar results per run, and ``load_results(DIR)``.

A sweep directory (``python -m pydriver sweep``) holds ``sweep.json`` (the manifest: base
deck, swept parameters and grid), ``decks/<id>.nml`` and one record per finished deck in
``runs/<id>/``: the files of ``python -m pydriver run`` (``summary.json``, ``table.csv``,
``modes.csv``, ``timeseries.csv``) or ``error.json`` for a deck that failed.  The table of
``sweep.csv`` is built from those records, so this module is shared by the aggregation
(``pydriver.sweep``) and by ``load_results``.
"""

from __future__ import annotations

import csv
import json
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

SOLVER_KEYS_DYNAMIC = ("steps", "residual_evals", "jacobian_evals", "error_test_failures",
                       "convergence_failures")
SOLVER_KEYS_STATIC = ("newton_iterations", "residual_evals", "jacobian_evals", "line_search_cuts")

MANIFEST = "sweep.json"
TABLE = "sweep.csv"

REACTION_COLUMNS = [f"{kind}{side}_{c}" for side in "AB" for kind in "FM" for c in "xyz"]
# Columns present in every sweep.csv (blank where a run does not have the quantity, e.g.
# frequencies of a static run or FB_* of an open chain), so the layout depends only on
# the kind of analysis, not on which runs happened to fail.
RESULT_COLUMNS = (["analysis", "wall_time_s", "max_constraint_violation_m"] + REACTION_COLUMNS
                  + ["f1_hz", "f2_hz", "f3_hz", "f1_damped_hz", "zeta1"])
# Optional columns, included when at least one run has them.
DYNAMIC_COLUMNS = ["energy_drift_rel"]
SOLVER_COLUMNS = [f"solver_{k}" for k in dict.fromkeys(SOLVER_KEYS_STATIC + SOLVER_KEYS_DYNAMIC)]
TEXT_COLUMNS = {"id", "analysis", "error"}


def summary_row(summary: dict) -> dict:
    """Scalar results of one run's ``summary.json``, keyed by ``sweep.csv`` column.

    Parameters
    ----------
    summary : dict
        Content of ``summary.json`` (``pydriver.Result.summary``).

    Returns
    -------
    dict
        ``analysis``, ``wall_time_s``, ``max_constraint_violation_m``, the reactions
        flattened (``FA_x`` ... ``MB_z``, support on chain, world frame), ``f1_hz`` ...
        ``f3_hz`` (lowest undamped frequencies of a modal run), ``f1_damped_hz`` and
        ``zeta1`` (first damped frequency and damping ratio: from the modal analysis, or from
        the decay evaluation of a dynamic run with a pulse), ``energy_drift_rel`` (dynamic)
        and ``solver_<counter>``.  Quantities a run does not have are left out.
    """
    row = {"analysis": summary["analysis"], "wall_time_s": summary["wall_time_s"],
           "max_constraint_violation_m": summary["max_constraint_violation_m"]}
    for side, wrench in summary["reactions"].items():
        for kind in "FM":
            for c, comp in enumerate("xyz"):
                row[f"{kind}{side}_{comp}"] = wrench[kind][c]
    for k, f in enumerate(summary.get("frequencies_hz", [])[:3]):
        row[f"f{k + 1}_hz"] = f
    if summary.get("damped_frequencies_hz"):
        row["f1_damped_hz"] = summary["damped_frequencies_hz"][0]
        row["zeta1"] = summary["damping_ratios"][0]
    elif "decay" in summary:
        row["f1_damped_hz"] = summary["decay"]["f_damped_hz"]
        row["zeta1"] = summary["decay"]["zeta"]
    if "energy_drift_rel" in summary:
        row["energy_drift_rel"] = summary["energy_drift_rel"]
    for k, v in summary.get("solver", {}).items():
        row[f"solver_{k}"] = v
    return row


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


def read_manifest(out) -> dict:
    """The manifest ``DIR/sweep.json`` of a sweep directory."""
    path = Path(out) / MANIFEST
    if not path.is_file():
        raise FileNotFoundError(f"{out}: not a sweep directory (no {MANIFEST})")
    return json.loads(path.read_text())


def sweep_rows(out, manifest: dict) -> tuple[list[str], list[dict]]:
    """Columns and rows (finished runs only, sorted by id) of a sweep's table.

    Parameters
    ----------
    out : str or Path
        Sweep directory.
    manifest : dict
        Its ``sweep.json``.

    Returns
    -------
    columns : list of str
        ``id``, the swept parameters (``group.key``), the result columns, ``error``.
    rows : list of dict
        One per run with a record; values are floats, ints or strings, missing ones absent.
    """
    params = manifest["params"]
    rows = []
    for point in manifest["points"]:
        rec = read_record(Path(out) / "runs" / point["id"])
        if rec is None:
            continue
        row = {"id": point["id"], **dict(zip(params, point["values"]))}
        if "summary" in rec:
            row.update(summary_row(rec["summary"]))
            row["error"] = ""
        else:
            row["error"] = rec["error"]
        rows.append(row)
    present = set().union(*rows) if rows else set()
    columns = (["id"] + params + RESULT_COLUMNS
               + [c for c in DYNAMIC_COLUMNS + SOLVER_COLUMNS if c in present] + ["error"])
    rows.sort(key=lambda r: r["id"])
    return columns, rows


def _cell(v) -> str:
    if v is None:
        return ""
    if isinstance(v, float):
        return repr(v)          # shortest text that round-trips exactly
    return str(v)


def table_csv_text(columns: list[str], rows: list[dict]) -> str:
    """``sweep.csv`` text: a header and one row per run; blank cells for missing values.

    Written with the csv module because error messages contain commas and quotes.
    """
    import io
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(columns)
    for r in rows:
        w.writerow([_cell(r.get(c)) for c in columns])
    return buf.getvalue()


def _number(text: str) -> float | None:
    """A namelist number as float (Fortran ``1.0d-3`` exponents too); None if not one."""
    try:
        return float(text.strip().lower().replace("d", "e"))
    except ValueError:
        return None


def rows_to_table(columns: list[str], rows: list[dict], params=()) -> dict:
    """Column arrays: float for numeric columns (NaN where blank), str for text ones.

    A swept parameter is float when every one of its values is a number, else str.
    """
    table = {}
    for c in columns:
        vals = [r.get(c) for r in rows]
        if c in TEXT_COLUMNS:
            table[c] = np.array(["" if v is None else str(v) for v in vals], dtype=str)
        elif c in params:
            nums = [_number(str(v)) for v in vals]
            table[c] = (np.array(nums, dtype=float) if all(x is not None for x in nums)
                        else np.array([str(v) for v in vals], dtype=str))
        else:
            table[c] = np.array([math.nan if v in (None, "") else float(v) for v in vals], dtype=float)
    return table


def _read_columns(path: Path, ints=()) -> dict | None:
    if not path.is_file():
        return None
    with path.open() as fh:
        names = fh.readline().strip().split(",")
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
