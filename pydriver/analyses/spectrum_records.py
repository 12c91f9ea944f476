"""One regime of a usage spectrum, run: what the spectrum's combination needs of it, in memory
or as the record of a spectrum directory.

What a regime (or the run-up) gives the combination (:mod:`pydriver.analyses.spectrum_damage`)
is small: at every refinement level, every jacket point's damage per record and per hour, the
damage of its closed cycles, its smallest, largest and first value
(:class:`pydriver.analyses.fatigue_loads.JacketPoints`), and the finest level's summary (peaks,
warnings, the regime's own refinement).  :func:`regime_result` runs a regime's deck in this
process; :func:`write_record` is the task a sweep engine runs for one regime
(:func:`pydriver.sweep.records.run_task` with the maker ``"spectrum"``): it writes the run's
``summary.json``, ``fatigue.csv``, ``refinement.csv`` and the points of every level,
``fatigue_points.csv`` (no time series: a spectrum of 20 regimes at n = 44 would keep 20 of
them), and :func:`read_record` reads them back, exactly (every number written with ``repr``).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pydriver.analyses.fatigue_loads import JacketPoints

#: The record's table of every level's jacket points.
POINTS_FILE = "fatigue_points.csv"
_COLUMNS = ("n_bodies", "joint", "angle_deg", "damage_per_record", "closed_damage_per_record", "minimum",
            "maximum", "first", "records_per_hour")


@dataclass
class RegimeRun:
    """A regime's (or the run-up's) run, as the combination needs it."""

    ns: list                  #: the levels' numbers of bodies, coarse to fine
    levels: list              #: JacketPoints per level
    summary: dict             #: the finest level's summary (with the regime's refinement)


def of_result(result) -> RegimeRun:
    """The :class:`RegimeRun` of a finished run (refined or not) of a deck with ``&fatigue``."""
    levels = result.extra.get("fatigue_points_levels") or [result.extra["fatigue_points"]]
    return RegimeRun(ns=[int(lv.joint.max()) for lv in levels], levels=list(levels), summary=result.summary)


def points_table(run: RegimeRun) -> dict:
    """``fatigue_points.csv``: one row per level and jacket point."""
    cols = {name: [] for name in _COLUMNS}
    for n, lv in zip(run.ns, run.levels):
        size = lv.joint.size
        cols["n_bodies"].append(np.full(size, n))
        cols["joint"].append(lv.joint)
        cols["angle_deg"].append(lv.angle_deg)
        for name in ("damage_per_record", "closed_damage_per_record", "minimum", "maximum", "first"):
            cols[name].append(getattr(lv, name))
        cols["records_per_hour"].append(np.full(size, lv.per_hour))
    return {name: np.concatenate(parts).tolist() for name, parts in cols.items()}


def levels_of_table(columns: dict) -> tuple[list, list]:
    """(ns, JacketPoints per level) of a ``fatigue_points.csv`` read back."""
    n = np.asarray(columns["n_bodies"], float).astype(int)
    ns, levels = [], []
    for value in dict.fromkeys(n.tolist()):
        rows = n == value
        ns.append(int(value))
        levels.append(JacketPoints(
            joint=np.asarray(columns["joint"], float)[rows].astype(int),
            angle_deg=np.asarray(columns["angle_deg"], float)[rows],
            damage_per_record=np.asarray(columns["damage_per_record"], float)[rows],
            closed_damage_per_record=np.asarray(columns["closed_damage_per_record"], float)[rows],
            minimum=np.asarray(columns["minimum"], float)[rows],
            maximum=np.asarray(columns["maximum"], float)[rows],
            first=np.asarray(columns["first"], float)[rows],
            per_hour=float(np.asarray(columns["records_per_hour"], float)[rows][0])))
    return ns, levels


def regime_result(deck):
    """Run a regime's (or the run-up's) deck in this process: the result of ``analyses.run``
    (refined at the deck's levels), without output files."""
    from pydriver.analyses import run
    from pydriver.model import Model
    from pydriver.run_result import require_finite
    model = Model(deck)
    result = run(model)
    require_finite(result, model.name)
    return result


def write_record(deck_path, out) -> None:
    """Run the regime deck at ``deck_path`` and write its record into the new directory ``out``
    (the files named in the module docstring; all or none, :class:`pydriver.output.RunDirectory`).
    The record maker of a spectrum directory's tasks (:mod:`pydriver.sweep.spectrum`)."""
    from pydriver.deckfile import read_deck
    from pydriver.output import RunDirectory, write_files
    deck = read_deck(deck_path)
    with RunDirectory(Path(out), deck=deck.name) as run_dir:
        result = regime_result(deck)
        result.timeseries = None
        result.extra.pop("modes", None)
        result.extra.setdefault("tables", {})[POINTS_FILE] = points_table(of_result(result))
        write_files(result, run_dir)
        run_dir.commit()


def read_record(run_dir) -> RegimeRun:
    """The :class:`RegimeRun` of a regime's record (:func:`write_record`).

    Raises
    ------
    OSError, ValueError, KeyError
        A record that is not whole (the caller names it).
    """
    from pydriver.output import read_csv
    run_dir = Path(run_dir)
    summary = json.loads((run_dir / "summary.json").read_text(encoding="utf-8"))
    ns, levels = levels_of_table(read_csv(run_dir / POINTS_FILE))
    return RegimeRun(ns=ns, levels=levels, summary=summary)
