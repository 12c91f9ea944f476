"""The table of a sweep, ``DIR/sweep.csv``: one row of scalar results per record.

The table is rebuilt from the records every time (:func:`collect`, and
:func:`pydriver.load_results` for Python), so it always holds exactly one row per finished
deck, sorted by id, whatever was interrupted or run twice.
"""

from __future__ import annotations

import csv
import io
import math
import shlex
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from pydriver.sweep.columns import (
    DYNAMIC_COLUMNS,
    RESULT_COLUMNS,
    SOLVER_COLUMNS,
    TEXT_COLUMNS,
)
from pydriver.sweep.errors import SweepError
from pydriver.sweep.faults import writing
from pydriver.sweep.given_paths import checked_path
from pydriver.sweep.layout import check_sweep_directory, existing_manifest, write_file
from pydriver.sweep.lock import hold_lock
from pydriver.sweep.plots import plot_sweep
from pydriver.sweep.records import read_manifest, read_record
from pydriver.sweep.report import sweep_report_html

TABLE = "sweep.csv"


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
    elif "f_damped_hz" in summary.get("decay", {}):       # a run too short for a decay has none
        row["f1_damped_hz"] = summary["decay"]["f_damped_hz"]
        if "zeta" in summary["decay"]:
            row["zeta1"] = summary["decay"]["zeta"]
    if "energy_drift_rel" in summary:
        row["energy_drift_rel"] = summary["energy_drift_rel"]
    for k, v in summary.get("solver", {}).items():
        row[f"solver_{k}"] = v
    return row


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


def sweep_header(columns: list[str]) -> list[str]:
    """The header cells of ``sweep.csv``: every column with its unit in brackets (a swept key's
    from the deck schema, the results' from ``pydriver/output_columns.py``)."""
    from pydriver.output_columns import header
    from pydriver.schema import lookup
    units = {}
    for c in columns:
        group, _, key = c.partition(".")
        k = lookup(group, key.split("(")[0]) if key else None
        if k is not None:
            units[c] = k.unit
    return header("sweep.csv", columns, units)


def table_csv_text(columns: list[str], rows: list[dict]) -> str:
    """``sweep.csv`` text: a header and one row per run; blank cells for missing values.

    Written with the csv module because error messages contain commas and quotes.
    """
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(sweep_header(columns))
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


@dataclass
class SweepStatus:
    """Outcome of ``run_sweep`` / ``collect``.

    Attributes
    ----------
    out : Path
        Sweep directory.
    n_points : int
        Grid size.
    ran : list of str
        Ids run by this call.
    skipped : list of str
        Ids that had a record already (resume).
    failed : list of str
        Ids whose record is an error (``error`` column of sweep.csv).
    missing : list of str
        Ids without a record (interrupted, lost worker, not yet run).
    interrupted : bool
        The run was stopped by Ctrl-C; rerun the same command to resume.
    lost : dict
        Id -> message for tasks the engine lost (worker crash), not deck failures.
    """

    out: Path
    n_points: int
    ran: list = field(default_factory=list)
    skipped: list = field(default_factory=list)
    failed: list = field(default_factory=list)
    missing: list = field(default_factory=list)
    interrupted: bool = False
    lost: dict = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        """Every grid point has a record and none failed."""
        return not (self.failed or self.missing)

    def line(self) -> str:
        """One-line report."""
        n_ok = self.n_points - len(self.failed) - len(self.missing)
        s = (f"sweep {self.out}: {self.n_points} points, {n_ok} ok, {len(self.failed)} failed, "
             f"{len(self.missing)} missing")
        if self.ran or self.skipped:
            s += f" ({len(self.ran)} run now, {len(self.skipped)} done before)"
        s += f" -> {self.out / TABLE}"
        if self.interrupted:
            s += "; interrupted: rerun the same command to resume"
        elif self.missing:
            s += "; rerun the sweep to run the missing ones"
        return s


def collect(out, plots: bool = True, report: bool = False) -> SweepStatus:
    """Aggregate the records of a sweep into ``DIR/sweep.csv`` (and plots).

    Parameters
    ----------
    out : str or Path
        Sweep directory.
    plots : bool
        Also draw ``DIR/plots/<result>_vs_<parameter>.png`` (matplotlib).
    report : bool
        Also write ``DIR/report.html`` (one self-contained page: grid, table, plots).

    Returns
    -------
    SweepStatus
        With ``failed`` and ``missing`` filled in.

    Raises
    ------
    SweepError
        ``out`` with a control character, a usage spectrum in ``out`` (combined by ``rotorcable
        spectrum``), a sweep running in ``out`` (it collects itself),
        ``out`` holding anything but its sweep (named: :mod:`pydriver.sweep.layout`), or
        ``sweep.csv``, a plot or the report that cannot be written (named, with the reason:
        e.g. no space left on device).  A file that cannot be written is left as it was,
        whole (:func:`pydriver.sweep.files.write_atomic`).

    Notes
    -----
    ``sweep.csv`` is rebuilt from ``runs/*`` each time and replaced atomically, so it always
    holds exactly one row per finished run, sorted by id.  Safe to run while tasks are still
    running (e.g. a Slurm array): it shows what has finished.
    """
    out = checked_path(out, "sweep directory", link_ok=False)
    check_sweep_directory(out, existing_manifest(out), "sweep directory")   # names what is there
    manifest = read_manifest(out)
    if manifest.get("maker", "run") != "run":
        # A usage spectrum's records are regimes, combined into its life (pydriver/sweep/spectrum.py).
        raise SweepError(f"{out} holds a usage spectrum, not a sweep: its records are combined by "
                         f"`rotorcable spectrum {shlex.quote(str(manifest['base_deck']))} --out {shlex.quote(str(out))}`")
    with hold_lock(out):
        check_sweep_directory(out, manifest, "sweep directory")       # again, under the lock
        return collect_locked(out, manifest, plots, report)


def collect_locked(out: Path, manifest: dict, plots: bool = True, report: bool = False) -> SweepStatus:
    """:func:`collect` for a caller that holds the sweep's lock and has checked its directory."""
    columns, rows = sweep_rows(out, manifest)
    # The records stay whatever fails here; the table, plots and report are made from them.
    hint = (f" (the records in {out / 'runs'} are kept: once fixed, run "
            f"`python -m pydriver sweep-collect {shlex.quote(str(out))}`)")
    with writing(out / TABLE, hint):
        write_file(out, TABLE, table_csv_text(columns, rows))
    done = {r["id"] for r in rows}
    status = SweepStatus(out=out, n_points=len(manifest["points"]),
                         failed=[r["id"] for r in rows if r["error"]],
                         missing=[p["id"] for p in manifest["points"] if p["id"] not in done])
    if plots and rows:
        with writing(out / "plots", hint):
            plot_sweep(out, rows_to_table(columns, rows, manifest["params"]), manifest["params"],
                       manifest.get("scales", {}))
    if report:
        with writing(out / "report.html", hint):
            write_file(out, "report.html", sweep_report_html(out, manifest, columns, rows, status))
    return status
