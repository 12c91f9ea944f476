"""Campbell diagram run time (issue 23 item 2, models that update).

The Campbell analysis solves an equilibrium and linearises about it at every speed of its
grid.  It used to build a new model from the deck per speed (``Model.with_changes``: schema
check, deck rules, assembly, the core's model); it now changes the rotor speed of one model in
place (``CoreModel.update('rotor.omega', ...)``).  Timed: ``pydriver.run_deck`` of the two
Campbell decks of inputs/ (no files), and ``campbell.solve_speeds`` alone (the part that
changed), median of ``--repeat`` runs, both ways in one run: ``rebuild`` is the earlier
per-speed rebuild (the reference of tests/test_model_update.py), ``update`` today's code.

Run:  .venv/bin/python benchmarks/campbell_update.py        (about 30 s)
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import numpy as np

import pydriver
from pydriver.analyses import campbell, linear_modes

ROOT = Path(__file__).resolve().parents[1]
DECKS = ["uh60_part2_campbell", "uh60_part2_campbell_soft"]


def solve_speeds_rebuilt(model, rpm):
    """The speeds solved as before models updated: a model built from the deck per speed."""
    s = model.deck.values["solver"]
    q_prev, solved = None, []
    for r in rpm:
        m = model.with_changes({"rotor.rpm": float(r), "case.analysis": "static"})
        q, lam, _ = m.core.static(m.q0 if q_prev is None else q_prev, 0.0, s["newton_tol"], s["newton_max_iter"])
        q_prev = q
        mats = m.core.modal_matrices(q, lam)
        solved.append((mats, *linear_modes.complex_modes(mats)))
    return solved


def median_time(fn, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)
    print("| deck | speeds | way | run_deck, median [s] | solve_speeds, median [s] |")
    print("|---|---|---|---|---|")
    updating = campbell.solve_speeds
    for stem in DECKS:
        model = pydriver.Model.from_deck(ROOT / "inputs" / f"{stem}.nml")
        rpm = np.linspace(0.0, campbell.diagram_top(model), int(model.deck["campbell.n_speeds"]))
        for way, solver in (("rebuild", solve_speeds_rebuilt), ("update", updating)):
            campbell.solve_speeds = solver           # what campbell_analysis calls
            try:
                whole = median_time(lambda: pydriver.run_deck(model), args.repeat)
                speeds = median_time(lambda: solver(model, rpm), args.repeat)
            finally:
                campbell.solve_speeds = updating
            print(f"| {stem} | {len(rpm)} | {way} | {whole:.3f} | {speeds:.3f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
