"""A usage spectrum on a real Slurm (issue 38, items 4 and 5): the job array as a user runs it.

``rotorcable spectrum DECK --out DIR --slurm`` writes the regimes' decks and ``DIR/sweep.slurm``
and prints two commands: ``sbatch DIR/sweep.slurm`` and, for when every task is done, the
command that combines the records (``rotorcable spectrum DECK --out DIR`` again).  The tests
run both on the session's private single-node Slurm (the ``slurm`` fixture,
``tests/slurm_cluster.py``), the combining command through bash as a user pastes it, and
compare the spectrum with the same deck's run on the local pool (``--jobs 2``) bit for bit:
``summary.json`` without its wall times, ``spectrum.csv`` and ``refinement.csv`` byte for byte,
every regime's record too (the engines run the same task, ``pydriver.sweep.records.run_task``,
with single-threaded BLAS: tests/test_slurm.py).  The Dask path (``spectrum --dask``) runs on
workers that dask-jobqueue starts as jobs of the same Slurm.

The deck is small, as tests/test_spectrum.py's (a 4-body cable, refined to 8 bodies, 16
samples per revolution): what is tested is the path through Slurm, which is the same at any
size.  One regime, ``fine``, samples its revolution 6144 times (~2-4 s on the 2-core VM,
against ~0.3 s for the others), so that the task cancelled halfway is still running when
``scancel`` reaches it.
"""

from __future__ import annotations

import json
import os
import shlex
import subprocess
import sys
import time
from pathlib import Path

import pytest

from test_slurm import (
    AWKWARD_NAME,
    JOB_TIMEOUT,
    assert_same_records,
    pydriver_cli,
    record_stamps,
    task_logs,
    without_measurements,
)
from test_spectrum import spectrum_group, spectrum_text

SPECTRUM = spectrum_group({
    "regimes": "'cruise', 'fine'", "share": "0.6, 0.4", "forward_speed": "5.0, 15.0", "load_factor": "1.0, 1.3",
    "changes": "'', 'solver.samples_per_rev = 6144'", "flights_per_hour": "2.0", "runup_time": "0.5"})
#: Array index -> what it runs: the run-up, then the regimes in the deck's order.
POINTS = {0: "run-up", 1: "cruise", 2: "fine"}
FINE = 2
#: What the combined spectrum is: files of the engine or of Slurm (the task logs) are not.
RESULT_FILES = ("summary.json", "spectrum.csv", "refinement.csv")


def write_deck(directory: Path) -> Path:
    directory.mkdir(parents=True, exist_ok=True)
    deck = directory / "spectrum.nml"
    deck.write_text(spectrum_text(SPECTRUM, levels=2))
    return deck


def write_slurm_spectrum(deck, out) -> tuple[Path, str]:
    """``spectrum DECK --out OUT --slurm``: returns the script and the combining command it
    printed (shell text)."""
    proc = pydriver_cli("spectrum", deck, "--out", out, "--slurm")
    assert proc.returncode == 0, proc.stdout + proc.stderr
    lines = proc.stdout.splitlines()
    submit = next(ln for ln in lines if ln.startswith("submit:")).split(None, 1)[1]
    combine = next(ln for ln in lines if ln.startswith("when all tasks are done:")).split(":", 1)[1].strip()
    script = Path(out) / "sweep.slurm"
    assert shlex.split(submit) == ["sbatch", str(script)], proc.stdout
    return script, combine


def combine(command: str) -> subprocess.CompletedProcess:
    """The printed combining command, run by bash as a user pastes it."""
    return subprocess.run(["bash", "-c", command], capture_output=True, text=True, timeout=JOB_TIMEOUT)


