"""Parameter sweeps (issue: batch runs of input decks on one machine and on a cluster).

The 24-point c_y sweep of the UH-60 part 2 modal case (thesis Figure 5.9) is run once
uninterrupted (the reference), killed midway and resumed, through a Dask LocalCluster and as
a Slurm array task.  Every path runs the same deterministic computation on the same decks,
so their numbers must agree to round-off; the tolerance 1e-12 relative is far above the
~1e-16 of identical floating-point operations and far below any modelling difference.
Also: grid values checked by the deck schema, a base deck written with one-line groups, two
sweeps started together into one directory (the lock), a killed sweep's pool processes, and
the permissions of a sweep's files.
"""

import contextlib
import csv
import json
import math
import os
import signal
import stat
import subprocess
import sys
import time
import uuid
from pathlib import Path

import numpy as np
import pytest

import pydriver
from pydriver.output_columns import bare_name
from pydriver.deckfile import read_deck
from pydriver.sweep import SweepError, expand_grid, parse_set
from conftest import INPUTS

BASE = INPUTS / "uh60_part2_modal.nml"
CY = "springs.c_beta=1:70:24"
CY_VALUES = np.arange(1.0, 71.0, 3.0)      # 1:70:24 -> 1, 4, ..., 70
RTOL = 1e-12                                # same computation, see the module docstring


def cli(*args, **kw):
    return subprocess.run([sys.executable, "-m", "pydriver", *map(str, args)],
                          capture_output=True, text=True, **kw)


def sweep_cmd(out, *extra):
    return [sys.executable, "-m", "pydriver", "sweep", str(BASE), "--set", CY, "--out", str(out),
            "--quiet", "--no-plots", *extra]


def read_csv(path):
    """sweep.csv rows keyed by the bare column names (the header carries units, issue 22)."""
    with open(path, newline="") as fh:
        return [{bare_name(k): v for k, v in row.items()} for row in csv.DictReader(fh)]


