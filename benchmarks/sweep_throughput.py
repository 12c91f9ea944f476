"""Sweep throughput: the local process pool against a serial loop in one process.

For each case the same grid of decks is run (a) serially, ``run_task`` on one deck after the
other in this process (what a user's own ``for`` loop over ``run_deck`` does, writing the
same files), and (b) with ``pydriver.run_sweep`` on a pool of ``--jobs`` workers, end to end:
pool start-up, deck writing, runs and the aggregation into ``sweep.csv`` included.  Each is
repeated ``--repeats`` times into fresh directories (a sweep directory would resume) and the
median wall time is reported as runs per second.

Cases:
  modal24   the issue's 24-point c_y sweep of uh60_part2_modal (about 10 ms per deck: the
            pool's start-up is comparable to the whole serial loop)
  modal240  the same c_y range with 240 points (start-up amortised over many light decks)
  decay8    8-point c_y sweep of the dynamic decay test uh60_part2_decay (about 0.6 s per
            deck: heavy decks)

``busy`` is the fraction of the pool's wall time x workers spent inside the solver (sum of
the runs' ``wall_time_s`` over wall x jobs): 1.0 would be every core solving all the time.

Run from the project root:  .venv/bin/python benchmarks/sweep_throughput.py
Writes benchmarks/results/sweep_throughput.json and prints one line per case.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CASES = {
    "modal24": ("uh60_part2_modal.nml", "springs.c_beta=1:70:24"),
    "modal240": ("uh60_part2_modal.nml", "springs.c_beta=1:70:240"),
    "decay8": ("uh60_part2_decay.nml", "springs.c_beta=5:75:8"),
}


def serial(base: Path, spec: str, tmp: Path) -> tuple[float, int]:
    """Wall time of a serial in-process loop over the grid's decks (decks written first)."""
    from pydriver.sweep import prepare, run_task
    out = tmp / "serial_decks"
    manifest = prepare(base, [spec], out)
    runs = Path(tempfile.mkdtemp(dir=tmp))
    t0 = time.perf_counter()
    for p in manifest["points"]:
        run_task(out / "decks" / f"{p['id']}.nml", runs / p["id"])
    return time.perf_counter() - t0, len(manifest["points"])


def pooled(base: Path, spec: str, tmp: Path, jobs: int) -> tuple[float, float]:
    """Wall time of run_sweep on a pool of ``jobs`` workers, and the solver-busy fraction."""
    import pydriver
    out = Path(tempfile.mkdtemp(dir=tmp)) / "sweep"
    t0 = time.perf_counter()
    status = pydriver.run_sweep(base, [spec], out, jobs=jobs, progress=False, plots=False)
    wall = time.perf_counter() - t0
    assert status.ok, status.line()
    solver = sum(pydriver.load_results(out).table["wall_time_s"])
    return wall, solver / (wall * jobs)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--cases", nargs="+", default=list(CASES), choices=list(CASES))
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "sweep_throughput.json"))
    args = ap.parse_args(argv)
    results = {"machine": {"cpus": os.cpu_count(), "python": sys.version.split()[0],
                           "platform": platform.platform()},
               "jobs": args.jobs, "repeats": args.repeats, "statistic": "median", "cases": {}}
    for name in args.cases:
        deck, spec = CASES[name]
        base = ROOT / "inputs" / deck
        t_serial, t_pool, busy = [], [], []
        with tempfile.TemporaryDirectory() as tmp:
            for _ in range(args.repeats):
                t, n = serial(base, spec, Path(tmp))
                t_serial.append(t)
                t, b = pooled(base, spec, Path(tmp), args.jobs)
                t_pool.append(t)
                busy.append(b)
        s, p = statistics.median(t_serial), statistics.median(t_pool)
        # Other processes on the machine take cores from both loops alike; the 1-minute
        # load average says how quiet it was (about 0 + jobs would be quiet).
        load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
        results["cases"][name] = {
            "deck": deck, "set": spec, "runs": n,
            "serial_s": s, "pool_s": p, "serial_runs_per_s": n / s, "pool_runs_per_s": n / p,
            "speedup": s / p, "pool_solver_busy": statistics.median(busy),
            "serial_s_all": t_serial, "pool_s_all": t_pool, "loadavg_1min_after": load}
        print(f"{name}: {n} runs, serial {n / s:.1f} runs/s, pool ({args.jobs} workers) "
              f"{n / p:.1f} runs/s, ratio {s / p:.2f}, solver busy {statistics.median(busy):.2f}, "
              f"load average {load:.1f}",
              flush=True)
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(results, indent=1) + "\n")
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
