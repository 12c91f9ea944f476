"""The sensitivity residual's columns F_y s + F_y' s' per call: tangent sweeps against the whole
derivative matrices times the columns (issue 39, item 2; ``ggl_residual_columns`` in
src_fortran/ggl_residual.f90 chooses between the two by this measurement).

The chains are those of benchmarks/peers/pinocchio_derivatives.py (``inputs/uh60_part2_decay.nml``
with n bodies on zy joints, at its consistent start); for m = 2 ... 40 random columns each route
is called through the probe ``core_probes.residual_tangent_columns`` (the same Python call on
both sides, so its overhead is in both), interleaved, best of 7 batches (the least disturbed by
the other processes of a shared machine).  Each pair is checked to have done the work: the two
routes' results finite and within 1e-12 of the largest entry of each other.

Run from the repository root (needs the ``probes`` build of .ci/setup)::

    .venv/bin/python benchmarks/residual_columns.py [--sizes 11 22 44]

writes ``benchmarks/results/residual_columns.csv`` and prints the table of benchmarks/README.md.
"""

from __future__ import annotations

import argparse
import csv
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))

from harness import NoWorkDone, prepared  # noqa: E402
from pydriver import core_probes as probes  # noqa: E402
from pydriver.study import override_deck  # noqa: E402

WIDTHS = (2, 4, 8, 12, 20, 40)


def chain_deck(n: int, path: Path) -> Path:
    """The decay deck with n bodies on zy joints (as benchmarks/peers/pinocchio_derivatives.py)."""
    bend = 66.0 / (n - 1)
    changes = {"chain": {"n_bodies": str(n), "joint": "'zy'"},
               "shape": {"gamma_deg": f"90.0, 90.0, {n - 2}*0.0", "beta_deg": f"70.0, {n - 1}*{bend:.6f}"},
               "loads": {"pulse_body": str(max(2, n // 2))}}
    return override_deck(ROOT / "inputs" / "uh60_part2_decay.nml", path, changes)


def best_us(call, per_batch: int, batches: int = 7) -> float:
    """The fastest batch's time per call [us]."""
    times = []
    for _ in range(batches):
        start = time.perf_counter()
        for _ in range(per_batch):
            call()
        times.append((time.perf_counter() - start) / per_batch)
    return min(times) * 1e6


def measure(n: int) -> list[dict]:
    with tempfile.TemporaryDirectory() as tmp:
        m, q0, v0, _ = prepared(chain_deck(n, Path(tmp) / "deck.nml"))
    y, yd = probes.consistent_ggl_state(m.core, q0, v0)
    rng = np.random.default_rng(1)
    rows = []
    for width in WIDTHS:
        dy, dyd = rng.standard_normal((len(y), width)), rng.standard_normal((len(y), width))
        results = {route: probes.residual_tangent_columns(m.core, y, yd, dy, dyd, route=route)
                   for route in ("sweeps", "matrices")}
        if not all(np.all(np.isfinite(r)) for r in results.values()):
            raise NoWorkDone(f"n={n}, {width} columns: a non-finite column")
        gap = np.abs(results["sweeps"] - results["matrices"]).max() / np.abs(results["sweeps"]).max()
        if gap > 1e-12:
            raise NoWorkDone(f"n={n}, {width} columns: the routes differ by {gap:.1e}")
        per = max(5, 4000 // (n * width))
        sweeps = best_us(lambda: probes.residual_tangent_columns(m.core, y, yd, dy, dyd, route="sweeps"), per)
        matrices = best_us(lambda: probes.residual_tangent_columns(m.core, y, yd, dy, dyd, route="matrices"), per)
        rows.append({"n_bodies": n, "nq": m.nq, "columns": width, "sweeps_us": sweeps, "matrices_us": matrices,
                     "sweeps_over_matrices": sweeps / matrices, "relative_gap": gap})
        print(f"n={n:3d} nq={m.nq:3d} columns {width:3d}: sweeps {sweeps:7.1f} us, matrices {matrices:7.1f} us, "
              f"ratio {sweeps / matrices:5.2f} (gap {gap:.1e})", flush=True)
    return rows


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[11, 22, 44])
    parser.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results" / "residual_columns.csv")
    args = parser.parse_args(argv)
    rows = [row for n in args.sizes for row in measure(n)]
    args.out.parent.mkdir(parents=True, exist_ok=True)
    with open(args.out, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
