"""Scaling of rotorcable with the number of bodies: closed chain, n = 20 ... 200.

The scene is the UH-60 part 2 cable (thesis Table A.2: 0.59 m, 0.313 kg, both ends clamped)
cut into n bodies, started at rest in its static equilibrium and excited by the 1 N pulse of
the decay test; 0.05 s are integrated with IDA (GGL index-2, rtol 1e-6, atol 1e-8).  Each n
runs in a fresh process (peak memory = that process's max RSS) and reports:

* wall time of the integration alone per simulated second (harness.timed_run; the start
  equilibrium and the outputs are not timed, the consistent start is) and the steps it took,
  median of ``--repeat`` runs, with the default linear solver (``'chain'``: O(n)
  articulated-body factorisation) and, once each, with the block (Schur-complement, O(n^3))
  solver for n <= ``--block-max`` and SUNDIALS's dense LU of the whole iteration matrix for
  n <= ``--dense-max`` (the earlier defaults: the "before");
* the cost of one GGL residual, one Jacobian with analytic and with finite-difference physics
  columns, and one mass matrix (core probe);
* one factorisation and one solve at cj = 1e4: the chain solver's, the block solver's and
  LAPACK's dense LU (dgetrf/dgetrs) of the whole matrix (core probes);
* peak resident memory of the process.

Targets (issue 14): n = 200 at most 2 s of wall time per simulated second, and the exponent
of wall per simulated second fitted between n = 20 and 200 (least squares over the sizes run
in that range) at most 1.5; each printed as PASS or MISS (``--strict``: exit status 1 on a
MISS).  The two-point exponent log(w_200 / w_20) / log(10) is printed beside the fit.

Writes benchmarks/results/scaling.csv, scaling.png, scaling_exponents.json (the fits and the
target verdicts) and prints the fitted exponents.
Needs the core's test and benchmark probes (timed integration, kernels, solvers): a build with
the meson option ``probes`` on, as ``bash .ci/setup`` makes; the product wheel has none.
Run:  .venv/bin/python benchmarks/scaling.py   (about four minutes on 2 cores)
      .venv/bin/python benchmarks/scaling.py --dense-max 0 --set solver.linear_solver=chain
"""

from __future__ import annotations

import os

# Single-threaded BLAS for every method (set before numpy loads it): on 2 cores an idle
# OpenBLAS thread pool spins after each call and its CPU time would be charged to whatever
# runs next in this process.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse
import csv
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "benchmarks" / "results"
SIZES = (20, 40, 80, 120, 200)
T_SIM = 0.05     # simulated time per run [s]
TARGET_N, TARGET_WALL = 200, 2.0          # n = 200: at most 2 s wall per simulated s
TARGET_EXPONENT, FIT_RANGE = 1.5, (20, 200)


