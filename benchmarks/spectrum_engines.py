"""The shipped usage spectrum on the sweep engines: its wall time on the local process pool with 1
and 2 workers and on a local Slurm, and the share of it outside the regimes' own runs (issue 38).

Each engine runs the spectrum as a user does, into a fresh directory each time (a spectrum
directory would resume), timed end to end from the first command to the combined result:

  pool1, pool2  ``python -m pydriver spectrum DECK --out DIR --jobs N``
  slurm         ``python -m pydriver spectrum DECK --out DIR --slurm``, ``sbatch DIR/sweep.slurm``,
                waiting until squeue no longer lists the array (polled every 0.1 s), then the
                combining command that the first command printed (run by bash)

on a private single-node Slurm that this script starts and stops (``tests/slurm_cluster.py``:
Debian's slurm-wlm and munge, root needed; its node is this machine, as ``slurmd -C`` sees it).

Every run is checked to have done the work before its time counts: every regime's and the
run-up's record is in ``DIR/runs/`` (none an error), the summary names the deck's regimes, the
life is finite, the Slurm run's combining command ran nothing itself (``0 run now``), and
every engine's ``summary.json`` spectrum block is the first pool run's bit for bit.

What the regimes' own runs take is each record's ``wall_time_s`` (its refined run, every
level; ``pydriver/analyses/refinement.py``); their sum is the *work*.  On ``slots`` cores (the
workers, or the Slurm node's CPUs):

  outside share   1 - work / (wall x slots): the share of the slots' time not spent in a
                  regime's own run (process start-up, imports, deck reading and model builds,
                  writing the records, the pool's or Slurm's scheduling, combining the records,
                  and slots idle while the last regime finishes)
  above bound     1 - bound / wall, bound = max(longest record, work / slots): the share of the
                  wall time above the least any schedule of these runs could take on the slots
                  (the idle slots of an ideal schedule, which no engine can avoid, left out)

With one worker the two are the same number.  The times vary from run to run with the other
processes on the machine: the 1-minute load average before and after each engine is recorded.

Run from the project root (as root, for the Slurm engine):
  .venv/bin/python benchmarks/spectrum_engines.py                      # 3 runs each, ~5 min
  .venv/bin/python benchmarks/spectrum_engines.py --engines pool1 pool2 --repeat 5
Writes benchmarks/results/spectrum_engines.json and prints one line per engine.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import os
import platform
import re
import shlex
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))
sys.path.insert(0, str(ROOT / "tests"))

from harness import add_set_option, nested_sets, parse_sets  # noqa: E402

DECK = ROOT / "inputs" / "uh60_part2_spectrum.nml"
ENGINES = ("pool1", "pool2", "slurm")
# Seconds: a run of the shipped spectrum takes ~30 s on one core; the limit only turns a hang
# into an error.
RUN_TIMEOUT = 1800
MEASUREMENTS = {"wall_time_s", "wall_time_levels_s"}
# Keys whose value names a file relative to the deck: a deck rewritten by --set elsewhere takes them along.
FILE_KEYS = (("spectrum", "blade_file"), ("fatigue", "sn_file"))


class NoWorkDone(RuntimeError):
    """A run that did not do the whole spectrum: its time means nothing."""


def cli(*args, **kw) -> subprocess.CompletedProcess:
    """``python -m pydriver ARGS`` (text output captured; a failure is raised with it)."""
    proc = subprocess.run([sys.executable, "-m", "pydriver", *map(str, args)], capture_output=True, text=True,
                          timeout=RUN_TIMEOUT, check=False, **kw)
    if proc.returncode != 0:
        raise NoWorkDone(f"pydriver {' '.join(map(str, args))}: status {proc.returncode}\n{proc.stdout}{proc.stderr}")
    return proc


def deck_with_sets(deck: Path, sets: dict, tmp: Path) -> Path:
    """``deck``, or with ``--set`` values a copy in ``tmp`` beside copies of the files it names."""
    if not sets:
        return deck
    from pydriver.deckfile import read_deck
    from pydriver.study import override_deck
    copy = override_deck(deck, tmp / deck.name, nested_sets(sets))
    parsed = read_deck(copy)
    for group, key in FILE_KEYS:
        values = parsed[f"{group}.{key}"]
        for name in ([] if values is None else [values] if isinstance(values, str) else list(values)):
            if name and not Path(name).is_absolute():
                shutil.copy(deck.parent / name, tmp / name)
    return copy


def pool_run(deck: Path, out: Path, jobs: int, cluster=None) -> tuple[float, dict]:
    """Wall time of ``spectrum DECK --out OUT --jobs N`` (and no details)."""
    t0 = time.perf_counter()
    proc = cli("spectrum", deck, "--out", out, "--jobs", jobs)
    wall = time.perf_counter() - t0
    if "0 failed, 0 missing" not in proc.stdout:
        raise NoWorkDone(proc.stdout)
    return wall, {}


# slurmctld's log lines (Slurm 22.05) of an array task's start and end, with their times.
_ALLOCATE = re.compile(r"^\[(?P<time>[^\]]+)\] sched: Allocate JobId=(?P<job>\d+)_(?P<task>\d+)\(")
_COMPLETE = re.compile(r"^\[(?P<time>[^\]]+)\] _job_complete: JobId=(?P<job>\d+)_(?P<task>\d+)\(\d+\) done")


def array_timeline(log_text: str, job: str) -> dict:
    """``{task: (start, end)}`` in seconds of the array ``job``, from slurmctld's log: when the
    controller gave each task its CPU and when it saw it end (millisecond stamps)."""
    from datetime import datetime
    times: dict = {}
    for line in log_text.splitlines():
        for which, pattern in enumerate((_ALLOCATE, _COMPLETE)):
            m = pattern.match(line)
            if m and m["job"] == job:
                stamp = datetime.fromisoformat(m["time"]).timestamp()
                times.setdefault(int(m["task"]), [None, None])[which] = stamp
    return {task: tuple(t) for task, t in sorted(times.items()) if None not in t}


def _busy(timeline: dict, lo: float, hi: float) -> float:
    """Task-seconds of the timeline inside [lo, hi]."""
    return sum(max(0.0, min(b, hi) - max(a, lo)) for a, b in timeline.values())


def slurm_details(timeline: dict, records: list, slots: int, t_submit: float, t_done: float, t_end: float) -> dict:
    """Where the Slurm run's time went, in slot-seconds: ``task_outside_s`` the tasks' time
    beyond their records' own runs (bash, Python's start-up and imports, reading the spectrum
    directory, writing the record, the process's end); ``idle_pending_s`` slots idle while tasks
    were still pending (the controller starts the next task some 0.1-0.7 s after one ends);
    ``idle_tail_s`` slots idle after the last task started (nothing left to give them); and in
    seconds of wall time ``first_start_s`` from sbatch until the first task got its CPU,
    ``last_end_s`` from the last task's end until squeue no longer listed it, ``combine_s`` the
    combining command."""
    starts = [a for a, _ in timeline.values()]
    first, last_start, last_end = min(starts), max(starts), max(b for _, b in timeline.values())
    per_task = {str(k): {"task_s": b - a, "record_s": records[k], "outside_s": b - a - records[k]}
                for k, (a, b) in timeline.items()}
    return {"tasks": per_task, "task_outside_s": sum(t["outside_s"] for t in per_task.values()),
            "idle_pending_s": slots * (last_start - first) - _busy(timeline, first, last_start),
            "idle_tail_s": slots * (last_end - last_start) - _busy(timeline, last_start, last_end),
            "first_start_s": first - t_submit, "last_end_s": t_done - last_end, "combine_s": t_end - t_done}


def slurm_run(deck: Path, out: Path, jobs: int, cluster) -> tuple[float, dict]:
    """Wall time of ``spectrum --slurm``, ``sbatch``, the wait and the combining command, and
    where it went (:func:`slurm_details`)."""
    t0 = time.perf_counter()
    proc = cli("spectrum", deck, "--out", out, "--slurm")
    written = time.perf_counter() - t0
    lines = proc.stdout.splitlines()
    submit = next(ln for ln in lines if ln.startswith("submit:")).split(None, 1)[1]
    combine = next(ln for ln in lines if ln.startswith("when all tasks are done:")).split(":", 1)[1].strip()
    sbatch, script = shlex.split(submit)
    assert sbatch == "sbatch", submit
    t_submit = time.time()
    job = cluster.sbatch(script, cwd=out.parent)
    while cluster.jobs(job):
        if time.perf_counter() - t0 > RUN_TIMEOUT:
            raise NoWorkDone(f"job {job} not done after {RUN_TIMEOUT} s\n{cluster.logs()}")
        time.sleep(0.1)
    t_done = time.time()
    done = subprocess.run(["bash", "-c", combine], capture_output=True, text=True, timeout=RUN_TIMEOUT, check=False)
    wall = time.perf_counter() - t0
    manifest = json.loads((out / "sweep.json").read_text())
    records = [json.loads((out / "runs" / p["id"] / "summary.json").read_text())["wall_time_s"]
               if (out / "runs" / p["id"] / "summary.json").is_file() else math.nan for p in manifest["points"]]
    timeline = array_timeline((cluster.root / "slurmctld.log").read_text(errors="replace"), job)
    details = (slurm_details(timeline, records, jobs, t_submit, t_done, time.time()) if len(timeline) == len(records)
               else {"timeline": "not in slurmctld.log"})
    details["write_s"] = written
    # Every regime ran as an array task: the combining command found them all and ran none.
    if done.returncode != 0 or "0 failed, 0 missing (0 run now" not in done.stdout:
        logs = "".join(p.read_text() for p in sorted((out / "slurm").glob("*.out")))
        raise NoWorkDone(f"{combine}: status {done.returncode}\n{done.stdout}{done.stderr}\n{logs}")
    return wall, details


def without_measurements(value):
    if isinstance(value, dict):
        return {k: without_measurements(v) for k, v in value.items() if k not in MEASUREMENTS}
    if isinstance(value, list):
        return [without_measurements(v) for v in value]
    return value


def checked_records(deck: Path, out: Path) -> tuple[dict, dict]:
    """The run's summary and ``{regime: record wall time}``; raises NoWorkDone unless every point
    of the spectrum has its record, the summary names the deck's regimes and the life is finite."""
    from pydriver.deckfile import read_deck
    from pydriver.usage_spectrum import spectrum_of
    manifest = json.loads((out / "sweep.json").read_text())
    walls = {}
    for point in manifest["points"]:
        record = out / "runs" / point["id"] / "summary.json"
        if not record.is_file():
            raise NoWorkDone(f"{out}: no record of {point['values'][0]} ({record})")
        walls[point["values"][0]] = json.loads(record.read_text())["wall_time_s"]
    summary = json.loads((out / "summary.json").read_text())
    names = [r.name for r in spectrum_of(read_deck(deck)).regimes]
    if [r["name"] for r in summary["spectrum"]["regimes"]] != names or sorted(walls) != sorted([*names, "run-up"]):
        raise NoWorkDone(f"{out}: regimes {sorted(walls)}, the deck's {names} and the run-up")
    life = summary["spectrum"]["life_converged_hours"]
    if life is None or not math.isfinite(life):
        raise NoWorkDone(f"{out}: life {life}")
    return summary, walls


