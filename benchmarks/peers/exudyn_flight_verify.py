"""Verification of the forward-flight Exudyn peer (exudyn_flight.py) against rotorcable.

1. Start: the Exudyn model's CMs at t = 0 (inertial = hub frame then) against rotorcable's
   shape at the same q (the tree reproduces the Cardan chain, the rotor centre, body 1).
2. Step sweep: CMs in the hub frame at ``--samples`` equally spaced times over ``--t-end``
   (default one revolution) against rotorcable-IDA at rtol 1e-10; the observed order between
   neighbouring steps (generalized-alpha: 2) and the agreement at the finest step, which must be
   below ``--tol`` (default 1e-4 m, issue 14) or the script exits with status 1.

Usage (from the project root):
    .venv/bin/python benchmarks/peers/exudyn_flight_verify.py [--n 11] [--steps-per-rev 250 500 1000]

Needs the core's test and benchmark probes: a build with the meson option ``probes`` on
(``bash .ci/setup``), not the product wheel (benchmarks/README.md).
"""

from __future__ import annotations

import argparse
import math
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.dirname(HERE))

from flight_scene import flight_model, flight_start  # noqa: E402
from harness import add_set_option, parse_sets, timed_run  # noqa: E402

DECK = os.path.join(os.path.dirname(os.path.dirname(HERE)), "inputs", "uh60_part2_forward_flight.nml")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=11)
    ap.add_argument("--revolutions", type=float, default=1.0)
    ap.add_argument("--samples", type=int, default=11)
    ap.add_argument("--steps-per-rev", type=int, nargs="+", default=[250, 500, 1000])
    ap.add_argument("--tol", type=float, default=1e-4, help="required agreement at the finest step [m]")
    add_set_option(ap)
    args = ap.parse_args(argv)
    model = flight_model(DECK, args.n, parse_sets(args.sets))
    q0, v0 = flight_start(model)
    period = 2.0 * math.pi / float(model.description["rotor"]["speed"]["omega"])
    t_end = args.revolutions * period
    ref = timed_run(model, q0, v0, t_end, rtol=1e-10, atol=1e-12, samples=args.samples)
    import exudyn_flight as ef               # after the rotorcable runs (import slows the core)
    fm = ef.FlightModel(model, q0, v0)
    start = float(np.abs(fm.cms_hub(0.0) - model.core.shape(q0, 0.0)["cm"]).max())
    print(f"n = {args.n}: start CMs Exudyn vs rotorcable {start:.1e} m; rotorcable reference rtol 1e-10 "
          f"({ref['stats']['steps']} steps) over {t_end:.4f} s")
    print(f"  {'steps/rev':>9} {'h [s]':>9} {'steps':>6} {'newton':>7} {'cpu_s':>8} {'max err [m]':>11} "
          f"{'end err [m]':>11} {'order':>6}")
    prev, err = None, np.inf
    for k in args.steps_per_rev:
        h = period / k
        r = ef.simulate(model, q0, v0, h, t_end, args.samples)
        if r["status"] != "ok":
            print(f"  {k:9d} FAILED: {r['status']}")
            continue
        diff = np.abs(r["cm_samples"] - ref["cm_samples"])
        err = float(diff.max())
        order = f"{math.log(prev[1] / err) / math.log(prev[0] / h):6.2f}" if prev else ""
        prev = (h, err)
        print(f"  {k:9d} {h:9.2e} {r['n_steps']:6d} {r['newton_iterations']:7d} {r['cpu_s']:8.2f} {err:11.2e} "
              f"{float(diff[-1].max()):11.2e} {order:>6}", flush=True)
    ok = start < 1e-12 and err < args.tol
    print(f"agreement at the finest step {err:.2e} m (required < {args.tol:g} m): {'PASS' if ok else 'FAIL'}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
