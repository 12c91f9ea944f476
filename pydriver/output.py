"""Result files: summary.json, table.txt/.csv (thesis appendix layout), timeseries.csv or
timeseries.h5, modes.csv; all of one run in one directory, complete or not at all.

A run writes into a temporary sibling directory and swaps it into place when everything is
written (:class:`pydriver.run_directory.RunDirectory`, which also refuses any directory that
is not empty or one earlier run's).  Time series are streamed in chunks (:class:`TimeseriesWriter`), never
built as one text in memory; large ones go to HDF5 (h5py), which every analysis tool reads.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np

from pydriver.netcdf_layout import NetcdfTimeseries, is_netcdf_layout, read_columns
from pydriver.output_columns import bare_name, header
from pydriver.run_directory import RunDirectory

#: Time series with more values than this go to HDF5 when the deck asks for 'auto'.
CSV_MAX_VALUES = 5_000_000


def _fmt(x: float) -> str:
    return repr(float(x))


class TimeseriesWriter:
    """Streams time-series rows (chunks of columns) to CSV or HDF5."""

    def __init__(self, path: Path, columns: list[str], fmt: str):
        self.columns = columns
        self.fmt = fmt
        self.path = path
        self.rows = 0
        if fmt == "hdf5":
            # netCDF4 layout (dimensions time, body, joint, component): xarray opens it.
            n_bodies = sum(1 for c in columns if re.fullmatch(r"x\d+", c))
            self._nc = NetcdfTimeseries(path, columns, n_bodies)
        else:
            self._fh = open(path, "w", encoding="utf-8", newline="\n")
            self._fh.write(",".join(header("timeseries.csv", columns)) + "\n")

    def write(self, chunk: dict):
        n = len(chunk[self.columns[0]])
        if self.fmt == "hdf5":
            self._nc.write(chunk)
        else:
            data = np.column_stack([np.asarray(chunk[c], float) for c in self.columns])
            self._fh.write("".join(",".join(map(_fmt, row)) + "\n" for row in data))
        self.rows += n

    def close(self):
        if self.fmt == "hdf5":
            self._nc.close()
        else:
            self._fh.close()


def read_timeseries(path: Path) -> dict:
    """The columns of a timeseries.csv or timeseries.h5 as numpy arrays."""
    path = Path(path)
    if path.suffix == ".h5":
        import h5py
        with h5py.File(path, "r") as h5:
            if is_netcdf_layout(h5):
                return read_columns(h5)
            return {c: h5[c][:] for c in json.loads(h5.attrs["columns"])}     # one dataset per column
    return read_csv(path)


def read_csv(path: Path) -> dict:
    """The columns of a CSV file written here (numbers only)."""
    with open(path, encoding="utf-8") as fh:
        names = [bare_name(c) for c in fh.readline().strip().split(",")]
        data = np.loadtxt(fh, delimiter=",", ndmin=2) if names != [""] else np.zeros((0, 0))
    if data.size == 0:
        return {n: np.zeros(0) for n in names}
    return {n: data[:, i] for i, n in enumerate(names)}


def format_table(result, language: str = "en") -> str:
    """The equilibrium table in the layout of the thesis's Tables A.3-A.6.

    Columns: body, gamma_i [deg], beta_i [deg] (2 decimals), x, y, z [m] (4 decimals), and a
    caption line with the case and the bending spring c_beta (the thesis's c_y).  ``language = 'de'`` gives the
    thesis's own German form with decimal commas (Körper, γ_i [°], "Tabelle: Ruhelage ...").
    """
    s = result.summary
    t = result.table
    german = language == "de"
    names = ("Körper", "γ_i [°]", "β_i [°]") if german else ("body", "gamma_i [deg]", "beta_i [deg]")
    lines = [f"{names[0]:>6}  {names[1]:>13}  {names[2]:>13}  {'x [m]':>8}  {'y [m]':>8}  {'z [m]':>8}"]
    for i in range(len(t["body"])):
        row = (f"{int(t['body'][i]):>6}  {t['gamma_deg'][i]:13.2f}  {t['beta_deg'][i]:13.2f}  "
               f"{t['x_m'][i]:8.4f}  {t['y_m'][i]:8.4f}  {t['z_m'][i]:8.4f}")
        lines.append(row.replace(".", ",") if german else row)
    cy = f"{s.get('c_beta_Nm_per_rad', 0.0):.2f}"
    lines.append("")
    hover = "hover" in s["case"]
    if german:
        what = "Ruhelage" if hover else "Statische Ruhelage"
        lines.append(f"Tabelle: {what} {s['case']}, c_y = {cy.replace('.', ',')} Nm/rad")
    else:
        what = "equilibrium in hover" if hover else "static equilibrium"
        # The deck's name of the bending spring (the German form keeps the thesis's c_y).
        lines.append(f"Table: {what}, {s['case']}, c_beta = {cy} Nm/rad")
    return "\n".join(lines) + "\n"


def _cell(value, integer: bool) -> str:
    """One CSV cell; None (e.g. the life of a joint that takes no damage) is an empty cell."""
    if value is None or (isinstance(value, (float, np.floating)) and not np.isfinite(value)):
        return ""                      # not defined here (docs/outputs.md): never 'nan' in a file
    if isinstance(value, str):                     # a name: quoted as RFC 4180 wants
        return '"' + value.replace('"', '""') + '"' if any(c in value for c in ',"\n') else value
    return str(int(value)) if integer else _fmt(value)


#: Columns written as integers (a body, mode or joint number, a design iteration, its pass and mode).
INT_COLUMNS = ("body", "mode", "joint", "iteration", "pass", "margin_mode")


def csv_text(name: str, columns: dict, int_columns=INT_COLUMNS, units: dict | None = None) -> str:
    """The text of the table ``name`` (a file name of ``pydriver/output_columns.py``) with its
    units in the header."""
    names = list(columns)
    lines = [",".join(header(name, names, units))]
    n = len(columns[names[0]]) if names else 0
    for i in range(n):
        lines.append(",".join(_cell(columns[c][i], c in int_columns) for c in names))
    return "\n".join(lines) + "\n"


def _write_csv(path: Path, columns: dict, int_columns=INT_COLUMNS, units: dict | None = None):
    """A table with its units in the header (``pydriver/output_columns.py``)."""
    with open(path, "w", encoding="utf-8", newline="\n") as fh:
        fh.write(csv_text(path.name, columns, int_columns, units))


def write_files(result, run_dir: RunDirectory, plots: bool = False, table_language: str = "en") -> None:
    """Write every file of a result into the run directory (before commit); summary.json last,
    so that wherever it exists the run's other files do too."""
    if result.table is not None:
        run_dir.path("table.txt").write_text(format_table(result, table_language), encoding="utf-8")
        _write_csv(run_dir.path("table.csv"), result.table)
        result.files["table.txt"] = run_dir.out / "table.txt"
        result.files["table.csv"] = run_dir.out / "table.csv"
    if result.timeseries is not None and not run_dir.path("timeseries.csv").exists() \
            and not run_dir.path("timeseries.h5").exists():
        writer = TimeseriesWriter(run_dir.path("timeseries.csv"), list(result.timeseries), "csv")
        writer.write(result.timeseries)
        writer.close()
        result.files["timeseries.csv"] = run_dir.out / "timeseries.csv"
    if result.modes is not None:
        _write_csv(run_dir.path("modes.csv"), result.modes)
        result.files["modes.csv"] = run_dir.out / "modes.csv"
    units = dict(result.extra.get("units", {}))
    if "fatigue" in result.summary:            # the DEL is in the unit of the S-N curve's quantity
        units.setdefault("fatigue.csv", {"del_amplitude": result.summary["fatigue"].get("unit", "-")})
    for name, columns in result.extra.get("tables", {}).items():
        _write_csv(run_dir.path(name), columns, units=units.get(name))
        result.files[name] = run_dir.out / name
    for name, text in result.extra.get("texts", {}).items():       # a written deck (optimum.nml)
        run_dir.path(name).write_text(text, encoding="utf-8")
        result.files[name] = run_dir.out / name
    if plots:
        from pydriver.plots import plot_result
        for name in plot_result(result, run_dir.tmp):
            result.files[name] = run_dir.out / name
    (run_dir.path("summary.json")).write_text(json.dumps(result.summary, indent=2, allow_nan=False) + "\n",
                                              encoding="utf-8")
    result.files["summary.json"] = run_dir.out / "summary.json"