def assert_same_rows(rows, ref):
    """Same ids, parameters, analysis and errors; every number equal to RTOL relative
    (wall_time_s excepted: it is a measurement, not a result)."""
    assert [r["id"] for r in rows] == [r["id"] for r in ref]
    assert list(rows[0]) == list(ref[0])
    for r, q in zip(rows, ref):
        for k in r:
            if k == "wall_time_s":
                continue
            if k in ("id", "analysis", "error", "springs.c_beta"):
                assert r[k] == q[k], (r["id"], k)
            elif q[k] == "":
                assert r[k] == "", (r["id"], k)
            else:
                assert math.isclose(float(r[k]), float(q[k]), rel_tol=RTOL, abs_tol=1e-300), \
                    (r["id"], k, r[k], q[k])


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The uninterrupted 24-point sweep through the CLI (local pool, with plots)."""
    out = tmp_path_factory.mktemp("sweep") / "ref"
    proc = cli("sweep", BASE, "--set", CY, "--out", out, "--quiet")
    assert proc.returncode == 0, proc.stderr
    assert "24 ok, 0 failed, 0 missing" in proc.stdout
    return out


def test_grid_syntax():
    assert parse_set(CY)[1] == [str(int(c)) for c in CY_VALUES]
    name, values, scale = parse_set("springs.c_beta=log:1:100:3")
    assert name == "springs.c_beta" and scale == "log" and values == ["1.0", "10.0", "100.0"]
    assert parse_set("solver.rtol=1e-6, 0.1:0.3:3")[1] == ["1e-6", "0.1", "0.2", "0.3"]
    # Quoted strings keep their commas; group/key are case-insensitive.
    assert parse_set("Case.Name='a,b','c'")[:2] == ("case.name", ["'a,b'", "'c'"])
    assert parse_set("loads.gravity(3)=-9.81,-1.62")[:2] == ("loads.gravity(3)", ["-9.81", "-1.62"])
    params, points, _ = expand_grid(["springs.c_beta=1,2", "springs.d_beta=5,6,7"])
    assert params == ["springs.c_beta", "springs.d_beta"]
    assert points == [["1", "5"], ["1", "6"], ["1", "7"], ["2", "5"], ["2", "6"], ["2", "7"]]
    # A per-joint key takes one value for every joint (the schema's rule), or one element.
    assert parse_set("springs.rest_beta_deg=0,5")[:2] == ("springs.rest_beta_deg", ["0", "5"])
    assert parse_set("springs.c_beta(2)=5")[0] == "springs.c_beta(2)"
    # Every value is parsed and type-checked by the deck schema, wherever it is in the list.
    for bad, words in [("springs.c_beta", "GROUP.KEY=VALUES"), ("c_beta=1", "GROUP.KEY"),
                       ("springs.c_beta=1:2", "a:b:n"), ("springs.c_beta=1:2:x", "integer n"),
                       ("springs.c_beta=log:0:1:3", "a > 0"), ("springs.c_beta=1,,2", "empty"),
                       ("loads.gravity=0,0,-9.81", "array"), ("springs.c_bta=1", "unknown key"),
                       ("nogroup.x=1", "unknown group"), ("springs.c_beta=1,abc", "not a number"),
                       ("springs.c_beta=1,.true.", "not a number"),
                       ("springs.c_beta=1,11*3", "reads as 11 values"),
                       ("chain.n_bodies=5,1.5", "not an integer"), ("chain.n_bodies(2)=5", "not an array"),
                       ("loads.gravity(4)=1", "no element 4"), ("clamp_b.active=.true.,1", "not a logical")]:
        with pytest.raises(SweepError, match=words) as exc:
            parse_set(bad)
        assert f"--set {bad}" in str(exc.value)


def test_local_sweep_24_points(reference):
    rows = read_csv(reference / "sweep.csv")
    assert [r["id"] for r in rows] == [f"{i:04d}" for i in range(24)]
    header = list(rows[0])
    assert header[:3] == ["id", "springs.c_beta", "analysis"] and header[-1] == "error"
    for col in ("wall_time_s", "max_constraint_violation_m", "FA_x", "MB_z", "f1_hz", "f2_hz",
                "f3_hz", "f1_damped_hz", "zeta1", "solver_newton_iterations"):
        assert col in header
    assert np.array_equal([float(r["springs.c_beta"]) for r in rows], CY_VALUES)
    assert all(r["error"] == "" and r["analysis"] == "modal" for r in rows)
    # Figure 5.9: the first frequency rises with c_y (strictly, on this grid).
    f1 = np.array([float(r["f1_damped_hz"]) for r in rows])
    assert np.all(np.diff(f1) > 0)
    # Same numbers as the existing study (pydriver.study, one process, its own decks).
    from pydriver.study import frequency_vs_cy
    study = frequency_vs_cy(BASE, CY_VALUES[[0, 11, 23]])
    assert np.allclose(f1[[0, 11, 23]], study["f_damped_hz"], rtol=RTOL, atol=0)
    # Each deck is a plain namelist a person can re-run alone.
    res = pydriver.run_deck(reference / "decks" / "0011.nml")
    assert math.isclose(res.summary["frequencies_hz"][0], float(rows[11]["f1_hz"]), rel_tol=RTOL)
    assert (reference / "plots" / "f1_damped_hz_vs_springs.c_beta.png").stat().st_size > 1000
    assert not list((reference / "runs").glob(".*"))          # no temporary directories left


def test_load_results(reference):
    res = pydriver.load_results(reference)
    rows = read_csv(reference / "sweep.csv")
    assert list(res.table) == list(rows[0]) and res.params == ["springs.c_beta"]
    assert res.missing == [] and len(res.runs) == 24
    assert list(res.table["id"]) == [r["id"] for r in rows]
    assert res.table["springs.c_beta"].dtype == float
    # The table is rebuilt from the same records with exact float text: equal bit for bit.
    assert np.array_equal(res.table["f1_hz"], [float(r["f1_hz"]) for r in rows])
    run = res.runs["0005"]
    assert run.ok and run.params == {"springs.c_beta": "16"}
    assert run.summary["frequencies_hz"][0] == res.table["f1_hz"][5]
    assert run.modes["f_damped_hz"][0] == res.table["f1_damped_hz"][5]
    assert list(run.table["body"]) == list(range(1, 12)) and run.timeseries is None


def test_load_results_single_run(tmp_path):
    pydriver.run_deck(INPUTS / "six_link_static.nml", out=tmp_path)
    res = pydriver.load_results(tmp_path)
    assert res.params == [] and list(res.table["id"]) == [tmp_path.name]
    # 75.131 N: the thesis value the existing tests check; 1e-3 N is its printed precision.
    assert abs(res.table["FB_z"][0] - 75.131) < 1e-3
    assert np.isnan(res.table["f1_hz"][0])                    # static run: no frequencies


def wait_for_records(proc, out, n=1, timeout=120):
    deadline = time.monotonic() + timeout
    while proc.poll() is None and time.monotonic() < deadline:
        # Records only: "[!.]*" skips the hidden temporaries a run writes into first.
        if len(list(out.glob("runs/[!.]*/summary.json"))) >= n:
            return
        time.sleep(0.001)


#: The interrupted sweep: six 1-s decay integrations (~0.3 s each on this VM), so that the
#: window between the first record and the end (~1.5 s with one worker) stays wide on any CPU;
#: the 24 modal points of the reference sweep take ~5 ms each, a window a fast or an idle
#: machine closed before the signal arrived (all 24 records written in 0.13 s, measured).
SLOW_BASE = INPUTS / "uh60_part2_decay.nml"
SLOW_SET = "springs.c_beta=20:45:6"
N_SLOW = 6


def slow_sweep_cmd(out, *extra):
    return [sys.executable, "-m", "pydriver", "sweep", str(SLOW_BASE), "--set", SLOW_SET, "--out", str(out),
            "--quiet", "--no-plots", *extra]


@pytest.fixture(scope="module")
def slow_reference(tmp_path_factory):
    """The uninterrupted slow sweep, which an interrupted and resumed one must reproduce."""
    out = tmp_path_factory.mktemp("sweep") / "slow_ref"
    proc = subprocess.run(slow_sweep_cmd(out), capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    assert f"{N_SLOW} ok, 0 failed, 0 missing" in proc.stdout
    return out


@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGINT], ids=["SIGKILL", "SIGINT"])
def test_killed_sweep_resumes(slow_reference, tmp_path, sig):
    # The whole process group is signalled, as Ctrl-C or a job scheduler does.  One worker
    # (--jobs 1) keeps the window between the first record and the end wide; if the sweep
    # still won the race it is started again.
    for attempt in range(3):
        out = tmp_path / f"attempt{attempt}"
        # SIGINT at its default in the child: a shell running the suite in the background
        # (`cmd &`, nohup) ignores SIGINT, the sweep would inherit that and never see Ctrl-C.
        proc = subprocess.Popen(slow_sweep_cmd(out, "--jobs", "1"), start_new_session=True,
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
        wait_for_records(proc, out)
        os.killpg(proc.pid, sig)
        stdout, stderr = proc.communicate(timeout=60)
        before = {p.parent.name: p.stat().st_mtime_ns for p in out.glob("runs/[!.]*/summary.json")}
        if len(before) < N_SLOW:
            break
    assert 1 <= len(before) < N_SLOW, "the sweep finished before it could be interrupted"
    if sig == signal.SIGINT:
        # Ctrl-C: the running deck finishes, sweep.csv holds exactly the finished runs.
        assert proc.returncode == 130, stderr
        assert "interrupted" in stdout
        assert [r["id"] for r in read_csv(out / "sweep.csv")] == sorted(before)
    else:
        assert proc.returncode == -signal.SIGKILL
    resumed = subprocess.run(slow_sweep_cmd(out), capture_output=True, text=True)
    assert resumed.returncode == 0, resumed.stderr
    assert f"({N_SLOW - len(before)} run now, {len(before)} done before)" in resumed.stdout
    # Finished decks were not recomputed: their records are the same files.
    for id_, mtime in before.items():
        assert (out / "runs" / id_ / "summary.json").stat().st_mtime_ns == mtime, id_
    assert not list((out / "runs").glob(".*"))     # temporaries of killed runs cleaned up
    rows = read_csv(out / "sweep.csv")
    assert len(rows) == N_SLOW and len({r["id"] for r in rows}) == N_SLOW   # none lost, none twice
    assert_same_rows(rows, read_csv(slow_reference / "sweep.csv"))


def test_failed_deck_lands_in_error_column(tmp_path):
    # c_y = -1 is rejected by the deck check (springs must not be negative); the first grid
    # point is valid, so the sweep starts, and the other points must still finish.
    out = tmp_path / "fail"
    proc = cli("sweep", BASE, "--set", "springs.c_beta=35.531,-1,10", "--out", out, "--quiet",
               "--no-plots", "--jobs", "2")
    assert proc.returncode == 1 and "2 ok, 1 failed, 0 missing" in proc.stdout
    rows = read_csv(out / "sweep.csv")
    assert [r["error"] == "" for r in rows] == [True, False, True]
    assert rows[1]["error"].startswith("DeckError:") and "c_beta" in rows[1]["error"]
    assert rows[1]["f1_hz"] == "" and float(rows[2]["f1_hz"]) > 0
    # 26.25 Hz: the undamped first frequency of the unchanged deck (docs/model.md, 11 bodies);
    # 0.01 Hz is the precision it is quoted with.
    assert abs(float(rows[0]["f1_hz"]) - 26.25) < 0.01
    res = pydriver.load_results(out)
    assert not res.runs["0001"].ok and "must not be negative" in res.runs["0001"].error
    assert np.isnan(res.table["f1_hz"][1])


def test_bad_set_option_is_named(tmp_path, reference):
    out = tmp_path / "bad"
    proc = cli("sweep", BASE, "--set", "springs.c_bta=1,2", "--out", out)
    assert proc.returncode == 2
    assert "--set springs.c_bta=1,2" in proc.stderr and "unknown key" in proc.stderr
    assert not out.exists()                     # nothing written, nothing run
    proc = cli("sweep", BASE, "--set", "nogroup.x=1", "--out", out)
    assert proc.returncode == 2 and "--set nogroup.x=1" in proc.stderr and "unknown group" in proc.stderr
    # A malformed value anywhere in the grid (not only at the first point) stops the sweep.
    proc = cli("sweep", BASE, "--set", "springs.d_beta=0.05", "--set", "springs.c_beta=1,2,3x", "--out", out)
    assert proc.returncode == 2 and "--set springs.c_beta=1,2,3x: value 3x" in proc.stderr
    # The base deck gives the start shape body by body: one value would flatten it.
    proc = cli("sweep", BASE, "--set", "shape.beta_deg=10,20", "--out", out)
    assert proc.returncode == 2 and "per element" in proc.stderr and "shape.beta_deg(2)" in proc.stderr
    assert not out.exists()
    # A resume with another grid is refused and leaves the sweep alone.
    manifest = (reference / "sweep.json").read_text()
    proc = cli("sweep", BASE, "--set", "springs.c_beta=1:70:12", "--out", reference, "--quiet")
    assert proc.returncode == 2 and "holds another sweep" in proc.stderr and CY in proc.stderr
    assert (reference / "sweep.json").read_text() == manifest


def test_dask_local_cluster_gives_the_same_csv(reference, tmp_path):
    distributed = pytest.importorskip("distributed")
    out = tmp_path / "dask"
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster:
        proc = subprocess.run(sweep_cmd(out, "--dask", cluster.scheduler_address),
                              capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert_same_rows(read_csv(out / "sweep.csv"), read_csv(reference / "sweep.csv"))


def test_slurm_script(reference, tmp_path):
    out = tmp_path / "slurm"
    proc = cli("sweep", BASE, "--set", CY, "--out", out, "--slurm")
    assert proc.returncode == 0, proc.stderr
    script = (out / "sweep.slurm").read_text()
    assert script.startswith("#!/bin/bash\n")
    assert "#SBATCH --array=0-23\n" in script
    task = f'{sys.executable} -m pydriver sweep-task {out} "$SLURM_ARRAY_TASK_ID"'
    assert task in script
    assert f"source {sys.prefix}/bin/activate" in script or sys.prefix == sys.base_prefix
    assert f"sbatch {out / 'sweep.slurm'}" in proc.stdout
    assert f"-m pydriver sweep-collect {out}" in proc.stdout
    assert sorted(p.name for p in (out / "decks").iterdir()) == [f"{i:04d}.nml" for i in range(24)]
    assert json.loads((out / "sweep.json").read_text())["python"] == sys.executable
    assert not list((out / "runs").iterdir())                 # nothing was run
    # The script itself runs array task 7 here (its #SBATCH lines are comments to bash).
    env = dict(os.environ, SLURM_ARRAY_TASK_ID="7")
    run = subprocess.run(["bash", str(out / "sweep.slurm")], env=env, capture_output=True, text=True)
    assert run.returncode == 0 and "0007: ok" in run.stdout, run.stderr
    coll = cli("sweep-collect", out, "--no-plots")
    assert coll.returncode == 1 and "1 ok, 0 failed, 23 missing" in coll.stdout
    rows = read_csv(out / "sweep.csv")
    assert_same_rows(rows, [r for r in read_csv(reference / "sweep.csv") if r["id"] == "0007"])
    # Written again (a resume), the array leaves out the finished point.
    cli("sweep", BASE, "--set", CY, "--out", out, "--slurm")
    assert "#SBATCH --array=0-6,8-23\n" in (out / "sweep.slurm").read_text()


# One-line groups, and a one-line group followed by a multi-line group whose key has the same
# name as one swept (clamp_a.gamma_deg / shape.gamma_deg): the text scanner of the old sweep
# took c_beta and clamp_a.gamma_deg for arrays here.  Otherwise the deck is uh60_part2_modal
# (clamp A's frame at its default orientation).
ONE_LINE_DECK = """\
&case name = 'one_line', analysis = 'modal' /
&chain n_bodies = 11, total_length = 0.590, diameter = 0.015, total_mass = 0.313 /
&clamp_a gamma_deg = 0.0, beta_deg = 0.0 /
&springs c_beta = 35.531, c_gamma = 1.0e-4, d_beta = 5.0e-2, d_gamma = 1.0e-4 /
&shape
  gamma_deg = 90.0, 90.0, 9*0.0
  beta_deg  = 70.0, 10*12.0
