"""Result files: summary.json, table.txt/.csv (thesis appendix layout), timeseries.csv.

Every file is first written under a temporary name in the target directory and renamed
once all of them exist, so a failure leaves no partial output behind.
"""

from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path

import numpy as np


def format_table(result) -> str:
    """The equilibrium table in the layout of the thesis's Tables A.3-A.6.

    Columns: Körper, gamma_i [°], beta_i [°] (2 decimals), x, y, z [m] (4 decimals), and a
    caption line with the case and the bending spring c_y (German decimal comma as printed).
    """
    s = result.summary
    t = result.table
    lines = [f"{'Körper':>6}  {'γ_i [°]':>8}  {'β_i [°]':>8}  {'x [m]':>8}  {'y [m]':>8}  {'z [m]':>8}"]
    for i in range(len(t["body"])):
        lines.append(f"{int(t['body'][i]):>6}  {t['gamma_deg'][i]:8.2f}  {t['beta_deg'][i]:8.2f}  "
                     f"{t['x_m'][i]:8.4f}  {t['y_m'][i]:8.4f}  {t['z_m'][i]:8.4f}")
    cy = f"{s.get('c_beta_Nm_per_rad', 0.0):.2f}".replace(".", ",")
    lines.append("")
    what = "Ruhelage" if "hover" in s["case"] else "Statische Ruhelage"
    lines.append(f"Tabelle: {what} {s['case']}, c_y = {cy} Nm/rad")
    return "\n".join(lines) + "\n"


def _csv(columns: dict) -> str:
    names = list(columns)
    data = np.column_stack([np.asarray(columns[n], dtype=float) for n in names])
    rows = [",".join(names)]
    for r in data:
        rows.append(",".join(repr(float(x)) for x in r))
    return "\n".join(rows) + "\n"


def table_csv(table: dict) -> str:
    names = ["body", "gamma_deg", "beta_deg", "x_m", "y_m", "z_m"]
    rows = [",".join(names)]
    for i in range(len(table["body"])):
        rows.append(",".join([str(int(table["body"][i]))]
                             + [repr(float(table[n][i])) for n in names[1:]]))
    return "\n".join(rows) + "\n"


def write_result(result, out: Path, plots: bool = False) -> list[Path]:
    """Write all files of a result into ``out`` atomically; return the final paths."""
    files: dict[str, str] = {"summary.json": json.dumps(result.summary, indent=2) + "\n"}
    if result.table is not None:
        files["table.txt"] = format_table(result)
        files["table.csv"] = table_csv(result.table)
    if result.timeseries is not None:
        files["timeseries.csv"] = _csv(result.timeseries)
    if "modes" in result.extra:
        files["modes.csv"] = _csv(result.extra["modes"])
    out.mkdir(parents=True, exist_ok=True)
    staged: list[tuple[str, Path]] = []
    try:
        for name, text in files.items():
            fd, tmp = tempfile.mkstemp(prefix=f".{name}.", dir=out)
            with os.fdopen(fd, "w", encoding="utf-8") as fh:
                fh.write(text)
            staged.append((tmp, out / name))
        if plots:
            from pydriver.plots import plot_result
            for tmp, final in plot_result(result, out):
                staged.append((tmp, final))
    except BaseException:
        for tmp, _ in staged:
            Path(tmp).unlink(missing_ok=True)
        raise
    for tmp, final in staged:
        os.replace(tmp, final)
    return [final for _, final in staged]
