"""Work-precision in forward flight: rotorcable against Exudyn (issue 14, "Targets").

Case ``flight``: UH-60 part 2 in forward flight (inputs/uh60_part2_forward_flight.nml) refined to
``--n`` bodies (default 44; springs and dampers per joint scaled by n/11 so the cable's EI, GJ
and damping per length stay, peers/exudyn_flight.flight_model), ``--revolutions`` revolutions
(default 10) from rotorcable's flight start (equilibrium of the loads at t = 0, made
consistent with the moving blade clamp).  Error = the largest CM distance, hub frame, over
``SAMPLES_PER_REV`` samples per revolution, against rotorcable-IDA at rtol 1e-10 (atol 1e-12);
its distance to rtol 1e-9 is printed as a bound on its own error.  rotorcable: IDA at
a range of rtol (atol = rtol/100), CPU time of the integration alone (harness.timed_run),
median of ``--repeat``.  Exudyn: peers/exudyn_flight.py (inertial frame, prescribed rotor and
blade hinges, drag through a Python force user function), default generalized-alpha at fixed
steps of period/k for k in ``--exudyn-steps-per-rev``, CPU time of SolveDynamic, one run each.

Case ``decay`` (kept from work_precision.py so both ratios come from one run): UH-60 part 2
decay, n = 11, 1 s, the same measures against rotorcable at rtol 1e-12
(work_precision.fortran_run, peers/exudyn_route.py); rotorcable from rtol 1e-2, the mean of
its sweeps over the tolerances repeated for ``--decay-seconds`` (decay_case says why); Exudyn
at the steps of ``--decay-exudyn-steps``, medians of ``--peer-repeat``.

Reported: CPU time to reach ``TARGET`` = 1e-6 m (log-log interpolation, work_precision.
time_to_target) and the ratio Exudyn / rotorcable at equal error; targets >= 30x (flight) and
>= 80x (decay), PASS/MISS.  Every run is checked for work done (steps > 0, finite answer).
Writes benchmarks/results/flight_precision.csv and .json (flight_precision_flight.* or
flight_precision_decay.* when one case runs alone).

Run:  .venv/bin/python benchmarks/flight_precision.py                 (n = 44, 10 rev: hours,
      Exudyn's Python drag dominates; see README)
      .venv/bin/python benchmarks/flight_precision.py --n 11 --revolutions 1     (minutes)
      ... --set solver.linear_solver=chain   (deck override for the rotorcable runs)

Needs the core's test and benchmark probes: a build with the meson option ``probes`` on
(``bash .ci/setup``), not the product wheel (benchmarks/README.md).
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse
import csv
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "benchmarks" / "results"
sys.path.insert(0, str(ROOT / "benchmarks"))
sys.path.insert(0, str(ROOT / "benchmarks" / "peers"))

from harness import NoWorkDone, add_set_option, parse_sets, timed_run  # noqa: E402
from work_precision import time_to_target  # noqa: E402

FLIGHT_DECK = ROOT / "inputs" / "uh60_part2_forward_flight.nml"
DECAY_DECK = ROOT / "inputs" / "uh60_part2_decay.nml"
TARGET = 1e-6
SAMPLES_PER_REV = 10
RTOLS = (1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9)
TARGET_RATIO = {"flight": 30.0, "decay": 80.0}


def verdict(ratio: float, target: float) -> str:
    return "NOT REACHED" if not np.isfinite(ratio) else ("PASS" if ratio >= target else "MISS")


def flight_case(args, sets, rows, info) -> callable:
    """rotorcable's runs now; returns the Exudyn part, to be run after every rotorcable run."""
    from flight_scene import flight_model, flight_start
    model = flight_model(FLIGHT_DECK, args.n, sets)
    q0, v0 = flight_start(model)
    omega = float(model.description["rotor"]["speed"]["omega"])
    period = 2.0 * np.pi / omega
    t_end = args.revolutions * period
    samples = args.revolutions * SAMPLES_PER_REV + 1
    t0 = time.perf_counter()
    ref = timed_run(model, q0, v0, t_end, rtol=1e-10, atol=1e-12, samples=samples)
    # Its error is bounded by its distance to a 10x looser run (rtol 1e-11 fails at n = 44:
    # IDA's corrector stalls on round-off).
    loose = timed_run(model, q0, v0, t_end, rtol=1e-9, atol=1e-11, samples=samples)
    floor = float(np.max(np.abs(loose["cm_samples"] - ref["cm_samples"])))
    print(f"flight n = {args.n}, {args.revolutions} rev ({t_end:.3f} s): reference rtol 1e-10 in "
          f"{time.perf_counter() - t0:.1f} s ({ref['stats']['steps']} steps), vs rtol 1e-9: {floor:.1e} m",
          flush=True)

    def add(method, knob, value, cpu, err, steps, status="ok"):
        rows.append({"case": "flight", "n": args.n, "method": method, "knob": knob, "value": value,
                     "cpu_s": cpu, "cm_traj_error_m": err, "steps": steps, "status": status})
        print(f"  flight {method:16s} {knob}={value:9.3g} cpu {cpu:9.4f} s  error {err:9.2e} m  "
              f"{steps} steps {'' if status == 'ok' else status}", flush=True)

    for rtol in RTOLS:
        runs = [timed_run(model, q0, v0, t_end, rtol=rtol, samples=samples) for _ in range(args.repeat)]
        err = float(np.max(np.abs(runs[0]["cm_samples"] - ref["cm_samples"])))
        add("rotorcable-IDA", "rtol", rtol, float(np.median([r["cpu_s"] for r in runs])), err,
            runs[0]["stats"]["steps"])
    info["flight"] = {"reference_floor_m": floor, "t_end_s": t_end, "reference_steps": ref["stats"]["steps"]}

    def peer():
        import exudyn_flight as ef
        for k in args.exudyn_steps_per_rev:
            if k % SAMPLES_PER_REV:
                raise SystemExit(f"--exudyn-steps-per-rev {k}: must be a multiple of {SAMPLES_PER_REV}")
            r = ef.simulate(model, q0, v0, period / k, t_end, samples, symbolic=not args.python_uf)
            if r["status"] != "ok":
                add("exudyn-genalpha", "steps/rev", k, np.nan, np.nan, r.get("n_steps", 0), r["status"])
                continue
            err = float(np.max(np.abs(r["cm_samples"] - ref["cm_samples"])))
            add("exudyn-genalpha", "steps/rev", k, r["cpu_s"], err, r["n_steps"])
            info["flight"]["exudyn_symbolic_user_functions"] = r.get("symbolic")
    return peer