/
&clamp_b active = .true., position = -0.161, 0.430, -0.135, gamma_deg = 0.0, beta_deg = 200.0 /
&loads gravity = 0.0, 0.0, -9.81 /
"""


def test_base_deck_with_one_line_groups(tmp_path, reference):
    base = tmp_path / "one_line.nml"
    base.write_text(ONE_LINE_DECK)
    out = tmp_path / "one_line"
    proc = cli("sweep", base, "--set", "springs.c_beta=10,20", "--set", "clamp_a.gamma_deg=0,10",
               "--set", "loads.gravity(3)=-9.81", "--out", out, "--quiet", "--no-plots", "--jobs", "2")
    assert proc.returncode == 0, proc.stderr
    assert "4 points, 4 ok" in proc.stdout
    rows = read_csv(out / "sweep.csv")
    assert [(r["springs.c_beta"], r["clamp_a.gamma_deg"], r["loads.gravity(3)"]) for r in rows] == \
        [("10", "0", "-9.81"), ("10", "10", "-9.81"), ("20", "0", "-9.81"), ("20", "10", "-9.81")]
    for r in rows:
        deck = read_deck(out / "decks" / f"{r['id']}.nml")
        assert np.all(deck["springs.c_beta"] == float(r["springs.c_beta"]))
        assert deck["clamp_a.gamma_deg"] == float(r["clamp_a.gamma_deg"])
        # The rest of the one-line groups is the base deck's.
        assert np.all(deck["springs.d_beta"] == 0.05) and deck["clamp_a.beta_deg"] == 0.0
        assert list(deck["loads.gravity"]) == [0.0, 0.0, -9.81]
        assert list(deck["clamp_b.position"]) == [-0.161, 0.430, -0.135]
        assert list(deck["shape.beta_deg"]) == [70.0] + [12.0] * 10
    # c_beta = 10 at clamp A's default frame is point 0003 of the reference sweep (1, 4, 7, 10):
    # the same deck in another layout gives the same numbers (RTOL: same computation).
    ref = read_csv(reference / "sweep.csv")[3]
    assert ref["springs.c_beta"] == "10"
    for col in ("f1_hz", "f2_hz", "f3_hz", "f1_damped_hz", "zeta1", "FB_z", "MA_x"):
        assert math.isclose(float(rows[0][col]), float(ref[col]), rel_tol=RTOL), col


# Imports pydriver, says so, then waits for a line on stdin before running the command line:
# the test releases two of these together, so both sweeps start within microseconds.
BARRIER_CLI = ("import sys; import pydriver.__main__ as cli; print('ready', flush=True); "
               "sys.stdin.readline(); sys.exit(cli.main(sys.argv[1:]))")


def test_concurrent_sweeps_into_one_directory(tmp_path):
    # Two sweeps with different grids started at the same moment into one new directory: one
    # runs, the other is refused before it writes anything, and every row of sweep.csv carries
    # the parameter its run used.  Ten trials, the start order alternating; the race this
    # guards against (manifest and decks written before the lock) showed in 1 of 12 trials
    # without the barrier.
    grids = {"springs.c_beta=37,38": ["37", "38"], "springs.c_beta=220,221,222": ["220", "221", "222"]}
    for trial in range(10):
        out = tmp_path / f"trial{trial}"
        specs = list(grids) if trial % 2 == 0 else list(grids)[::-1]
        procs = [subprocess.Popen([sys.executable, "-c", BARRIER_CLI, "sweep", str(BASE), "--set", spec,
                                   "--out", str(out), "--quiet", "--no-plots", "--jobs", "1"],
                                  stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                  text=True) for spec in specs]
        for p in procs:
            assert p.stdout.readline() == "ready\n"
        for p in procs:
            p.stdin.write("go\n")
            p.stdin.flush()
        # 120 s: each sweep is two or three modal runs of milliseconds plus ~1 s of start-up;
        # the limit only turns a hang into a failure.
        outputs = [p.communicate(timeout=120) for p in procs]
        codes = [p.returncode for p in procs]
        assert sorted(codes) == [0, 2], (trial, outputs)
        winner = specs[codes.index(0)]
        refused = outputs[codes.index(2)][1]
        assert "another sweep is running" in refused or "holds another sweep" in refused, refused
        assert json.loads((out / "sweep.json").read_text())["sets"] == [winner]
        rows = read_csv(out / "sweep.csv")
        assert [r["springs.c_beta"] for r in rows] == grids[winner] and all(r["error"] == "" for r in rows)
        for r in rows:
            used = json.loads((out / "runs" / r["id"] / "summary.json").read_text())["c_beta_Nm_per_rad"]
            assert used == float(r["springs.c_beta"]), (trial, r["id"], used, r["springs.c_beta"])
            assert np.all(read_deck(out / "decks" / f"{r['id']}.nml")["springs.c_beta"] == used)
        assert sorted(p.name for p in (out / "runs").iterdir()) == [r["id"] for r in rows]
        assert sorted(p.name for p in (out / "decks").iterdir()) == [f"{r['id']}.nml" for r in rows]


MARK_VAR = "ROTORCABLE_TEST_SWEEP_MARK"


def marked_processes(mark: str) -> dict:
    """pid -> parent pid of the live processes (zombies left out) whose environment holds
    MARK_VAR=mark: a process inherits it from the sweep started with it, whoever its parent
    is by now."""
    found = {}
    for environ in Path("/proc").glob("[0-9]*/environ"):
        try:
            if f"{MARK_VAR}={mark}".encode() not in environ.read_bytes().split(b"\0"):
                continue
            stat_line = (environ.parent / "stat").read_text()
        except OSError:                 # gone meanwhile, or another user's
            continue
        state, ppid = stat_line[stat_line.rindex(")") + 2:].split()[:2]
        if state not in ("Z", "X"):
            found[int(environ.parent.name)] = int(ppid)
    return found


@pytest.mark.skipif(not Path("/proc/self/environ").exists(), reason="finds processes through /proc")
def test_killed_sweep_leaves_no_processes(tmp_path):
    mark = uuid.uuid4().hex
    out = tmp_path / "killed"
    # Decay runs of 5-8 s simulated time (seconds each): the workers are inside a deck when
    # the sweep process is killed.
    proc = subprocess.Popen([sys.executable, "-m", "pydriver", "sweep", str(INPUTS / "uh60_part2_decay.nml"),
                             "--set", "solver.t_end=5,6,7,8", "--out", str(out), "--quiet", "--no-plots",
                             "--jobs", "2"], env=dict(os.environ, **{MARK_VAR: mark}),
                            start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        # 120 s for the sweep to start a deck: seconds normally, a hang otherwise.
        deadline = time.monotonic() + 120
        while True:
            assert proc.poll() is None and time.monotonic() < deadline, "no deck started"
            procs = marked_processes(mark)
            # Workers are forks of the forkserver, itself a child of the sweep process.
            workers = [p for p, parent in procs.items() if parent in procs and parent != proc.pid]
            if workers and list((out / "runs").glob(".*")):     # a deck in flight
                break
            time.sleep(0.01)
        assert len(procs) >= 3, procs           # the sweep, its forkserver, a worker at least
        os.kill(proc.pid, signal.SIGKILL)       # the sweep process only, not its group
        proc.wait(timeout=10)                   # reaped at once; 10 s only bounds a failure
        # 5 s: the kernel signal and the pipe's end-of-file act within milliseconds; the rest
        # is slack for a loaded machine.
        deadline = time.monotonic() + 5
        while marked_processes(mark) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert not marked_processes(mark), f"alive after the sweep was killed: {marked_processes(mark)}"
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.pid, signal.SIGKILL)             # whatever is left of a failure
        proc.wait()


def test_sweep_files_follow_the_umask(tmp_path):
    # Results are for others to read: no file of a sweep may be created 0600 (mkstemp) or a
    # directory 0700 (mkdtemp); with umask 027 every file is 0640 (the Slurm script 0750)
    # and every directory 0750, as plain open() and mkdir() give.
    out, slurm = tmp_path / "run", tmp_path / "slurm"
    proc = cli("sweep", BASE, "--set", "springs.c_beta=35.531,-1", "--out", out, "--quiet", "--jobs", "2",
               umask=0o027)
    assert proc.returncode == 1 and "1 ok, 1 failed" in proc.stdout, proc.stderr   # an error.json too
    assert cli("sweep", BASE, "--set", "springs.c_beta=1,2", "--out", slurm, "--slurm",
               umask=0o027).returncode == 0
    paths = [out, slurm, *out.rglob("*"), *slurm.rglob("*")]
    assert {p.name for p in paths} >= {"sweep.json", ".sweep.lock", "0000.nml", "summary.json", "error.json",
                                       "sweep.csv", "f1_hz_vs_springs.c_beta.png", "sweep.slurm"}
    for p in paths:
        want = 0o750 if p.is_dir() or p.name == "sweep.slurm" else 0o640
        assert stat.S_IMODE(p.stat().st_mode) == want, (p, oct(p.stat().st_mode))
