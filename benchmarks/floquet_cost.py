"""What the Floquet analysis costs beside the flight run it belongs to (issue 39: <= 2x the flight
run without it).

Two settings of the main job (``inputs/uh60_part2_forward_flight_cable.nml``):

* ``refined``: as shipped (n = 11, 22, 44), the least damped Floquet modes from a subspace of
  the monodromy at every level (pydriver/analyses/floquet_subspace.py);
* ``one level``: n = 11 only, the whole monodromy (54 sensitivity columns, pydriver/analyses/floquet.py).

Each is run with ``&solver floquet`` on and off, interleaved (off, on, off, on, ...: a slow phase
of the shared machine falls on both alike), ``--repeat`` times, the whole ``pydriver.run_deck``
timed.  Reported: the medians; Floquet's cost as the difference of the medians over the run
without it; and, robust to a busy machine, Floquet's own wall time (the summary's
``floquet.levels[*].wall_time_s``, or ``floquet.wall_time_s`` of a one-level run, which times the
whole monodromy's integration and eigenvalues) over the run without it, median over the repeats.
Every run is checked to have done the work: revolutions and solver steps > 0, a Floquet verdict
with its least damped mode when on.

    .venv/bin/python benchmarks/floquet_cost.py [--repeat 5]

Writes benchmarks/results/floquet_cost.csv.
"""

from __future__ import annotations

import argparse
import csv
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import pydriver  # noqa: E402

DECK = ROOT / "inputs" / "uh60_part2_forward_flight_cable.nml"
SETTINGS = {"refined": {}, "one level": {"refinement.levels": 1}}


def timed(model) -> tuple[float, dict]:
    start = time.perf_counter()
    summary = pydriver.run_deck(model).summary
    wall = time.perf_counter() - start
    if summary["revolutions"] <= 0 or summary["solver"]["steps"] <= 0:
        raise SystemExit("no work done")
    return wall, summary


def floquet_own_s(summary: dict) -> float:
    """Floquet's own wall time in a run with it (every level's, or the one level's)."""
    floquet = summary.get("floquet")
    if not floquet or "least_damped" not in floquet:
        raise SystemExit("a run with floquet on has no Floquet verdict")
    levels = floquet.get("levels")
    return float(sum(level["wall_time_s"] for level in levels)) if levels else float(floquet["wall_time_s"])


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args(argv)
    base = pydriver.Model.from_deck(DECK)
    rows = []
    for name, changes in SETTINGS.items():
        off_model = base.with_changes({**changes, "solver.floquet": False})
        on_model = base.with_changes({**changes, "solver.floquet": True})
        off, on, own = [], [], []
        for _ in range(args.repeat):
            off.append(timed(off_model)[0])
            wall, summary = timed(on_model)
            on.append(wall)
            own.append(floquet_own_s(summary))
        m_off, m_on = statistics.median(off), statistics.median(on)
        row = {"setting": name, "repeat": args.repeat, "run_without_s": m_off, "run_with_s": m_on,
               "floquet_by_difference_s": m_on - m_off, "difference_over_run": (m_on - m_off) / m_off,
               "floquet_own_s": statistics.median(own),
               "own_over_run": statistics.median(o / f for o, f in zip(own, off))}
        rows.append(row)
        print(f"{name:9s}: without {m_off:6.2f} s, with {m_on:6.2f} s; Floquet {row['floquet_by_difference_s']:5.2f} s "
              f"by difference = {row['difference_over_run']:.2f}x the run, its own {row['floquet_own_s']:5.2f} s = "
              f"{row['own_over_run']:.2f}x (target <= 2x)", flush=True)
    out = ROOT / "benchmarks" / "results" / "floquet_cost.csv"
    out.parent.mkdir(parents=True, exist_ok=True)
    with open(out, "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
