"""Cost of a flight run's design sensitivities (issue 24: <= 3x the run without them for <= 8
parameters).

The main job's cable (``inputs/uh60_part2_forward_flight_cable.nml`` at one level, n = 11) run
as a whole flight run (``pydriver.run_deck``: marching to the periodic state, sampling, fatigue)
without ``&design`` and with 1, 3 and 8 parameters, in two settings:

* ``floquet on``: the deck as shipped (``&solver floquet = .true.``): the run takes the monodromy
  for the Floquet analysis anyway, and the sensitivities solve (I - Phi) directly;
* ``floquet off``: no monodromy; the periodic start's sensitivity comes from block GMRES on
  one-revolution products, all parameters in one Krylov space (pydriver/analyses/flight_sensitivities.py).

Reports the median wall time of --repeat runs and its ratio to the run without sensitivities
(the issue's measure, on a quiet machine); the median over the rounds of each round's ratio
(the runs are interleaved, every parameter count once a round, so that a drift of the machine's
speed falls on all of them alike); and, robust to a busy machine, the paired ratio of
each run with sensitivities: its wall time over its wall time less the sensitivities' own
(``summary['sensitivities']['wall_time_s']`` and the parameters' model builds,
``model_builds_wall_time_s``; the rest is the run as without them), median over the repeats;
and the work (solver steps of the sensitivity integrations, Krylov iterations).  Every run is
checked to have done the work: revolutions > 0 and steps > 0, and with parameters a finite
sensitivity for every output and parameter.

    .venv/bin/python benchmarks/flight_sensitivities.py [--repeat 5]

Writes benchmarks/results/flight_sensitivities.csv.
"""

from __future__ import annotations

import argparse
import csv
import math
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import pydriver  # noqa: E402

DECK = ROOT / "inputs" / "uh60_part2_forward_flight_cable.nml"
#: Parameters that leave the supports and the period alone (flight runs refuse the others).
PARAMETERS = ["cable.ei", "cable.gj", "cable.damping_time", "drag.cd", "cable.mass_per_length", "chain.diameter",
              "drag.forward_speed", "loads.gravity(3)"]


def one(model):
    t0 = time.perf_counter()
    s = pydriver.run_deck(model).summary
    wall = time.perf_counter() - t0
    if s["revolutions"] <= 0 or s["solver"]["steps"] <= 0:
        raise SystemExit("no work done")
    work, paired = "", 1.0
    if "design" in model.deck.groups:
        sens = s["sensitivities"]
        values = [v for row in sens["d_output_d_parameter"].values() for v in row.values()]
        if not values or not all(math.isfinite(v) for v in values):
            raise SystemExit("sensitivities missing or not finite")
        solver = sens["solver"]
        steps = solver["first"]["steps"] + solver.get("second", {"steps": 0})["steps"] + solver.get("steps", 0)
        if steps <= 0:
            raise SystemExit("sensitivity integrations took no steps")
        work = f"{steps} sensitivity steps" + (f", Krylov blocks of {solver['block_columns']} columns"
                                               if "krylov_iterations" in solver else ", monodromy solve")
        paired = wall / (wall - sens["wall_time_s"] - sens.get("model_builds_wall_time_s", 0.0))
    return wall, work, paired


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    base = pydriver.Model.from_deck(DECK).with_changes({"refinement.levels": 1})
    rows = []
    counts = (0, 1, 3, 8)
    for floquet in (True, False):
        models = {}
        for n_par in counts:
            changes = {"solver.floquet": floquet}
            if n_par:
                changes["design.parameters"] = PARAMETERS[:n_par]
            models[n_par] = base.with_changes(changes)
        # Interleaved: each round runs every parameter count once, so that a drift of the
        # machine's speed between rounds falls on all of them alike (the round's ratio).
        runs = {n_par: [] for n_par in counts}
        for _ in range(args.repeat):
            for n_par in counts:
                runs[n_par].append(one(models[n_par]))
        ref = statistics.median(r[0] for r in runs[0])
        for n_par in counts:
            wall = statistics.median(r[0] for r in runs[n_par])
            paired = statistics.median(r[2] for r in runs[n_par])
            per_round = statistics.median(r[0] / r0[0] for r, r0 in zip(runs[n_par], runs[0]))
            rows.append({"floquet": "on" if floquet else "off", "parameters": n_par, "median_wall_s": wall,
                         "ratio": wall / ref, "round_ratio": per_round, "paired_ratio": paired,
                         "work": runs[n_par][0][1]})
            print(f"floquet {rows[-1]['floquet']:3s}  {n_par} parameters: {wall:7.3f} s  "
                  f"{wall / ref:5.2f}x  round {per_round:5.2f}x  paired {paired:5.2f}x  {runs[n_par][0][1]}",
                  flush=True)
    out = ROOT / "benchmarks" / "results" / "flight_sensitivities.csv"
    with out.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
