"""Before/after figures of the integrator's linear algebra (issues 4 and 14).

The same integrations (harness.timed_run: the integration alone, no set-up, no outputs) with
the solver options switched on one after the other, all in one run so that the ratios are
comparable on a shared machine:

1. ``before``: SUNDIALS's dense LU of the whole iteration matrix, SUNDIALS's own N_Vector
   kernels (Debian builds them without optimisation), physics Jacobian by finite differences
   formed at every setup;
2. ``+ compiled vector kernels`` (``&solver vector_kernels = 'compiled'``);
3. ``+ block solver`` (``linear_solver = 'block'``, Schur complement, LAPACK);
4. ``+ Jacobian kept`` (``jacobian_max_age = 50``; the default of issue 4);
5. ``+ analytic Jacobian`` (``jacobian = 'analytic'``, kept 100 steps);
6. ``+ chain solver where long`` (``linear_solver = 'auto'``): today's defaults.

Cases: the UH-60 part 2 decay (1 s, rtol 1e-8), the six-link swing (2 s,
rtol 1e-8) and the UH-60 cable cut into 80 bodies (0.05 s, rtol 1e-6, as in scaling.py).
Median wall time of ``--repeat`` runs.  Writes benchmarks/results/before_after.csv and prints
a Markdown table.  Run:  .venv/bin/python benchmarks/before_after.py   (about a minute)

Needs the core's test and benchmark probes: a build with the meson option ``probes`` on
(``bash .ci/setup``), not the product wheel (benchmarks/README.md).
"""

from __future__ import annotations

import argparse
import csv
import statistics
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "benchmarks" / "results"
sys.path.insert(0, str(ROOT / "benchmarks"))

from harness import prepared, timed_run  # noqa: E402

FD = {"jacobian": "finite_difference"}
CONFIGS = [
    ("before", {**FD, "linear_solver": "dense", "vector_kernels": "sundials", "jacobian_max_age": 1}),
    ("+ compiled vector kernels", {**FD, "linear_solver": "dense", "vector_kernels": "compiled", "jacobian_max_age": 1}),
    ("+ block solver", {**FD, "linear_solver": "block", "vector_kernels": "compiled", "jacobian_max_age": 1}),
    ("+ Jacobian kept", {**FD, "linear_solver": "block", "vector_kernels": "compiled", "jacobian_max_age": 50}),
    ("+ analytic Jacobian", {"jacobian": "analytic", "linear_solver": "block", "vector_kernels": "compiled",
                             "jacobian_max_age": 100}),
    ("+ chain solver where long (default)", {"jacobian": "analytic", "linear_solver": "auto",
                                              "vector_kernels": "compiled", "jacobian_max_age": 100}),
]


def cases(tmp: Path):
    import scaling
    return [("uh60_part2_decay", ROOT / "inputs" / "uh60_part2_decay.nml", 1e-8, 1e-10),
            ("six_link_dynamic", ROOT / "inputs" / "six_link_dynamic.nml", 1e-8, 1e-10),
            ("uh60 n = 80, 0.05 s", scaling.deck_for(80, tmp / "n80.nml"), 1e-6, 1e-8)]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args(argv)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for name, deck, rtol, atol in cases(tmp):
            repeat = args.repeat if "80" not in name else max(1, args.repeat // 2)
            model, q0, v0, t_end = prepared(deck)
            for label, solver in CONFIGS:
                walls, st = [], None
                for _ in range(repeat):
                    out = timed_run(model, q0, v0, t_end, rtol=rtol, atol=atol, **solver)
                    walls.append(out["wall_s"])
                    st = out["stats"]
                rows.append({"case": name, "configuration": label, "wall_s": statistics.median(walls),
                             "steps": st["steps"], "residual_evals": st["residual_evals"],
                             "jacobian_evals": st["jacobian_evals"]})
                print(f"{name:22s} {label:28s} {rows[-1]['wall_s'] * 1e3:9.1f} ms  steps {st['steps']:6d}  "
                      f"residuals {st['residual_evals']:6d}", flush=True)
    OUT.mkdir(parents=True, exist_ok=True)
    with open(OUT / "before_after.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    print("\n| case | configuration | wall [ms] | speed-up | steps | residuals |\n|---|---|---|---|---|---|")
    for r in rows:
        base = next(b for b in rows if b["case"] == r["case"])
        print(f"| {r['case']} | {r['configuration']} | {r['wall_s'] * 1e3:.1f} | "
              f"{base['wall_s'] / r['wall_s']:.1f}x | {r['steps']} | {r['residual_evals']} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
