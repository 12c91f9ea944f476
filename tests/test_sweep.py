"""Parameter sweeps (issue: batch runs of input decks on one machine and on a cluster).

The 24-point c_y sweep of the UH-60 part 2 modal case (thesis Figure 5.9) is run once
uninterrupted (the reference), killed midway and resumed, through a Dask LocalCluster and as
a Slurm array task.  Every path runs the same deterministic computation on the same decks,
so their numbers must agree to round-off; the tolerance 1e-12 relative is far above the
~1e-16 of identical floating-point operations and far below any modelling difference.
"""

import csv
import json
import math
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

import pydriver
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
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


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
    for bad, words in [("springs.c_beta", "GROUP.KEY=VALUES"), ("c_beta=1", "GROUP.KEY"),
                       ("springs.c_beta=1:2", "a:b:n"), ("springs.c_beta=1:2:x", "integer n"),
                       ("springs.c_beta=log:0:1:3", "a > 0"), ("springs.c_beta=1,,2", "empty"),
                       ("loads.gravity=0,0,-9.81", "array")]:
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


@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGINT], ids=["SIGKILL", "SIGINT"])
def test_killed_sweep_resumes(reference, tmp_path, sig):
    # The whole process group is signalled, as Ctrl-C or a job scheduler does.  One worker
    # (--jobs 1) keeps the window between the first record and the end wide (~0.2 s); if the
    # sweep still won the race it is started again.
    for attempt in range(3):
        out = tmp_path / f"attempt{attempt}"
        proc = subprocess.Popen(sweep_cmd(out, "--jobs", "1"), start_new_session=True,
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        wait_for_records(proc, out)
        os.killpg(proc.pid, sig)
        stdout, stderr = proc.communicate(timeout=60)
        before = {p.parent.name: p.stat().st_mtime_ns for p in out.glob("runs/[!.]*/summary.json")}
        if len(before) < 24:
            break
    assert 1 <= len(before) < 24, "the sweep finished before it could be interrupted"
    if sig == signal.SIGINT:
        # Ctrl-C: the running deck finishes, sweep.csv holds exactly the finished runs.
        assert proc.returncode == 130, stderr
        assert "interrupted" in stdout
        assert [r["id"] for r in read_csv(out / "sweep.csv")] == sorted(before)
    else:
        assert proc.returncode == -signal.SIGKILL
    resumed = subprocess.run(sweep_cmd(out), capture_output=True, text=True)
    assert resumed.returncode == 0, resumed.stderr
    assert f"({24 - len(before)} run now, {len(before)} done before)" in resumed.stdout
    # Finished decks were not recomputed: their records are the same files.
    for id_, mtime in before.items():
        assert (out / "runs" / id_ / "summary.json").stat().st_mtime_ns == mtime, id_
    assert not list((out / "runs").glob(".*"))     # temporaries of killed runs cleaned up
    rows = read_csv(out / "sweep.csv")
    assert len(rows) == 24 and len({r["id"] for r in rows}) == 24   # none lost, none twice
    assert_same_rows(rows, read_csv(reference / "sweep.csv"))


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