def assert_same_spectrum(out: Path, reference: Path) -> None:
    """The spectra in ``out`` and ``reference`` are the same bit for bit: ``summary.json``
    parsed, without the wall times (measurements, not results; floats read back from JSON are
    the written doubles, so == is bitwise), ``spectrum.csv`` and ``refinement.csv`` byte for
    byte (every number written as the shortest text of its double), and every record."""
    for name in RESULT_FILES:
        mine, theirs = out / name, reference / name
        if name == "summary.json":
            assert (without_measurements(json.loads(mine.read_text()))
                    == without_measurements(json.loads(theirs.read_text())))
        else:
            assert mine.read_bytes() == theirs.read_bytes(), mine
    assert_same_records(out, reference)


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The spectrum on the local pool of 2 workers, as ``rotorcable spectrum --jobs 2`` runs it."""
    directory = tmp_path_factory.mktemp("pool")
    out = directory / "spectrum"
    proc = pydriver_cli("spectrum", write_deck(directory), "--out", out, "--jobs", "2")
    assert proc.returncode == 0, proc.stdout + proc.stderr
    summary = json.loads((out / "summary.json").read_text())["spectrum"]
    # It is a whole spectrum: both regimes and the ground-air-ground cycle (which spans the
    # run-up's record too) take damage at the worst point, and the life is refined.
    assert [r["name"] for r in summary["regimes"]] == ["cruise", "fine"]
    shares = summary["damage_shares"]
    assert min(shares["cruise"], shares["fine"], shares["ground-air-ground"]) > 0.0, shares
    assert [lv["n"] for lv in summary["levels"]] == [4, 8]
    return out


def test_spectrum_array_equals_pool(slurm, reference, tmp_path):
    out = tmp_path / AWKWARD_NAME
    deck = write_deck(tmp_path / f"deck {AWKWARD_NAME}")
    script, command = write_slurm_spectrum(deck, out)
    assert "#SBATCH --array=0-2\n" in script.read_text()
    job = slurm.sbatch(script, cwd=tmp_path)
    slurm.wait(job, JOB_TIMEOUT)
    logs = task_logs(out, job)
    assert sorted(logs) == sorted(POINTS)
    for index, text in logs.items():
        assert f"{index:04d}: ok" in text, text
    proc = combine(command)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    # The combining command found every record and ran nothing itself.
    assert "3 ok, 0 failed, 0 missing (0 run now, 3 done before)" in proc.stdout, proc.stdout
    assert_same_spectrum(out, reference)
    # No task wrote into the directory sbatch was run from.
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([AWKWARD_NAME, f"deck {AWKWARD_NAME}"])


def _wait_for_run_to_start(runs: Path, id_: str, timeout: float) -> None:
    """Until ``runs`` holds the hidden directory that task ``id_`` makes its record in
    (``.<id>.<pid>.<random>``, pydriver.sweep.records.run_task): its regime is running."""
    deadline = time.monotonic() + timeout
    while not (runs.is_dir() and any(p.name.startswith(f".{id_}.") for p in runs.iterdir())):
        assert not (runs / id_).exists(), f"{runs / id_} finished before it could be cancelled"
        assert time.monotonic() < deadline, f"task {id_} did not start in {timeout} s"
        time.sleep(0.05)


def test_a_regime_cancelled_halfway_is_resubmitted_alone(slurm, reference, tmp_path):
    deck = write_deck(tmp_path)
    out = tmp_path / "spectrum"
    script, command = write_slurm_spectrum(deck, out)
    job = slurm.sbatch(script, cwd=tmp_path)
    # The fine regime's task is cancelled while its run is under way; the others finish.
    _wait_for_run_to_start(out / "runs", f"{FINE:04d}", JOB_TIMEOUT)
    slurm.command("scancel", f"{job}_{FINE}")
    slurm.wait(job, JOB_TIMEOUT)
    logs = task_logs(out, job)
    assert sorted(logs) == sorted(POINTS)
    for index, text in logs.items():
        assert (f"{index:04d}: ok" in text) == (index != FINE), (index, text)
    assert "CANCELLED" in logs[FINE], logs[FINE]              # slurmstepd's line: it was scancel
    # A record is whole or absent: the cancelled regime has none, the others theirs, and no
    # result of the spectrum is written.
    assert sorted(p.name for p in (out / "runs").iterdir() if not p.name.startswith(".")) == ["0000", "0001"]
    assert not any((out / name).exists() for name in RESULT_FILES)
    before = record_stamps(out)
    # The resume: the same `spectrum --slurm` writes an array of the regime without a record.
    script, command = write_slurm_spectrum(deck, out)
    assert f"#SBATCH --array={FINE}\n" in script.read_text()
    again = slurm.sbatch(script, cwd=tmp_path)
    slurm.wait(again, JOB_TIMEOUT)
    assert list(task_logs(out, again)) == [FINE] and f"{FINE:04d}: ok" in task_logs(out, again)[FINE]
    # The other records are untouched; what the cancelled task was making (``runs/.0002.*`` and
    # its temporary ``runs/..0002.*``, left by its killed process) is its own and is gone once
    # the resubmitted task has run.
    cancelled = (f"runs/{FINE:04d}/", f"runs/.{FINE:04d}.", f"runs/..{FINE:04d}.")
    assert ({k: v for k, v in record_stamps(out).items() if not k.startswith(cancelled)}
            == {k: v for k, v in before.items() if not k.startswith(cancelled)})
    proc = combine(command)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "3 ok, 0 failed, 0 missing (0 run now, 3 done before)" in proc.stdout, proc.stdout
    # What the cancelled task was making is gone (its process is), and the spectrum is the pool's.
    assert [p.name for p in (out / "runs").iterdir() if p.name.startswith(".")] == []
    assert_same_spectrum(out, reference)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["spectrum", "spectrum.nml"]


def test_spectrum_on_dask_workers_that_are_slurm_jobs(slurm, reference, tmp_path, monkeypatch):
    """``spectrum --dask ADDRESS`` with the workers started by dask-jobqueue as Slurm jobs."""
    from dask_jobqueue import SLURMCluster
    from distributed import Client

    # SLURMCluster submits, lists and cancels its worker jobs from this process: they must
    # reach the private cluster (as in tests/test_slurm.py).
    for name in set(os.environ) - set(slurm.env):
        monkeypatch.delenv(name)
    for name, value in slurm.env.items():
        monkeypatch.setenv(name, value)
    deck = write_deck(tmp_path)
    out = tmp_path / "spectrum"
    with SLURMCluster(cores=1, processes=1, memory="512MB", walltime="00:15:00", queue=slurm.partition,
                      python=sys.executable, scheduler_options={"host": "127.0.0.1", "dashboard_address": None},
                      log_directory=str(tmp_path / "worker-logs"),
                      local_directory=str(tmp_path / "worker-space")) as cluster:
        cluster.scale(jobs=2)
        with Client(cluster) as client:
            client.wait_for_workers(2, timeout=JOB_TIMEOUT)
        proc = pydriver_cli("spectrum", deck, "--out", out, "--dask", cluster.scheduler_address)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "3 ok, 0 failed, 0 missing (3 run now, 0 done before)" in proc.stdout, proc.stdout
    assert_same_spectrum(out, reference)
