"""Memory of a long output and speed of reading a large deck (issue 14, "Targets").

1. **One million output samples.**  The UH-60 part 2 decay deck (n = 11, 140 columns per
   sample) run for ``T_END`` = 10 s with dt_out = 1e-5 s (1 000 001 samples, 1.1 GB of values)
   and ``output_format = 'hdf5'``, by ``pydriver.run_deck(deck, out=...)`` in a child process.
   The time series streams to ``timeseries.h5`` in chunks (pydriver.output.TimeseriesWriter),
   so the child's memory must not grow with the number of samples.  Measured: the child's
   peak resident set (``os.wait4`` rusage of that child alone, ru_maxrss) and its wall time.
   Checked (else the benchmark fails loudly): the child succeeded, ``summary.json`` reports
   IDA steps > 0, the file holds every sample (h5py: the row count, the first and last time,
   times increasing).  Target: peak RSS < 500 MB (MB = 1e6 bytes).
2. **A 10 MB deck.**  A deck of ``--deck-bodies`` bodies (2000, the schema's limit) whose
   per-body lists (lengths, masses, diameters, start angles, springs, dampers, drag
   coefficients) are written one value per line with a comment line every few values, blade
   angle tables of ``--table-samples`` samples (&blade motion = 'table': times, flap, lag,
   pitch; a comment line per revolution), padded with comment blocks to ``--deck-mb`` MB,
   parsed and validated by ``pydriver.deckfile.read_deck`` (no model built); median of
   ``--repeat``.  Checked: the parsed deck has the bodies, the lists' and tables' lengths and
   their last values.  Target: < 1 s.

Each prints PASS or MISS; ``--strict`` makes a MISS exit with status 1.  Writes
benchmarks/results/memory.json.
Run:  .venv/bin/python benchmarks/memory.py            (about a minute; 1.1 GB in /tmp)
      .venv/bin/python benchmarks/memory.py --set solver.linear_solver=chain

Needs the core's test and benchmark probes: a build with the meson option ``probes`` on
(``bash .ci/setup``), not the product wheel (benchmarks/README.md).
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "benchmarks" / "results"
sys.path.insert(0, str(ROOT / "benchmarks"))

from harness import NoWorkDone, add_set_option, nested_sets, parse_sets  # noqa: E402

DECK = ROOT / "inputs" / "uh60_part2_decay.nml"
T_END, DT_OUT = 10.0, 1.0e-5          # 1 000 001 samples
TARGET_RSS_MB = 500.0
TARGET_PARSE_S = 1.0


def verdict(ok: bool) -> str:
    return "PASS" if ok else "MISS"


# --- 1. one million samples --------------------------------------------------------------------

def long_run_deck(path: Path, sets: dict) -> Path:
    from pydriver.study import override_deck
    changes = {"solver": {"t_end": repr(T_END), "dt_out": repr(DT_OUT), "output_format": "'hdf5'"}}
    for group, values in nested_sets(sets).items():
        changes.setdefault(group, {}).update(values)
    return override_deck(DECK, path, changes)


def child_run(deck: str, out: str) -> int:
    """In the child: the run as a user would start it, files written."""
    import pydriver
    pydriver.run_deck(deck, out=out)
    return 0


def million_samples(sets: dict, workdir: Path) -> dict:
    deck = long_run_deck(workdir / "long_decay.nml", sets)
    out = workdir / "run"
    t0 = time.perf_counter()
    proc = subprocess.Popen([sys.executable, __file__, "--child-run", str(deck), str(out)],
                            cwd=ROOT, stderr=subprocess.PIPE, text=True)
    # wait4: the rusage of this child alone (RUSAGE_CHILDREN would fold in every child so far).
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t0
    proc.returncode = os.waitstatus_to_exitcode(status)
    err = proc.stderr.read()
    if proc.returncode != 0:
        raise NoWorkDone(f"long run failed (exit {proc.returncode}):\n{err[-3000:]}")
    summary = json.loads((out / "summary.json").read_text())
    steps = int(summary["solver"]["steps"])
    n_samples = int(summary["n_samples"])
    h5file = out / "timeseries.h5"
    csvfile = out / "timeseries.csv"                  # with --set solver.output_format=csv
    if steps <= 0 or not (h5file.is_file() or csvfile.is_file()):
        raise NoWorkDone(f"long run: {steps} steps, no timeseries.h5 or timeseries.csv")
    if h5file.is_file():
        import h5py
        from pydriver.netcdf_layout import read_columns
        with h5py.File(h5file, "r") as h5:
            data = read_columns(h5)
            columns = list(data)
            rows = {len(v) for v in data.values()}
            t = data["t"]
    else:
        h5file = csvfile
        with open(csvfile) as fh:
            columns = [c.split(" [")[0] for c in fh.readline().strip().split(",")]
            t = np.array([float(line.split(",", 1)[0]) for line in fh])
        rows = {len(t)}
    expected = int(round(T_END / DT_OUT)) + 1
    if rows != {expected} or n_samples != expected or not np.all(np.diff(t) > 0) \
            or abs(t[0]) > 1e-12 or abs(t[-1] - T_END) > 1e-9:
        raise NoWorkDone(f"{h5file.name}: rows per column {sorted(rows)}, summary n_samples {n_samples}, "
                         f"expected {expected}; t from {t[0]} to {t[-1]}")
    size = h5file.stat().st_size
    return {"samples": expected, "columns": len(columns), "file": h5file.name, "file_bytes": size, "ida_steps": steps,
            "child_wall_s": wall, "child_peak_rss_mb": usage.ru_maxrss * 1024 / 1e6,
            "target_rss_mb": TARGET_RSS_MB,
            "verdict": verdict(usage.ru_maxrss * 1024 / 1e6 < TARGET_RSS_MB)}


# --- 2. a 10 MB deck -----------------------------------------------------------------------------

def _per_body(name: str, values, comment_every: int) -> list[str]:
    """``name = v1,`` then one value per line, a comment line every ``comment_every`` values."""
    lines = [f"  {name} ="]
    for k, v in enumerate(values):
        if k % comment_every == 0:
            lines.append(f"    ! {name}: bodies {k + 1} to {k + comment_every} (sleeve, clamp or plain cable)")
        lines.append(f"    {float(v)!r},")
    return lines


def big_deck_text(n: int, megabytes: float, table_samples: int) -> str:
    """A valid deck of n bodies and blade tables of ``table_samples`` samples, padded with
    comment blocks to about ``megabytes`` MB."""
    rng = np.random.default_rng(1)
    length = 0.59 / n
    body_length = length * (1.0 + 0.01 * rng.standard_normal(n))
    lines = ["! Synthetic large deck for benchmarks/memory.py: per-body lists, one value a line.",
             "&case", "  name = 'big_deck'", "  analysis = 'static'", "/", "&chain", f"  n_bodies = {n}"]
    lines += _per_body("body_length", list(body_length), 16)
    lines += _per_body("diameter", list(0.015 * (1.0 + 0.001 * rng.standard_normal(n))), 16)
    lines += _per_body("body_mass", list(0.313 / n * (1.0 + 0.01 * rng.standard_normal(n))), 16)
    lines += ["  first_body = 'clamped'", "/", "&shape"]
    lines += _per_body("gamma_deg", [90.0, 90.0] + [0.0] * (n - 2), 32)
    lines += _per_body("beta_deg", [70.0] + list(66.0 / (n - 1) * (1.0 + 1e-3 * rng.standard_normal(n - 1))), 32)
    lines += ["/", "&springs"]
    lines += _per_body("c_beta", list(35.531 * n / 11 * (1.0 + 0.01 * rng.standard_normal(n))), 16)
    lines += _per_body("d_beta", list(0.05 * np.ones(n)), 64)
    lines += _per_body("c_gamma", list(1e-4 * np.ones(n)), 64)
    lines += ["/", "&clamp_b", "  active = .false.", "/", "&drag"]
    lines += _per_body("cd", list(1.2 + 0.01 * rng.standard_normal(n)), 16)
    lines += ["/", "&blade", "  motion = 'table'"]
    t = np.arange(table_samples) * 1e-3
    psi = 2.0 * np.pi * 260.0 / 60.0 * t
    per_rev = 231                       # samples per revolution at 1 ms and 260 rpm
    lines += _per_body("table_t", list(t), per_rev)
    lines += _per_body("table_flap_deg", list(3.5 - np.cos(psi) + 0.5 * np.sin(psi)), per_rev)
    lines += _per_body("table_lag_deg", list(1.5 + 0.5 * np.cos(psi)), per_rev)
    lines += _per_body("table_pitch_deg", list(2.0 + 1.5 * np.cos(psi) - 6.0 * np.sin(psi)), per_rev)
    lines += ["/"]
    text = "\n".join(lines) + "\n"
    block = "\n".join(f"! note {k:4d}: " + "x" * 100 for k in range(64)) + "\n"
    pad = max(0, int(megabytes * 1e6) - len(text))
    return text + block * (pad // len(block) + 1)


def deck_parsing(n: int, megabytes: float, table_samples: int, repeat: int, workdir: Path) -> dict:
    from pydriver.deckfile import read_deck
    path = workdir / "big_deck.nml"
    path.write_text(big_deck_text(n, megabytes, table_samples))
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        deck = read_deck(path)
        times.append(time.perf_counter() - t0)
    # Did it parse what was written: the bodies and the lists' ends.
    lens = {k: len(deck[k]) for k in ("chain.body_length", "chain.diameter", "shape.beta_deg", "springs.c_beta",
                                      "drag.cd")}
    tables = {k: len(deck[k]) for k in ("blade.table_t", "blade.table_flap_deg", "blade.table_pitch_deg")}
    if deck.n_bodies != n or set(lens.values()) != {n} or deck["shape.gamma_deg"][1] != 90.0 \
            or set(tables.values()) != {table_samples} \
            or abs(deck["blade.table_t"][-1] - (table_samples - 1) * 1e-3) > 1e-12:
        raise NoWorkDone(f"big deck parsed wrongly: n_bodies {deck.n_bodies}, list lengths {lens}, "
                         f"table lengths {tables}")
    median = float(np.median(times))
    return {"bytes": path.stat().st_size, "bodies": n, "table_samples": table_samples, "parse_s_median": median, "parse_s_all": times,
            "target_s": TARGET_PARSE_S, "verdict": verdict(median < TARGET_PARSE_S)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--deck-bodies", type=int, default=2000)
    ap.add_argument("--table-samples", type=int, default=80000)
    ap.add_argument("--deck-mb", type=float, default=10.0)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--skip-long", action="store_true", help="deck parsing only")
    ap.add_argument("--strict", action="store_true", help="exit status 1 if a target is missed")
    ap.add_argument("--child-run", nargs=2, help=argparse.SUPPRESS)
    add_set_option(ap)
    args = ap.parse_args(argv)
    if args.child_run:
        return child_run(*args.child_run)
    sets = parse_sets(args.sets)
    report = {"deck_overrides": sets}
    with tempfile.TemporaryDirectory() as tmp:
        if not args.skip_long:
            r = report["million_samples"] = million_samples(sets, Path(tmp))
            print(f"{r['samples']} samples x {r['columns']} columns ({r['file_bytes'] / 1e6:.0f} MB {r['file']}), "
                  f"{r['ida_steps']} IDA steps, child wall {r['child_wall_s']:.1f} s: peak RSS "
                  f"{r['child_peak_rss_mb']:.0f} MB (< {TARGET_RSS_MB:g} MB): {r['verdict']}", flush=True)
        d = report["deck_parsing"] = deck_parsing(args.deck_bodies, args.deck_mb, args.table_samples, args.repeat,
                                                          Path(tmp))
        print(f"deck of {d['bytes'] / 1e6:.1f} MB, {d['bodies']} bodies, tables of {d['table_samples']} samples: read_deck {d['parse_s_median']:.3f} s "
              f"(median of {args.repeat}; < {TARGET_PARSE_S:g} s): {d['verdict']}")
    OUT.mkdir(parents=True, exist_ok=True)
    (OUT / "memory.json").write_text(json.dumps(report, indent=2) + "\n")
    missed = any(v.get("verdict") == "MISS" for v in report.values() if isinstance(v, dict))
    return 1 if (args.strict and missed) else 0


if __name__ == "__main__":
    sys.exit(main())