def deck_for(n: int, path: Path, sets: dict | None = None) -> Path:
    """The UH-60 part 2 decay deck cut into n bodies, with the command line's ``--set`` values
    applied last (they win)."""
    from harness import nested_sets
    from pydriver.study import override_deck
    bend = 66.0 / (n - 1)
    changes = {
        "chain": {"n_bodies": str(n)},
        "shape": {"gamma_deg": f"90.0, 90.0, {n - 2}*0.0", "beta_deg": f"70.0, {n - 1}*{bend:.6f}"},
        "loads": {"pulse_body": str(max(2, n // 2))},
        "solver": {"t_end": "0.05", "dt_out": "0.05"}}
    for group, values in nested_sets(sets or {}).items():
        changes.setdefault(group, {}).update(values)
    return override_deck(ROOT / "inputs" / "uh60_part2_decay.nml", path, changes)


def measure_one(n: int, repeat: int, block: bool, dense: bool, sets: dict) -> dict:
    """Runs in a child process: one n, returns the measurements as a dict."""
    import resource

    from harness import prepared, timed_run
    from pydriver import core_probes as probes
    with tempfile.TemporaryDirectory() as tmp:
        model, q0, v0, _ = prepared(deck_for(n, Path(tmp) / f"n{n}.nml", sets))
    walls, stats = [], None
    for _ in range(repeat):
        out = timed_run(model, q0, v0, T_SIM, rtol=1e-6, atol=1e-8)
        walls.append(out["wall_s"])
        stats = out["stats"]
    def other(solver, run):
        if not run:
            return float("nan"), 0
        o = timed_run(model, q0, v0, T_SIM, rtol=1e-6, atol=1e-8, linear_solver=solver)
        return o["wall_s"] / T_SIM, o["stats"]["steps"]
    wall_block, steps_block = other("block", block)
    wall_dense, _ = other("dense", dense)
    nq, nc = model.nq, model.nc
    y, yd = probes.consistent_ggl_state(model.core, q0, v0)
    kern = probes.time_kernels(model.core, y, yd, max(200, 200000 // n))
    rhs = np.random.default_rng(0).standard_normal((2 * nq + 2 * nc, 1))
    it = probes.iteration_matrix(model.core, y, yd, 1.0e4, rhs, max(3, 20000 // n))
    chain = probes.chain_solver(model.core, y, 1.0e4, rhs, max(20, 20000 // n))
    rss_kib = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return {"n_bodies": n, "n_unknowns": 2 * nq + 2 * nc, "wall_per_sim_s": float(np.median(walls)) / T_SIM,
            "wall_per_sim_s_block": wall_block, "steps_block": steps_block,
            "wall_per_sim_s_dense": wall_dense,
            "chain_factor_ns": chain["ns_factor"], "chain_solve_ns": chain["ns_solve"],
            "block_factor_ns": it["ns_block_factor"],
            "block_solve_ns": it["ns_block_solve"], "lapack_dense_factor_ns": it["ns_dense_factor"],
            "lapack_dense_solve_ns": it["ns_dense_solve"],
            "steps": stats["steps"], "residual_evals": stats["residual_evals"],
            "jacobian_evals": stats["jacobian_evals"], "residual_ns": kern["residual_ns"],
            "jacobian_ns": kern["jacobian_ns"], "jacobian_fd_ns": kern["jacobian_fd_ns"],
            "mass_matrix_ns": kern["mass_matrix_ns"],
            "peak_rss_mib": rss_kib / 1024.0, "max_g_m": out["gmax_end"]}


def slope(x, y) -> float:
    return float(np.polyfit(np.log(x), np.log(y), 1)[0])


def fit_exponent(rows, key: str = "wall_per_sim_s", lo: int = FIT_RANGE[0], hi: int = FIT_RANGE[1]) -> float:
    """Least-squares exponent of ``key`` against n over the sizes in [lo, hi] (nan if < 2)."""
    pts = [(r["n_bodies"], r[key]) for r in rows if lo <= r["n_bodies"] <= hi]
    return slope(*zip(*pts)) if len(pts) >= 2 else float("nan")


def verdicts(rows) -> dict:
    """The issue-14 targets, PASS/MISS (or NOT RUN when the sizes do not cover them)."""
    wall = {r["n_bodies"]: r["wall_per_sim_s"] for r in rows}
    lo, hi = FIT_RANGE
    expo = fit_exponent(rows)
    two_point = (float(np.log(wall[hi] / wall[lo]) / np.log(hi / lo)) if lo in wall and hi in wall
                 else float("nan"))

    def verdict(value, limit, covered):
        return "NOT RUN" if not covered else ("PASS" if value <= limit else "MISS")
    return {"wall_per_sim_s_n200": wall.get(TARGET_N, float("nan")),
            "target_wall_per_sim_s": TARGET_WALL,
            "wall_verdict": verdict(wall.get(TARGET_N, np.inf), TARGET_WALL, TARGET_N in wall),
            "exponent_fit_20_200": expo, "exponent_two_point_20_200": two_point,
            "target_exponent": TARGET_EXPONENT,
            "exponent_verdict": verdict(expo, TARGET_EXPONENT, lo in wall and hi in wall)}


def report(rows, sets: dict) -> dict:
    """Fitted exponents, the target verdicts (printed, scaling_exponents.json) and the figure
    (scaling.png); returns the verdicts."""
    n = np.array([r["n_bodies"] for r in rows], float)
    big = n >= 20   # asymptotic range
    fits = {key: slope(n[big], np.array([r[key] for r in rows])[big])
            for key in ("wall_per_sim_s", "residual_ns", "jacobian_ns", "mass_matrix_ns", "chain_factor_ns",
                        "chain_solve_ns", "block_factor_ns", "lapack_dense_factor_ns")}
    print("fitted exponents (n >= 20): " + ", ".join(f"{k} ~ n^{v:.2f}" for k, v in fits.items()))
    targets = verdicts(rows)
    print(f"target n = {TARGET_N}: {targets['wall_per_sim_s_n200']:.3g} s per simulated s "
          f"(<= {TARGET_WALL:g}): {targets['wall_verdict']}")
    print(f"target exponent n = {FIT_RANGE[0]}..{FIT_RANGE[1]}: fit {targets['exponent_fit_20_200']:.2f}, "
          f"two-point {targets['exponent_two_point_20_200']:.2f} (<= {TARGET_EXPONENT:g}): "
          f"{targets['exponent_verdict']}")
    (OUT / "scaling_exponents.json").write_text(json.dumps(
        {"fits_n_ge_20": fits, "targets": targets, "deck_overrides": sets}, indent=2))
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7.0, 6.5))
    for key, label in (("wall_per_sim_s", "wall time per simulated second, default solver [s]"),
                       ("residual_ns", "one GGL residual [ns]"), ("jacobian_ns", "one analytic Jacobian [ns]"),
                       ("chain_factor_ns", "chain factorisation [ns]"), ("chain_solve_ns", "chain solve [ns]"),
                       ("block_factor_ns", "block factorisation [ns]"),
                       ("lapack_dense_factor_ns", "dense LU, LAPACK [ns]")):
        ax.loglog(n, [r[key] for r in rows], "o-", label=f"{label}  (~n^{fits[key]:.2f})")
    for key, style, label in (("wall_per_sim_s_block", "s--", "wall time per simulated second, block solver [s]"),
                              ("wall_per_sim_s_dense", "^:", "wall time per simulated second, dense LU [s]")):
        pts = [(r["n_bodies"], r[key]) for r in rows if np.isfinite(r[key])]
        if pts:
            ax.loglog(*zip(*pts), style, color="grey", label=label)
    ax.set_xlabel("number of bodies n")
    ax.set_ylabel("time: wall per simulated second [s], kernels [ns]")
    ax.set_title("rotorcable scaling, closed chain (UH-60 part 2 cut into n bodies)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.12), ncol=2)
    fig.tight_layout()
    fig.savefig(OUT / "scaling.png", dpi=120)
    return targets


def main(argv=None) -> int:
    from harness import add_set_option, parse_sets, set_args
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sizes", type=int, nargs="+", default=list(SIZES))
    ap.add_argument("--strict", action="store_true", help="exit status 1 if a target is missed")
    add_set_option(ap)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--block-max", type=int, default=200,
                    help="largest n also run with the block (Schur-complement) linear solver (one run)")
    ap.add_argument("--dense-max", type=int, default=120,
                    help="largest n also run with the dense linear solver (one run)")
    ap.add_argument("--child", type=int, help=argparse.SUPPRESS)
    ap.add_argument("--replot", action="store_true",
                    help="verdicts and figure again from results/scaling.csv, nothing measured")
    args = ap.parse_args(argv)
    sets = parse_sets(args.sets)
    if args.child:
        print(json.dumps(measure_one(args.child, args.repeat, args.child <= args.block_max,
                                     args.child <= args.dense_max, sets)))
        return 0
    if args.replot:
        with open(OUT / "scaling.csv", newline="") as fh:
            rows = [{k: (float(v) if k != "n_bodies" else int(v)) for k, v in r.items()} for r in csv.DictReader(fh)]
        targets = report(rows, sets)
        return 1 if (args.strict and "MISS" in (targets["wall_verdict"], targets["exponent_verdict"])) else 0
    if sets:
        print("deck overrides: " + ", ".join(f"{k} = {v}" for k, v in sets.items()))
    rows = []
    for n in args.sizes:
        out = subprocess.run([sys.executable, __file__, "--child", str(n), "--repeat", str(args.repeat),
                              "--block-max", str(args.block_max), "--dense-max", str(args.dense_max)]
                             + set_args(sets),
                             capture_output=True, text=True, cwd=ROOT)
        if out.returncode != 0:
            # A failed size is a failed benchmark: say which and why, do not fit around it.
            raise SystemExit(f"n = {n}: child failed (exit {out.returncode}):\n{out.stderr[-3000:]}")
        row = json.loads(out.stdout.strip().splitlines()[-1])
        rows.append(row)
        print(f"n = {n:4d}: {row['wall_per_sim_s']:8.3f} s per simulated s, {row['steps']:5d} steps "
              f"(block {row['wall_per_sim_s_block']:8.3f} s, {row['steps_block']} steps; dense LU "
              f"{row['wall_per_sim_s_dense']:8.3f} s); factor chain/block/LAPACK "
              f"{row['chain_factor_ns'] / 1e3:7.1f}/{row['block_factor_ns'] / 1e3:8.1f}/"
              f"{row['lapack_dense_factor_ns'] / 1e3:8.1f} us, solve chain {row['chain_solve_ns'] / 1e3:6.1f} us, "
              f"residual {row['residual_ns'] / 1e3:7.2f} us, Jacobian analytic/FD {row['jacobian_ns'] / 1e6:7.3f}/"
              f"{row['jacobian_fd_ns'] / 1e6:7.3f} ms, peak RSS {row['peak_rss_mib']:.0f} MiB", flush=True)
    OUT.mkdir(parents=True, exist_ok=True)
    with open(OUT / "scaling.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    targets = report(rows, sets)
    missed = "MISS" in (targets["wall_verdict"], targets["exponent_verdict"])
    return 1 if (args.strict and missed) else 0


if __name__ == "__main__":
    sys.exit(main())
