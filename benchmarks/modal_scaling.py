"""Cost of a modal analysis against the number of bodies: n = 32, 64, 128, 256.

The scene is the UH-60 part 2 cable with physical parameters (the forward-flight cable deck,
``inputs/uh60_part2_forward_flight_cable.nml``, in hover: &cable EI, GJ, mass per length and
damping time, xyz joints, both ends clamped, gravity, rotor at 260 rpm, no blade motion and no
stream), so the same cable is cut into n bodies; the start shape is the deck's bend (120 deg)
spread evenly over the joints.  Each n is timed as ``pydriver.run_deck`` of the model, the
whole analysis (static equilibrium, linearisation, undamped and damped eigenproblems, mode
shapes; no files), median of ``--repeat`` runs; the time of the modes' call alone is
reported beside it.  Every run must give nf = nq - nc frequencies, all
finite (else the script stops: a time without the answer means nothing).  "core modal" is the
modes' call alone (``modal.modes_about``: the core's linearised equations and their modes,
``linear_modes.modal_modes``).

Target (issue 21): n = 256 in at most 10 s.  The exponent is the least-squares slope of
log(wall) against log(n) over the sizes run, and the two-point slope between the two largest.

Writes benchmarks/results/modal_scaling.csv and prints the table.
Run:  .venv/bin/python benchmarks/modal_scaling.py          (about a minute on 2 cores)
"""

from __future__ import annotations

import os

# Single-threaded BLAS (set before numpy loads it), as in scaling.py: on 2 shared cores an
# idle OpenBLAS pool spins and its time lands on whatever runs next.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse
import csv
import statistics
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "benchmarks" / "results"
SIZES = (32, 64, 128, 256)
TARGET_N, TARGET_WALL = 256, 10.0


def cable_deck_text(n: int, extra: str = "") -> str:
    """The UH-60 part 2 cable in hover as a modal deck of n bodies (module docstring)."""
    bend = 120.0 / (n - 1)
    return f"""&case name = 'modal_cable_{n}', analysis = 'modal' /
&chain n_bodies = {n}, total_length = 0.590, diameter = 0.015, first_body = 'clamped', joint = 'xyz' /
&clamp_a gamma_deg = 90.0, beta_deg = 70.0 /
&shape gamma_deg = 0.0, 90.0, {n - 2}*0.0
       beta_deg = 0.0, {n - 1}*{bend:.9f} /
&cable ei = 1.906, gj = 1.466, mass_per_length = 0.5305, damping_time = 1.407e-3 /
&clamp_b active = .true., position = -0.161, 0.430, -0.135, gamma_deg = 0.0, beta_deg = 200.0 /
&rotor rpm = 260.0, centre = 0.0, -0.598, -0.135 /
&loads gravity = 0.0, 0.0, -9.81 /
{extra}"""


class NoAnswer(RuntimeError):
    """A run that did not give nf finite frequencies."""


def measure(n: int, repeat: int) -> dict:
    """Median wall time of ``repeat`` modal runs at n bodies, and of the core's modal call."""
    import pydriver
    from pydriver.analyses.modal import modes_about
    from pydriver.analyses.statics import equilibrium, unforced
    from pydriver.deckfile import deck_from_text
    model = pydriver.Model(deck_from_text(cable_deck_text(n), f"modal_cable_{n}.nml"))
    nf = model.nq - model.nc
    walls, f1 = [], None
    for _ in range(repeat):
        t0 = time.perf_counter()
        s = pydriver.run_deck(model).summary
        walls.append(time.perf_counter() - t0)
        f = np.asarray(s["frequencies_hz"]), np.asarray(s["damped_frequencies_hz"])
        if any(len(x) != nf or not np.all(np.isfinite(x)) for x in f):
            raise NoAnswer(f"n = {n}: {len(f[0])} frequencies for nf = {nf}, or a non-finite one")
        f1 = float(f[0][0])
    cores = []
    with unforced(model):                # a scope since models update (issue 23 item 2)
        q, lam, _ = equilibrium(model)
        for _ in range(repeat):
            t0 = time.perf_counter()
            modes_about(model, q, lam)
            cores.append(time.perf_counter() - t0)
    return {"n": n, "nf": nf, "wall_median_s": statistics.median(walls), "wall_min_s": min(walls),
            "wall_max_s": max(walls), "core_modal_median_s": statistics.median(cores), "f1_hz": f1}


def slope(ns, ts) -> float:
    """Least-squares exponent of t ~ n^p."""
    return float(np.polyfit(np.log(ns), np.log(ts), 1)[0])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=list(SIZES))
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--strict", action="store_true", help="exit 1 if the n = 256 target is missed")
    args = ap.parse_args(argv)
    sys.path.insert(0, str(ROOT))
    rows = []
    print(f"{'n':>5} {'nf':>5} {'wall median [s]':>16} {'min':>8} {'max':>8} {'core modal [s]':>15} {'f1 [Hz]':>10}")
    for n in args.sizes:
        r = measure(n, args.repeat)
        rows.append(r)
        print(f"{r['n']:5d} {r['nf']:5d} {r['wall_median_s']:16.3f} {r['wall_min_s']:8.3f} {r['wall_max_s']:8.3f} "
              f"{r['core_modal_median_s']:15.3f} {r['f1_hz']:10.5f}", flush=True)
    OUT.mkdir(parents=True, exist_ok=True)
    with open(OUT / "modal_scaling.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    ns = [r["n"] for r in rows]
    verdict = 0
    if len(rows) >= 2:
        p = slope(ns, [r["wall_median_s"] for r in rows])
        pc = slope(ns, [r["core_modal_median_s"] for r in rows])
        two = np.log(rows[-1]["wall_median_s"] / rows[-2]["wall_median_s"]) / np.log(ns[-1] / ns[-2])
        print(f"fitted exponent (n = {ns[0]} ... {ns[-1]}): wall n^{p:.2f}, core modal n^{pc:.2f}; "
              f"two-point {ns[-2]} -> {ns[-1]}: n^{two:.2f}")
    big = [r for r in rows if r["n"] == TARGET_N]
    if big:
        ok = big[0]["wall_median_s"] <= TARGET_WALL
        print(f"target n = {TARGET_N} in <= {TARGET_WALL:g} s: {big[0]['wall_median_s']:.2f} s "
              f"{'PASS' if ok else 'MISS'}")
        verdict = 0 if ok or not args.strict else 1
    print(f"wrote {OUT / 'modal_scaling.csv'}")
    return verdict


if __name__ == "__main__":
    sys.exit(main())
