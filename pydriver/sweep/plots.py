"""Plots of a sweep: ``DIR/plots/<result>_vs_<parameter>.png``, one per main result and
swept parameter, one line per combination of the other parameters."""

from __future__ import annotations

import io
import re
from pathlib import Path

import numpy as np

from pydriver.sweep.columns import REACTION_COLUMNS
from pydriver.sweep.layout import write_file

PLOT_RESULTS = ["f1_hz", "f1_damped_hz", "zeta1"] + REACTION_COLUMNS


def axis_label(name: str) -> str:
    """A sweep column or deck key with its unit in brackets (legible plots: units on every axis)."""
    from pydriver.schema import lookup
    base = re.sub(r"\(\d+\)$", "", name)
    if "." in base:
        key = lookup(*base.split(".", 1))
        unit = key.unit if key is not None else "-"
        return f"{name} [{unit}]"
    for prefix, unit in (("F", "N"), ("M", "Nm")):
        if re.fullmatch(prefix + r"[AB]_[xyz]", name):
            return f"{name} [{unit}]"
    if name.endswith("_hz"):
        return f"{name[:-3]} [Hz]"
    if name.endswith("_m"):
        return f"{name[:-2]} [m]"
    if name.endswith("_s"):
        return f"{name[:-2]} [s]"
    return f"{name} [-]"


def plot_sweep(out, table: dict, params: list, scales: dict) -> list[Path]:
    """Draw the plots of a sweep into ``out/plots/`` (each file written atomically, and listed
    in the sweep's marker first: :func:`pydriver.sweep.layout.write_file`; under its lock).

    Parameters
    ----------
    out : Path
        Sweep directory.
    table : dict of numpy arrays
        The ``sweep.csv`` columns (:func:`pydriver.sweep.table.rows_to_table`).
    params : list of str
        Swept parameters; those with non-numeric values get no plot.
    scales : dict
        Parameter -> ``"log"`` (log x axis) or ``"linear"``.

    Returns
    -------
    list of Path
        The files written.
    """
    from pydriver.plots import _plt  # the project's matplotlib set-up (Agg backend)
    plt = _plt()
    plots = Path(out) / "plots"
    plots.mkdir(exist_ok=True)
    ok = table["error"] == ""
    written = []
    for p in params:
        x = table[p]
        if x.dtype.kind != "f":
            continue                                    # non-numeric parameter (strings)
        others = [q for q in params if q != p]
        labels = [tuple(str(table[q][i]) for q in others) for i in range(len(x))]
        groups = sorted(set(labels))
        for name in PLOT_RESULTS:
            y = table.get(name)
            if y is None or not np.any(np.isfinite(y[ok])):
                continue
            fig, ax = plt.subplots(figsize=(7.5, 4), constrained_layout=True)
            for g in groups:
                sel = ok & np.array([lab == g for lab in labels], dtype=bool)
                order = np.argsort(x[sel])
                label = ", ".join(f"{q} = {v}" for q, v in zip(others, g)) or None
                ax.plot(x[sel][order], y[sel][order], "o-", ms=3, label=label)
            if scales.get(p) == "log":
                ax.set_xscale("log")
            ax.set_xlabel(axis_label(p))
            ax.set_ylabel(axis_label(name))
            ax.grid(True)
            if others and len(groups) <= 8:
                ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))   # beside: covers no point
            fig.suptitle(f"{name} against {p}", fontsize=10)
            png = io.BytesIO()
            fig.savefig(png, format="png", dpi=110)
            plt.close(fig)
            # File names without the parentheses of element keys (loads.gravity(3)).
            final = re.sub(r"[^\w.-]", "_", f"{name}_vs_{p}") + ".png"
            written.append(write_file(out, f"plots/{final}", png.getvalue()))
    return written