def decay_case(args, sets, rows, info) -> callable:
    """rotorcable's runs now; returns the Exudyn part."""
    import work_precision as wp
    deck = DECAY_DECK
    if sets:
        import tempfile

        from harness import nested_sets
        from pydriver.study import override_deck
        deck = override_deck(DECAY_DECK, Path(tempfile.mkdtemp()) / DECAY_DECK.name, nested_sets(sets))
    ref = wp.fortran_run(deck, "rotorcable-IDA", 1e-12, 1e-12)
    if ref["status"] != "ok":
        raise NoWorkDone(f"decay reference: {ref['status']}")

    def add(method, knob, value, res):
        ok = res.get("status") == "ok"
        err = float(np.max(np.abs(np.asarray(res["cm_samples"]) - ref["cm_samples"]))) if ok else np.nan
        rows.append({"case": "decay", "n": 11, "method": method, "knob": knob, "value": value,
                     "cpu_s": res.get("cpu_s", np.nan) if ok else np.nan, "cm_traj_error_m": err,
                     "steps": res.get("steps", res.get("n_steps", 0)), "status": res.get("status", "?")[:120]})
        print(f"  decay  {method:16s} {knob}={value:9.3g} cpu {rows[-1]['cpu_s']:9.4f} s  error {err:9.2e} m",
              flush=True)

    # From rtol 1e-2: at 1e-3 the error is already below the 1e-6 m target (6.8e-7 m), so
    # without the looser settings the time to the target could not be interpolated for
    # rotorcable as it is for Exudyn, only taken at the first setting below it.
    # This VM has phases of ~1 s in which everything runs 1.5-1.8x slower (the same integration
    # timed back to back: 9, 16, 9, 14 ms), so ratios of single short runs ranged 54-108x.  A
    # sweep over the tolerances is ~0.2 s; the sweeps repeat round-robin for at least
    # --decay-seconds, and rotorcable's time is the MEAN over them: each Exudyn run is long
    # (0.7-3 s) and so already averages over the phases, and a median of the short runs would
    # pick the fast phases for rotorcable alone.
    rtols = (1e-2, 3e-3, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7)
    sweeps, t_start = [], time.perf_counter()
    while len(sweeps) < args.repeat or time.perf_counter() - t_start < args.decay_seconds:
        sweeps.append([wp.fortran_run(deck, "rotorcable-IDA", rtol) for rtol in rtols])
    info["decay"] = {"rotorcable_sweeps": len(sweeps)}
    for i, rtol in enumerate(rtols):
        runs = [sweep[i] for sweep in sweeps]
        res = dict(runs[0])
        if res["status"] == "ok":
            res["cpu_s"] = float(np.mean([r["cpu_s"] for r in runs]))
        add("rotorcable-IDA", "rtol", rtol, res)
    def peer():
        from peers import exudyn_route
        # Median of --peer-repeat runs as for rotorcable: single Exudyn runs of this case vary by
        # ~35 % on the 2-core VM (0.75 and 1.01 s for the same step in two runs).
        for h in args.decay_exudyn_steps:
            add("exudyn-genalpha", "step", h,
                wp.median_run(lambda: exudyn_route.simulate(str(deck), "exudyn-genalpha", h, n_samples=wp.SAMPLES),
                              args.peer_repeat))
    return peer