def shares(wall: float, walls: dict, slots: int) -> dict:
    """The outside share and the share above the bound (module docstring)."""
    work = sum(walls.values())
    bound = max(max(walls.values()), work / slots)
    return {"wall_s": wall, "work_s": work, "bound_s": bound, "outside_share": 1.0 - work / (wall * slots),
            "above_bound_share": 1.0 - bound / wall}


def load_average() -> float:
    return os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")


def cpu_model() -> str:
    with contextlib.suppress(OSError):
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    return platform.processor()


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--deck", default=str(DECK), help="a spectrum deck (default: the shipped one)")
    ap.add_argument("--engines", nargs="+", default=list(ENGINES), choices=ENGINES)
    ap.add_argument("--repeat", type=int, default=3, help="runs per engine; the median is reported")
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "spectrum_engines.json"))
    add_set_option(ap)
    args = ap.parse_args(argv)
    sets = parse_sets(args.sets)
    results = {"machine": {"cpus": os.cpu_count(), "cpu": cpu_model(), "python": sys.version.split()[0],
                           "platform": platform.platform()},
               "deck": str(Path(args.deck).resolve().relative_to(ROOT)) if Path(args.deck).resolve().is_relative_to(ROOT)
               else args.deck, "deck_overrides": sets, "repeat": args.repeat, "statistic": "median", "engines": {}}
    reference = None
    with tempfile.TemporaryDirectory(prefix="spectrum-engines-") as tmp, contextlib.ExitStack() as stack:
        tmp = Path(tmp)
        deck = deck_with_sets(Path(args.deck).resolve(), sets, tmp)
        cluster, slurm_slots = None, None
        if "slurm" in args.engines:
            from slurm_cluster import local_slurm
            cluster = stack.enter_context(local_slurm())
            slurm_slots = int(cluster.command("sinfo", "-h", "-o", "%c").stdout.split()[0])
        for engine in args.engines:
            run, slots = {"pool1": (pool_run, 1), "pool2": (pool_run, 2), "slurm": (slurm_run, slurm_slots)}[engine]
            runs, load_before = [], load_average()
            for k in range(args.repeat):
                out = tmp / f"{engine}-{k}" / "spectrum"
                out.parent.mkdir()
                wall, details = run(deck, out, slots, cluster)
                summary, walls = checked_records(deck, out)
                block = without_measurements(summary["spectrum"])
                if reference is None:
                    reference = block
                elif block != reference:
                    raise NoWorkDone(f"{engine}: its spectrum differs from the first run's")
                runs.append({**shares(wall, walls, slots), "records_s": walls,
                             "life_converged_hours": summary["spectrum"]["life_converged_hours"], **details})
                shutil.rmtree(out.parent)
            median = statistics.median(r["wall_s"] for r in runs)
            middle = min(runs, key=lambda r: abs(r["wall_s"] - median))
            entry = {"slots": slots, "wall_s": median, "wall_s_all": [r["wall_s"] for r in runs],
                     "work_s": statistics.median(r["work_s"] for r in runs),
                     "outside_share": statistics.median(r["outside_share"] for r in runs),
                     "above_bound_share": statistics.median(r["above_bound_share"] for r in runs),
                     "median_run": middle, "runs": runs,
                     "loadavg_1min_before": load_before, "loadavg_1min_after": load_average()}
            results["engines"][engine] = entry
            print(f"{engine}: {slots} slot{'s' if slots > 1 else ''}, wall {median:.2f} s (median of {args.repeat}: "
                  f"{', '.join(f'{w:.2f}' for w in entry['wall_s_all'])}), regimes' own runs {entry['work_s']:.2f} s, "
                  f"outside {100 * entry['outside_share']:.1f} %, above bound {100 * entry['above_bound_share']:.1f} %, "
                  f"load average {load_before:.1f} -> {entry['loadavg_1min_after']:.1f}", flush=True)
            if "task_outside_s" in middle:
                print("  where the slots' time outside the regimes' runs went (median run): "
                      + ", ".join(f"{key} {middle[key]:.2f} s" for key in (
                          "write_s", "first_start_s", "task_outside_s", "idle_pending_s", "idle_tail_s", "last_end_s",
                          "combine_s")), flush=True)
    results["life_converged_hours"] = reference["life_converged_hours"] if reference else None
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(results, indent=1) + "\n")
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
