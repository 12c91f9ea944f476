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
* ``mujoco-implicitfast-weld`` (decay case only): the chain as MJCF, clamp B a stiff weld
  equality, MuJoCo's implicitfast integrator; ``mujoco-rk4-open``: the OPEN chain (end B free,
  an easier problem) with RK4, measured against rotorcable on that open chain, the case
  ``uh60_part2_decay_open`` (benchmarks/peers/mujoco_route.py); accuracy knob = fixed step.
  Before they run, the script checks that the MJCF chain is the same physics (static balance,
  open-chain frequencies, the welded chain's sag) and prints the agreement.

Error = max over all CM coordinates at t_end of |x - x_ref| [m] (the issue's measure), and
the trajectory error = the same maximum over SAMPLES equally spaced times 0 ... t_end (the
stricter measure: on the decay case the oscillation has died out by t_end, so every method's
end-time error is small); reference = rotorcable-IDA at rtol = atol = 1e-12 (atol 1e-14 takes
10x the steps for no gain), cross-checked by gsl-rk8pd at rtol 1e-12 and that disagreement is
reported as the error floor.  Reaction error = max |F, M - ref| at t_end.  Every method
returns the samples its own way: IDA interpolates (IDASolve to each sample time), the GSL
driver steps onto each sample time, solve_ivp uses its dense output, Exudyn's solve is split
at the sample times.  CPU time = process CPU time of the integration only (no set-up, no outputs),
median of ``--repeat`` runs for the fast methods, one run for SciPy, Exudyn and MuJoCo.  A peer
run counts only if it did the work: steps taken, a finite error measured (else its status says
why and it is left out of the table).

Writes benchmarks/results/work_precision.csv, work_precision.png and the table
benchmarks/results/work_precision.md (time to reach 1e-6 m and the ratio to rotorcable).
Run:  .venv/bin/pip install -r benchmarks/requirements.txt
      .venv/bin/python benchmarks/work_precision.py        (a few minutes on 2 cores)
A subset, written under another name so the full results stay:
      .venv/bin/python benchmarks/work_precision.py --cases uh60_part2_decay uh60_part2_decay_open \
          --peers mujoco --stem work_precision_mujoco

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
from harness import NoWorkDone, open_chain_model, prepared, timed_run  # noqa: E402

CASES = {"six_link_dynamic": ROOT / "inputs" / "six_link_dynamic.nml",
         "uh60_part2_decay": ROOT / "inputs" / "uh60_part2_decay.nml",
         "uh60_part2_decay_open": ROOT / "inputs" / "uh60_part2_decay.nml"}
# Cases whose chain is the deck's without clamp B (harness.open_chain_model): only the peers
# that say so (mujoco_route.CASE_OF) run them.
OPEN_CASES = ("uh60_part2_decay_open",)
FORTRAN = ("rotorcable-IDA", "gsl-rk8pd", "gsl-msbdf")
RTOLS = (1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10)
# SciPy runs take 0.5-25 s each (Radau stalls below rtol 1e-4 on the decay case, see
# peers/scipy_route.md): a few settings keep the whole script within minutes.
SCIPY_RTOLS = {"scipy-DOP853": (1e-3, 1e-4, 1e-6), "scipy-Radau": (1e-3, 1e-4)}
EXUDYN_STEPS = (1e-2, 5e-3, 2e-3, 1e-3, 5e-4, 2e-4, 1e-4)
# Fixed steps dividing the sample interval 0.02 s and the pulse window 0.1 s.  RK4 is unstable
# on the open chain above h ~1.25e-4 s (and exact to ~1e-11 m below), so its steps are dense
# there; implicitfast's weld gives way like h^2 (peers/mujoco_route.py).
MUJOCO_STEPS = {"mujoco-rk4-open": (5e-4, 2e-4, 1.6e-4, 1.25e-4, 1e-4, 8e-5, 5e-5, 2e-5),
                "mujoco-implicitfast-weld": (1e-3, 5e-4, 2e-4, 1e-4, 5e-5, 2e-5, 1e-5, 5e-6)}
TARGET = 1e-6
SAMPLES = 51
BAUMGARTE = 50.0


_PREPARED: dict = {}


def case_model(case: str):
    """The deck path of a case, or the open-chain model built from it."""
    return open_chain_model(CASES[case]) if case in OPEN_CASES else CASES[case]


def fortran_run(case: str, method: str, rtol: float, atol: float | None = None) -> dict:
    """One timed integration by the Fortran core from the case's consistent start (the model is
    built once per case; the timing covers the integration alone)."""
    if case not in _PREPARED:
        _PREPARED[case] = prepared(case_model(case))
    model, q0, v0, t_end = _PREPARED[case]
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


PEER_GROUPS = ("scipy", "mujoco", "exudyn")


def peer_modules(which: str):
    """The SciPy peers (``which="scipy"``), MuJoCo (``"mujoco"``) or Exudyn (``"exudyn"``),
    each imported only when its turn comes: importing Exudyn slows the Fortran core in the same
    process by ~1.5x (measured: IDA on the decay case at rtol 1e-3, 8.9 -> 13.2 ms CPU, wall
    alike), so it is loaded after every other method has run.

    Returns {method: (knob, module, values, cases or None = every closed-chain case)}."""
    peers = {}
    try:
        if which == "scipy":
            from peers import scipy_route
            peers.update({m: ("rtol", scipy_route, SCIPY_RTOLS[m], None) for m in scipy_route.METHODS})
        elif which == "mujoco":
            from peers import mujoco_route
            peers.update({m: ("step", mujoco_route, MUJOCO_STEPS[m], (mujoco_route.CASE_OF[m],))
                          for m in mujoco_route.METHODS})
        else:
            from peers import exudyn_route
            peers["exudyn-genalpha"] = ("step", exudyn_route, EXUDYN_STEPS, None)
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
    ap.add_argument("--peers", nargs="+", choices=PEER_GROUPS, default=list(PEER_GROUPS),
                    help="peer groups to run")
    ap.add_argument("--stem", default="work_precision",
                    help="results file names benchmarks/results/STEM.csv/.md/.png (a subset run "
                         "should use its own, so the full results stay)")
    args = ap.parse_args(argv)
    OUT.mkdir(parents=True, exist_ok=True)
    rows, floors, refs = [], {}, {}

    def record(case, method, knob, value, res):
        ref = refs[case]
        ok = res.get("status") == "ok"
        if ok and res.get("steps", res.get("n_steps", 1)) <= 0:
            res, ok = {"status": f"no work done: {res.get('steps', res.get('n_steps'))} steps"}, False
        err = float(np.max(np.abs(np.asarray(res["cm_end"]) - ref["cm_end"]))) if ok else np.nan
        terr = (float(np.max(np.abs(np.asarray(res["cm_samples"]) - ref["cm_samples"])))
                if ok else np.nan)
        rerr = (float(np.max(np.abs(np.asarray(res["reactions_end"]) - ref["reactions_end"])))
                if ok else np.nan)
        if ok and not (np.isfinite(err) and np.isfinite(terr) and np.isfinite(res.get("cpu_s", np.nan))):
            res, ok = {"status": f"non-finite error or time: {err}, {terr}"}, False
            err = terr = rerr = np.nan
        rows.append({"case": case, "method": method, "knob": knob, "value": value,
                     "cpu_s": res.get("cpu_s", np.nan) if ok else np.nan, "cm_error_m": err,
                     "cm_traj_error_m": terr,
                     "reaction_error": rerr, "status": res.get("status", "?")[:120]})
        print(f"  {case[:21]:21s} {method:24s} {knob}={value:8.1e}  cpu {rows[-1]['cpu_s']:9.4f} s  "
              f"error {err:9.2e} m  trajectory {terr:9.2e} m  reactions {rerr:9.2e}  "
              f"{'' if ok else res.get('status')}", flush=True)

    for case in args.cases:
        t0 = time.perf_counter()
        ref = fortran_run(case, "rotorcable-IDA", 1e-12, 1e-12)
        check = fortran_run(case, "gsl-rk8pd", 1e-12, 1e-12)
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
                       median_run(lambda: fortran_run(case, method, rtol), args.repeat))
    for which in () if args.no_peers else [g for g in PEER_GROUPS if g in args.peers]:
        peers = peer_modules(which)
        if which == "mujoco" and peers and any(c in args.cases for p in peers.values() for c in p[3]):
            next(iter(peers.values()))[1].check_physics(CASES["uh60_part2_decay"])
        for method, (knob, module, values, cases) in peers.items():
            for case in args.cases:
                if (case not in cases) if cases else (case in OPEN_CASES):
                    continue
                for value in values:
                    try:
                        res = module.simulate(str(CASES[case]), method, value, n_samples=SAMPLES)
                    except Exception as exc:  # a peer failing is a data point, not a crash
                        res = {"status": f"{type(exc).__name__}: {exc}"}
                    record(case, method, knob, value, res)

    with open(OUT / f"{args.stem}.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    summary = write_table(rows, floors, args.stem)
    plot(rows, floors, args.stem)
    print(summary)
    return 0


def write_table(rows, floors, stem="work_precision") -> str:
    lines = ["| case | method | CPU to 1e-6 m at t_end [s] | ratio | CPU to 1e-6 m over the trajectory [s] | ratio "
             "| best trajectory error [m] |",
             "|---|---|---|---|---|---|---|"]
    for case in dict.fromkeys(r["case"] for r in rows):
        per = {}
        for m in dict.fromkeys(r["method"] for r in rows if r["case"] == case):
            rs = [r for r in rows if r["case"] == case and r["method"] == m]
            best = [r["cm_traj_error_m"] for r in rs if np.isfinite(r["cm_traj_error_m"])]
            per[m] = (time_to_target([r["cm_error_m"] for r in rs], [r["cpu_s"] for r in rs]),
                      time_to_target([r["cm_traj_error_m"] for r in rs], [r["cpu_s"] for r in rs]),
                      min(best) if best else np.nan)
        base = per.get("rotorcable-IDA", (np.nan, np.nan, np.nan))
        for m, (t_end, t_traj, best) in per.items():
            lines.append(f"| {case} | {m} | {t_end:.4g} | {t_end / base[0]:.3g} | {t_traj:.4g} | "
                         f"{t_traj / base[1]:.3g} | {best:.1e} |")
    lines.append("")
    lines.append("Reference error floor (IDA vs rk8pd at rtol 1e-12, max over the samples): "
                 + ", ".join(f"{c} {f:.1e} m" for c, f in floors.items()))
    text = "\n".join(lines) + "\n"
    (OUT / f"{stem}.md").write_text(text)
    return text


def plot(rows, floors, stem="work_precision"):
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
    fig.savefig(OUT / f"{stem}.png", dpi=120)


if __name__ == "__main__":
    sys.exit(main())