def ratios(rows) -> dict:
    """Exudyn / rotorcable CPU time to the error TARGET, per case.  Where Exudyn's finest setting
    is still above the target (a 10-revolution run at n = 44 costs it over an hour per setting),
    its time to the target is at least that setting's time (errors fall with the step), and the
    ratio is reported as that lower bound ("ratio_is_lower_bound")."""
    out = {}
    for case in dict.fromkeys(r["case"] for r in rows):
        t, rs = {}, {}
        for m in ("rotorcable-IDA", "exudyn-genalpha"):
            rs[m] = [r for r in rows if r["case"] == case and r["method"] == m and np.isfinite(float(r["cpu_s"]))]
            t[m] = time_to_target([float(r["cm_traj_error_m"]) for r in rs[m]], [float(r["cpu_s"]) for r in rs[m]],
                                  TARGET)
        lower = False
        if not np.isfinite(t["exudyn-genalpha"]) and rs["exudyn-genalpha"]:
            t["exudyn-genalpha"] = max(float(r["cpu_s"]) for r in rs["exudyn-genalpha"])
            lower = True
        ratio = t["exudyn-genalpha"] / t["rotorcable-IDA"]
        out[case] = {"rotorcable_cpu_s": t["rotorcable-IDA"], "exudyn_cpu_s": t["exudyn-genalpha"],
                     "ratio": ratio, "ratio_is_lower_bound": lower, "target": TARGET_RATIO[case],
                     "verdict": verdict(ratio, TARGET_RATIO[case])}
    return out


def print_ratio(case: str, r: dict) -> None:
    bound = "at least " if r["ratio_is_lower_bound"] else ""
    print(f"{case}: CPU to {TARGET:g} m: rotorcable {r['rotorcable_cpu_s']:.4g} s, Exudyn {bound}"
          f"{r['exudyn_cpu_s']:.4g} s, ratio {bound}{r['ratio']:.3g} (>= {r['target']:g}): {r['verdict']}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cases", nargs="+", default=["flight", "decay"], choices=["flight", "decay"])
    ap.add_argument("--n", type=int, default=44)
    ap.add_argument("--revolutions", type=int, default=10)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--peer-repeat", type=int, default=3, help="repeats of each Exudyn decay run (median)")
    ap.add_argument("--decay-seconds", type=float, default=20.0,
                    help="least time over which rotorcable's decay runs repeat (their mean is taken)")
    ap.add_argument("--exudyn-steps-per-rev", type=int, nargs="+", default=[250, 500, 1000, 2000])
    ap.add_argument("--decay-exudyn-steps", type=float, nargs="+", default=[5e-4, 2e-4, 1e-4])
    ap.add_argument("--python-uf", action="store_true",
                    help="prescribed angles as Python user functions even if symbolic ones work")
    ap.add_argument("--strict", action="store_true", help="exit status 1 if a target is missed")
    ap.add_argument("--ratios-from", type=Path, metavar="CSV",
                    help="only the ratios and verdicts again, from a CSV this script wrote")
    add_set_option(ap)
    args = ap.parse_args(argv)
    if args.ratios_from:
        with open(args.ratios_from, newline="") as fh:
            for case, r in ratios(list(csv.DictReader(fh))).items():
                print_ratio(case, r)
        return 0
    sets = parse_sets(args.sets)
    rows, info = [], {"deck_overrides": sets}
    # Every rotorcable run first, then the Exudyn runs: importing Exudyn slows the Fortran core
    # in the same process by ~1.5x (work_precision.peer_modules).
    peers = [(decay_case if case == "decay" else flight_case)(args, sets, rows, info) for case in args.cases]
    for peer in peers:
        peer()
    OUT.mkdir(parents=True, exist_ok=True)
    # One case alone gets its own files, so a decay-only run does not overwrite a flight run
    # that took hours (and the other way round).
    stem = "flight_precision" + ("" if len(set(args.cases)) == 2 else "_" + args.cases[0])
    with open(OUT / f"{stem}.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    res = ratios(rows)
    info["ratios"] = res
    info["settings"] = {"n": args.n, "revolutions": args.revolutions, "repeat": args.repeat}
    (OUT / f"{stem}.json").write_text(json.dumps(info, indent=2) + "\n")
    for case, r in res.items():
        print_ratio(case, r)
    missed = any(r["verdict"] != "PASS" for r in res.values())
    return 1 if (args.strict and missed) else 0


if __name__ == "__main__":
    sys.exit(main())
