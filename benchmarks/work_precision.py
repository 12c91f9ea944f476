"""Work-precision: error against CPU time, rotorcable against its peers.

Cases: the six-link dynamic verification (thesis 4.4.2, 2 s) and the UH-60 part 2 decay
test (thesis 5.4, 1 s, start in the static equilibrium, 1 N pulse for 0.1 s).

Methods (all start from the same consistent state, pydriver.scene / benchmarks/harness.py):

* ``rotorcable-IDA``: the default route, SUNDIALS IDA on the GGL index-2 DAE, structured
  Jacobian (Fortran core, harness.timed_run);
* ``gsl-rk8pd`` / ``gsl-msbdf``: the thesis's route, index-1 ODE of eq. 3.55/3.58 with
  Baumgarte stabilisation (w = 50/s), GSL gsl_odeiv2, same Fortran model;
* ``scipy-DOP853`` / ``scipy-Radau``: the same model in numpy with solve_ivp
  (benchmarks/peers/scipy_route.py), what a Python user would write;
* ``exudyn-genalpha``: Exudyn's kinematic tree + generic joint with its default
  generalized-alpha solver (benchmarks/peers/exudyn_route.py); accuracy knob = fixed step.

Error = max over all CM coordinates at t_end of |x - x_ref| [m] (the issue's measure), and
the trajectory error = the same maximum over SAMPLES equally spaced times 0 ... t_end (the
stricter measure: on the decay case the oscillation has died out by t_end, so every method's
end-time error is small); reference = rotorcable-IDA at rtol = atol = 1e-12 (atol 1e-14 takes
10x the steps for no gain), cross-checked by gsl-rk8pd at rtol 1e-12 and that disagreement is
reported as the error floor.  Reaction error = max |F, M - ref| at t_end.  Every method
returns the samples its own way: IDA interpolates (IDASolve to each sample time), the GSL
driver steps onto each sample time, solve_ivp uses its dense output, Exudyn's solve is split
at the sample times.  CPU time = process CPU time of the integration only (no set-up, no outputs),
median of ``--repeat`` runs for the fast methods, one run for SciPy and Exudyn.

Writes benchmarks/results/work_precision.csv, work_precision.png and the table
benchmarks/results/work_precision.md (time to reach 1e-6 m and the ratio to rotorcable).
Run:  .venv/bin/pip install -r benchmarks/requirements.txt
      .venv/bin/python benchmarks/work_precision.py        (a few minutes on 2 cores)

Needs the core's test and benchmark probes: a build with the meson option ``probes`` on
(``bash .ci/setup``), not the product wheel (benchmarks/README.md).
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
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "benchmarks" / "results"
sys.path.insert(0, str(ROOT / "benchmarks"))

import pydriver  # noqa: E402
from harness import NoWorkDone, prepared, timed_run  # noqa: E402

CASES = {"six_link_dynamic": ROOT / "inputs" / "six_link_dynamic.nml",
         "uh60_part2_decay": ROOT / "inputs" / "uh60_part2_decay.nml"}
FORTRAN = ("rotorcable-IDA", "gsl-rk8pd", "gsl-msbdf")
RTOLS = (1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10)
# SciPy runs take 0.5-25 s each (Radau stalls below rtol 1e-4 on the decay case, see
# peers/scipy_route.md): a few settings keep the whole script within minutes.
SCIPY_RTOLS = {"scipy-DOP853": (1e-3, 1e-4, 1e-6), "scipy-Radau": (1e-3, 1e-4)}
EXUDYN_STEPS = (1e-2, 5e-3, 2e-3, 1e-3, 5e-4, 2e-4, 1e-4)
TARGET = 1e-6
SAMPLES = 51
BAUMGARTE = 50.0


_PREPARED: dict = {}


def fortran_run(deck: Path, method: str, rtol: float, atol: float | None = None) -> dict:
    """One timed integration by the Fortran core from the deck's consistent start (the model is
    built once per deck; the timing covers the integration alone)."""
    if deck not in _PREPARED:
        _PREPARED[deck] = prepared(deck)
    model, q0, v0, t_end = _PREPARED[deck]
    try:
        r = timed_run(model, q0, v0, t_end, method, rtol, atol, samples=SAMPLES, baumgarte=BAUMGARTE)
    except (pydriver.RunError, NoWorkDone) as exc:
        return {"status": str(exc)}
    return {"status": "ok", "cm_end": r["cm_samples"][-1], "reactions_end": r["reactions_end"],
            "cpu_s": r["cpu_s"], "wall_s": r["wall_s"], "steps": r["stats"]["steps"],
            "evals": r["stats"]["residual_evals"], "gmax": r["gmax_end"], "cm_samples": r["cm_samples"]}


def median_run(fn, repeat: int) -> dict:
    runs = [fn() for _ in range(repeat)]
    best = runs[0]
    if best["status"] == "ok":
        best = dict(best)
        best["cpu_s"] = float(np.median([r["cpu_s"] for r in runs]))
    return best


def peer_modules(which: str):
    """The SciPy peers (``which="scipy"``) or Exudyn (``"exudyn"``), each imported only when
    its turn comes: importing Exudyn slows the Fortran core in the same process by ~1.5x
    (measured: IDA on the decay case at rtol 1e-3, 8.9 -> 13.2 ms CPU, wall alike), so it
    is loaded after every other method has run."""
    peers = {}
    try:
        if which == "scipy":
            from peers import scipy_route
            peers.update({m: ("rtol", scipy_route, SCIPY_RTOLS[m]) for m in scipy_route.METHODS})
        else:
            from peers import exudyn_route
            peers["exudyn-genalpha"] = ("step", exudyn_route, EXUDYN_STEPS)
    except ImportError as exc:
        print(f"skipping {which}: {exc}", file=sys.stderr)
    return peers


def time_to_target(errors, times, target=TARGET) -> float:
    """CPU time at which the error first reaches ``target``, interpolated in log-log between
    the measured settings (nan if never reached; the cheapest time if already reached)."""
    pts = sorted((t, e) for t, e in zip(times, errors) if np.isfinite(e) and np.isfinite(t))
    if not pts:
        return float("nan")
    best = float("nan")
    for (t0, e0), (t1, e1) in zip(pts, pts[1:]):
        if e0 > target >= e1 and e1 > 0:
            s = (np.log(target) - np.log(e0)) / (np.log(e1) - np.log(e0))
            return float(np.exp(np.log(t0) + s * (np.log(t1) - np.log(t0))))
    for t, e in pts:
        if e <= target:
            return t
    return best


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeat", type=int, default=5, help="repeats of the fast (Fortran) runs")
    ap.add_argument("--cases", nargs="+", default=list(CASES))
    ap.add_argument("--no-peers", action="store_true", help="Fortran methods only")
    args = ap.parse_args(argv)
    OUT.mkdir(parents=True, exist_ok=True)
    rows, floors, refs = [], {}, {}

    def record(case, method, knob, value, res):
        ref = refs[case]
        ok = res.get("status") == "ok"
        err = float(np.max(np.abs(np.asarray(res["cm_end"]) - ref["cm_end"]))) if ok else np.nan
        terr = (float(np.max(np.abs(np.asarray(res["cm_samples"]) - ref["cm_samples"])))
                if ok else np.nan)
        rerr = (float(np.max(np.abs(np.asarray(res["reactions_end"]) - ref["reactions_end"])))
                if ok else np.nan)
        rows.append({"case": case, "method": method, "knob": knob, "value": value,
                     "cpu_s": res.get("cpu_s", np.nan) if ok else np.nan, "cm_error_m": err,
                     "cm_traj_error_m": terr,
                     "reaction_error": rerr, "status": res.get("status", "?")[:120]})
        print(f"  {case[:10]:10s} {method:16s} {knob}={value:8.1e}  cpu {rows[-1]['cpu_s']:9.4f} s  "
              f"error {err:9.2e} m  trajectory {terr:9.2e} m  reactions {rerr:9.2e}  "
              f"{'' if ok else res.get('status')}", flush=True)

    for case in args.cases:
        deck = CASES[case]
        t0 = time.perf_counter()
        ref = fortran_run(deck, "rotorcable-IDA", 1e-12, 1e-12)
        check = fortran_run(deck, "gsl-rk8pd", 1e-12, 1e-12)
        if ref["status"] != "ok":
            raise SystemExit(f"reference failed on {case}: {ref['status']}")
        floors[case] = (float(np.max(np.abs(check["cm_samples"] - ref["cm_samples"])))
                        if check["status"] == "ok" else np.nan)
        print(f"{case}: reference in {time.perf_counter() - t0:.1f} s, IDA vs rk8pd at rtol 1e-12 "
              f"differ by {floors[case]:.1e} m (max over the samples)", flush=True)
        refs[case] = ref
        for method in FORTRAN:
            for rtol in RTOLS:
                record(case, method, "rtol", rtol,
                       median_run(lambda: fortran_run(deck, method, rtol), args.repeat))
    for which in () if args.no_peers else ("scipy", "exudyn"):
        for method, (knob, module, values) in peer_modules(which).items():
            for case in args.cases:
                for value in values:
                    try:
                        res = module.simulate(str(CASES[case]), method, value, n_samples=SAMPLES)
                    except Exception as exc:  # a peer failing is a data point, not a crash
                        res = {"status": f"{type(exc).__name__}: {exc}"}
                    record(case, method, knob, value, res)

    with open(OUT / "work_precision.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    summary = write_table(rows, floors)
    plot(rows, floors)
    print(summary)
    return 0


def write_table(rows, floors) -> str:
    lines = ["| case | method | CPU to 1e-6 m at t_end [s] | ratio | CPU to 1e-6 m over the trajectory [s] | ratio |",
             "|---|---|---|---|---|---|"]
    for case in dict.fromkeys(r["case"] for r in rows):
        per = {}
        for m in dict.fromkeys(r["method"] for r in rows if r["case"] == case):
            rs = [r for r in rows if r["case"] == case and r["method"] == m]
            per[m] = (time_to_target([r["cm_error_m"] for r in rs], [r["cpu_s"] for r in rs]),
                      time_to_target([r["cm_traj_error_m"] for r in rs], [r["cpu_s"] for r in rs]))
        base = per.get("rotorcable-IDA", (np.nan, np.nan))
        for m, (t_end, t_traj) in per.items():
            lines.append(f"| {case} | {m} | {t_end:.4g} | {t_end / base[0]:.3g} | {t_traj:.4g} | "
                         f"{t_traj / base[1]:.3g} |")
    lines.append("")
    lines.append("Reference error floor (IDA vs rk8pd at rtol 1e-12, max over the samples): "
                 + ", ".join(f"{c} {f:.1e} m" for c, f in floors.items()))
    text = "\n".join(lines) + "\n"
    (OUT / "work_precision.md").write_text(text)
    return text


def plot(rows, floors):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    cases = list(dict.fromkeys(r["case"] for r in rows))
    fig, axes = plt.subplots(2, len(cases), figsize=(6.2 * len(cases), 9.0), squeeze=False)
    for row, (key, label) in enumerate((("cm_error_m", "max CM error at t_end [m]"),
                                        ("cm_traj_error_m", "max CM error over the trajectory [m]"))):
        for ax, case in zip(axes[row], cases):
            for m in dict.fromkeys(r["method"] for r in rows if r["case"] == case):
                rs = [r for r in rows if r["case"] == case and r["method"] == m and r["status"] == "ok"]
                if rs:
                    ax.loglog([r["cpu_s"] for r in rs], [max(r[key], 1e-16) for r in rs], "o-", label=m)
            ax.axhline(TARGET, color="k", lw=0.6, ls="--")
            if row == 1:
                ax.axhline(max(floors.get(case, 1e-16), 1e-16), color="grey", lw=0.6, ls=":")
            ax.set_xlabel("CPU time of the integration [s]")
            ax.set_ylabel(label)
            ax.set_title(case)
            ax.grid(True, which="both", alpha=0.3)
            ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(OUT / "work_precision.png", dpi=120)


if __name__ == "__main__":
    sys.exit(main())
