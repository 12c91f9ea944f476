"""Sweeps on a real Slurm (issue 38, item 5): the job array and dask-jobqueue.

Each test runs a small static sweep of the UH-60 part 2 cable on the session's private
single-node Slurm (the ``slurm`` fixture of ``conftest.py``, ``tests/slurm_cluster.py``) as a
user would: ``python -m pydriver sweep ... --slurm``, ``sbatch DIR/sweep.slurm``, wait,
``python -m pydriver sweep-collect DIR``; or through a ``dask_jobqueue.SLURMCluster``.  The
same sweep on the local pool is the reference.  Every engine runs the same task
(``pydriver.sweep.records.run_task``) on the same decks with single-threaded BLAS, so the
results must be equal bit for bit: every record's files byte for byte, ``summary.json`` and
``sweep.csv`` too except the wall times, which are measurements, not results.

The helpers take any base deck and grid, so that other analyses (a spectrum) can be checked
on the cluster the same way.
"""

from __future__ import annotations

import csv
import json
import os
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import INPUTS
from pydriver.output_columns import bare_name

DECK = INPUTS / "uh60_part2.nml"                 # static: a task takes ~1 s, mostly start-up
GRID = ["springs.c_beta=10:70:4"]                 # 4 points: 10, 30, 50, 70
N_POINTS = 4
# Seconds.  Four tasks of ~1 s on two cores (or two Dask worker jobs starting); the limits only
# turn a hang into a failure with the daemons' logs.
JOB_TIMEOUT = 300
# Differ from run to run: not compared (a refined run also times each level).
MEASUREMENTS = {"wall_time_s", "wall_time_levels_s"}


def pydriver_cli(*args, timeout=JOB_TIMEOUT, **kw) -> subprocess.CompletedProcess:
    """``python -m pydriver ARGS`` in a subprocess (text output captured)."""
    return subprocess.run([sys.executable, "-m", "pydriver", *map(str, args)], capture_output=True,
                          text=True, timeout=timeout, **kw)


def sweep_args(deck, grid, out) -> list[str]:
    """The ``sweep`` command line of ``deck`` over ``grid`` into ``out`` (no plots: they only
    slow the tests down, and PNGs are not numbers)."""
    sets = [a for spec in grid for a in ("--set", spec)]
    return ["sweep", str(deck), *sets, "--out", str(out), "--quiet", "--no-plots"]


def pool_sweep(deck, grid, out) -> Path:
    """The sweep of ``deck`` over ``grid`` on the local pool, into ``out``."""
    proc = pydriver_cli(*sweep_args(deck, grid, out))
    assert proc.returncode == 0, proc.stdout + proc.stderr
    return Path(out)


def write_slurm_sweep(deck, grid, out) -> Path:
    """``sweep --slurm``: the decks and ``out/sweep.slurm``; returns the script's path."""
    proc = pydriver_cli(*sweep_args(deck, grid, out), "--slurm")
    assert proc.returncode == 0, proc.stdout + proc.stderr
    script = Path(out) / "sweep.slurm"
    # The submit command it prints, as a shell reads it, is sbatch of the script.
    submit = next(ln for ln in proc.stdout.splitlines() if ln.startswith("submit:")).split(None, 1)[1]
    assert shlex.split(submit) == ["sbatch", str(script)], proc.stdout
    return script


def collect(out) -> subprocess.CompletedProcess:
    """``sweep-collect out`` (no plots)."""
    return pydriver_cli("sweep-collect", out, "--no-plots")


def slurm_sweep(slurm, deck, grid, out, cwd) -> str:
    """The sweep of ``deck`` over ``grid`` on ``slurm`` as a user runs it: write the script,
    ``sbatch`` it from ``cwd``, wait for the array, collect.  Returns the job id."""
    job = slurm.sbatch(write_slurm_sweep(deck, grid, out), cwd=cwd)
    slurm.wait(job, JOB_TIMEOUT)
    proc = collect(out)
    assert proc.returncode == 0, proc.stdout + proc.stderr + slurm.logs()
    return job


def read_table(path) -> list[dict]:
    """``sweep.csv`` rows keyed by bare column name (the header carries units), as text."""
    with open(path, newline="") as fh:
        return [{bare_name(k): v for k, v in row.items()} for row in csv.DictReader(fh)]


def without_measurements(value):
    """``value`` (a parsed ``summary.json``) without the keys of :data:`MEASUREMENTS`."""
    if isinstance(value, dict):
        return {k: without_measurements(v) for k, v in value.items() if k not in MEASUREMENTS}
    if isinstance(value, list):
        return [without_measurements(v) for v in value]
    return value


def assert_same_sweep(out, reference) -> None:
    """The sweeps in ``out`` and ``reference`` have the same results, bit for bit.

    ``sweep.csv``: the same columns and rows, every value the same text (Python writes the
    shortest text that reads back as the same double, so equal text is equal bits), the
    measurements excepted.  Each record as :func:`assert_same_records` compares them.
    """
    rows, ref_rows = read_table(out / "sweep.csv"), read_table(reference / "sweep.csv")
    assert list(rows[0]) == list(ref_rows[0])
    assert [r["id"] for r in rows] == [r["id"] for r in ref_rows]
    for row, ref in zip(rows, ref_rows):
        differ = {k: (row[k], ref[k]) for k in row if k not in MEASUREMENTS and row[k] != ref[k]}
        assert not differ, (row["id"], differ)
    assert_same_records(out, reference)


def assert_same_records(out, reference) -> None:
    """Every record ``runs/<id>/`` of ``out`` and ``reference``: the same ids, the same files,
    each byte for byte, but ``summary.json`` compared parsed without the measurements, and the
    marker (which names the directory it was written in) only present."""
    ids = sorted(p.name for p in (reference / "runs").iterdir())
    assert sorted(p.name for p in (out / "runs").iterdir()) == ids
    for id_ in ids:
        run, ref_run = out / "runs" / id_, reference / "runs" / id_
        names = sorted(p.name for p in run.iterdir())
        assert names == sorted(p.name for p in ref_run.iterdir()), run
        for name in names:
            if name == ".rotorcable-run.json":
                continue
            if name == "summary.json":
                mine, theirs = (without_measurements(json.loads((d / name).read_text())) for d in (run, ref_run))
                assert mine == theirs, run / name
            else:
                assert (run / name).read_bytes() == (ref_run / name).read_bytes(), run / name


def record_stamps(out) -> dict:
    """``runs/<id>/<file>`` -> (inode, mtime in ns) of every file of every record: a record
    written again has new ones."""
    return {str(p.relative_to(out)): (p.stat().st_ino, p.stat().st_mtime_ns)
            for p in sorted((Path(out) / "runs").rglob("*")) if p.is_file()}


def task_logs(out, job) -> dict:
    """Array index -> the text of its Slurm log ``out/slurm/<job>_<index>.out``."""
    return {int(p.stem.split("_")[1]): p.read_text() for p in (Path(out) / "slurm").glob(f"{job}_*.out")}


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The sweep on the local pool."""
    return pool_sweep(DECK, GRID, tmp_path_factory.mktemp("pool") / "sweep")


# A directory name with what sbatch reads in an #SBATCH line (space, quotes, '#', and '%A_%a'
# of its --output patterns) and what bash expands: tests/test_sweep_faults.py checks the script
# against a copy of sbatch's parser, this against sbatch itself.
AWKWARD_NAME = """a b%A_%a #c"d'e$(x)`y`"""


def test_slurm_array_equals_pool(slurm, reference, tmp_path):
    out = tmp_path / AWKWARD_NAME
    job = slurm_sweep(slurm, DECK, GRID, out, cwd=tmp_path)
    # One array task per point, each ran its deck and said so in its log, where the script
    # said: out/slurm/<job>_<task>.out.
    assert [p.name for p in tmp_path.iterdir()] == [AWKWARD_NAME]
    logs = task_logs(out, job)
    assert sorted(logs) == list(range(N_POINTS))
    for index, text in logs.items():
        assert f"{index:04d}: ok" in text, text
    assert_same_sweep(out, reference)


def test_cancelled_task_is_resubmitted_alone(slurm, reference, tmp_path):
    # Array task 2 is cancelled before it starts (held array: deterministic), the others run.
    out = tmp_path / "sweep"
    script = write_slurm_sweep(DECK, GRID, out)
    job = slurm.sbatch(script, "--hold", cwd=tmp_path)
    slurm.wait_until(job, {"PENDING"}, JOB_TIMEOUT)
    slurm.command("scancel", f"{job}_2")
    slurm.command("scontrol", "release", job)
    slurm.wait(job, JOB_TIMEOUT)
    assert sorted(task_logs(out, job)) == [0, 1, 3]
    proc = collect(out)
    assert proc.returncode == 1, proc.stdout + proc.stderr
    assert f"{N_POINTS} points, 3 ok, 0 failed, 1 missing" in proc.stdout
    assert sorted(p.name for p in (out / "runs").iterdir()) == ["0000", "0001", "0003"]
    before = record_stamps(out)
    # The project's resume: the same `sweep --slurm` again writes an array of the missing ids.
    assert "#SBATCH --array=2\n" in write_slurm_sweep(DECK, GRID, out).read_text()
    again = slurm.sbatch(script, cwd=tmp_path)
    slurm.wait(again, JOB_TIMEOUT)
    assert list(task_logs(out, again)) == [2] and "0002: ok" in task_logs(out, again)[2]
    after = record_stamps(out)
    assert {k: v for k, v in after.items() if not k.startswith("runs/0002/")} == before
    proc = collect(out)
    assert proc.returncode == 0 and f"{N_POINTS} points, {N_POINTS} ok" in proc.stdout, proc.stdout
    assert_same_sweep(out, reference)


def test_dask_jobqueue_workers_on_slurm(slurm, reference, tmp_path, monkeypatch):
    from dask_jobqueue import SLURMCluster
    from distributed import Client

    # SLURMCluster submits, lists and cancels its worker jobs with sbatch/squeue/scancel from
    # this process: they must reach the private cluster.
    for name in set(os.environ) - set(slurm.env):
        monkeypatch.delenv(name)
    for name, value in slurm.env.items():
        monkeypatch.setenv(name, value)
    out = tmp_path / "sweep"
    with SLURMCluster(cores=1, processes=1, memory="512MB", walltime="00:15:00", queue=slurm.partition,
                      python=sys.executable,
                      # One machine: the loopback; no dashboard (a fixed port may be taken).
                      scheduler_options={"host": "127.0.0.1", "dashboard_address": None},
                      log_directory=str(tmp_path / "worker-logs"),
                      local_directory=str(tmp_path / "worker-space")) as cluster:
        cluster.scale(jobs=2)
        with Client(cluster) as client:
            client.wait_for_workers(2, timeout=JOB_TIMEOUT)
        # The two workers are Slurm jobs of the cluster, running.
        jobs = slurm.command("squeue", "-h", "-o", "%j %T").stdout.split("\n")[:-1]
        assert jobs == ["dask-worker RUNNING"] * 2, jobs
        proc = pydriver_cli(*sweep_args(DECK, GRID, out), "--dask", cluster.scheduler_address)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert f"{N_POINTS} points, {N_POINTS} ok" in proc.stdout
    assert_same_sweep(out, reference)
