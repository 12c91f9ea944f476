"""Never a silent wrong answer (issue 10): each defect found by probing rotorcable with bad
inputs and faults, with the test that would have caught it."""

from __future__ import annotations

import json
import os
import signal
import stat
import subprocess
import sys
import time

import numpy as np
import pytest

import pydriver
from pydriver import core_probes as probes
from conftest import INPUTS
from pydriver.study import override_deck


def deck(tmp_path, stem, changes, name="case"):
    return override_deck(INPUTS / f"{stem}.nml", tmp_path / f"{name}.nml", changes)


# ---- solvers report converged only when their test passed -----------------------------------

def test_newton_without_iterations_is_not_an_equilibrium(tmp_path):
    """newton_max_iter = 0 once returned the unsolved start shape as "the equilibrium"."""
    p = deck(tmp_path, "uh60_part2", {"solver": {"newton_max_iter": "1"}})
    with pytest.raises(pydriver.RunError) as exc:
        pydriver.run_deck(p)
    assert "not found" in str(exc.value) and "newton_max_iter" in str(exc.value)
    p0 = deck(tmp_path, "uh60_part2", {"solver": {"newton_max_iter": "0"}}, name="zero")
    with pytest.raises(pydriver.DeckError) as exc:
        pydriver.run_deck(p0)
    assert exc.value.key == "newton_max_iter"


def test_same_integration_twice_takes_the_same_steps():
    """An uninitialised variable made a repeated integration return after 0 steps with
    status 0 (471, 471, then 0 steps on a 10-body deck).  Same model, same start: the same
    work every time."""
    m = pydriver.Model.from_deck(INPUTS / "uh60_part2_decay.nml")
    y, _ = probes.consistent_ggl_state(m.core, m.q0, np.zeros_like(m.q0))
    q0, v0 = y[:m.nq], y[m.nq:2 * m.nq]
    steps = [probes.integrate_timed(m.core, 1, m.solver_settings(), 0.0, 0.05, q0, v0, 2)["stats"]["steps"]
             for _ in range(4)]
    assert steps[0] > 10 and len(set(steps)) == 1, steps


# ---- output times --------------------------------------------------------------------------

@pytest.mark.parametrize("t_end,dt_out,expect", [
    (0.05, 0.04, [0.0, 0.04, 0.05]),          # once stopped at 0.04
    (0.03, 0.1, [0.0, 0.03]),                 # once one sample and 0 steps
    (0.02, 0.01, [0.0, 0.01, 0.02]),
])
def test_every_run_reaches_t_end_exactly(tmp_path, t_end, dt_out, expect):
    p = deck(tmp_path, "six_link_dynamic", {"solver": {"t_end": repr(t_end), "dt_out": repr(dt_out)}})
    res = pydriver.run_deck(p)
    assert res.timeseries["t"].tolist() == pytest.approx(expect, abs=1e-15)
    assert res.timeseries["t"][-1] == t_end
    assert res.summary["solver"]["steps"] > 0


@pytest.mark.parametrize("t_end,dt_out,key,words", [(1.0, 1e-10, "dt_out", "samples"),
                                                    (1e6, 1e-6, "dt_out", "samples"),
                                                    (1e300, 1e-2, "t_end", "1e+07")])
def test_sample_counts_that_cannot_fit_are_refused(tmp_path, t_end, dt_out, key, words):
    """dt_out = 1e-10 gave a raw f2py error about a negative dimension (32-bit overflow) and
    t_end = 1e300 ran nothing; both are refused before anything is allocated (t_end = 1e300
    now by the schema's range of t_end, up to 1e7 s)."""
    p = deck(tmp_path, "six_link_dynamic", {"solver": {"t_end": repr(t_end), "dt_out": repr(dt_out)}})
    with pytest.raises(pydriver.DeckError) as exc:
        pydriver.run_deck(p)
    assert (exc.value.group, exc.value.key) == ("solver", key) and words in str(exc.value)


def test_pulse_after_the_run_is_refused_and_a_short_decay_is_not_fitted(tmp_path):
    """A pulse window outside the run gave f_damped_hz: NaN with exit status 0."""
    p = deck(tmp_path, "uh60_part2_decay", {"loads": {"pulse_start": "2.0", "pulse_end": "2.1"}})
    with pytest.raises(pydriver.DeckError) as exc:
        pydriver.run_deck(p)
    assert exc.value.key == "pulse_start"
    short = deck(tmp_path, "uh60_part2_decay", {"solver": {"t_end": "0.15"}}, name="short")
    res = pydriver.run_deck(short, out=tmp_path / "out")
    assert "f_damped_hz" not in res.summary["decay"]
    assert any("decay evaluation omitted" in w for w in res.summary["warnings"])
    json.loads((tmp_path / "out" / "summary.json").read_text())          # strict JSON


# ---- supports that determine nothing ------------------------------------------------------

def _six_link_clamp(tmp_path, x, name, straight=False):
    beta = "90.0, 4*0.0" if straight else "90.0, 5.0, -5.0, -5.0, 5.0"
    return deck(tmp_path, "six_link_static", {
        "clamp_b": {"from_start": ".false.", "position": f"{x}, 0.0, 0.0", "gamma_deg": "0.0", "beta_deg": "90.0"},
        "shape": {"gamma_deg": "5*0.0", "beta_deg": beta}}, name=name)


@pytest.mark.parametrize("joint", ["zy", "xy"])
def test_taut_clamp_is_refused_naming_the_reach(tmp_path, joint):
    """Clamp B exactly at full reach was accepted: Newton ran to F_x = 2.4e8 N (xy) or returned
    an arbitrary self-balancing pair (zy).  A straight bar between two clamps has an
    undetermined axial force."""
    p = override_deck(_six_link_clamp(tmp_path, 1.0, f"taut_{joint}"), tmp_path / f"t_{joint}.nml",
                      {"chain": {"joint": f"'{joint}'"}})
    with pytest.raises(pydriver.DeckError) as exc:
        pydriver.run_deck(p)
    assert (exc.value.group, exc.value.key) == ("clamp_b", "position")
    assert "full reach" in str(exc.value) and "0.6" in str(exc.value)


def test_straight_start_names_the_rank_loss(tmp_path):
    """A straight start 0.1 mm from closing failed with "start from a shape nearer the clamp";
    the cause is the rank-deficient constraint Jacobian of a straight chain."""
    with pytest.raises(pydriver.DeckError) as exc:
        pydriver.run_deck(_six_link_clamp(tmp_path, 0.9999, "straight", straight=True))
    msg = str(exc.value)
    assert exc.value.key == "position" and "lost rank" in msg and "straight" in msg and "bent" in msg


# ---- output directories hold exactly one run's files ---------------------------------------

def test_out_directory_holds_one_run(tmp_path):
    """A modal run and then a static run of another deck into the same --out: the modal run's
    modes.csv must not survive beside the static run's files."""
    out = tmp_path / "out"
    pydriver.run_deck(INPUTS / "uh60_part2_modal.nml", out=out)
    assert (out / "modes.csv").exists()
    pydriver.run_deck(INPUTS / "six_link_static.nml", out=out)
    assert sorted(p.name for p in out.iterdir()) == [".rotorcable-run.json", "summary.json", "table.csv",
                                                     "table.txt"]
    run = next(iter(pydriver.load_results(out).runs.values()))
    assert run.modes is None and run.summary["n_bodies"] == 5 and len(run.table["body"]) == 5
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]    # no temporaries


def test_failed_run_leaves_the_earlier_results(tmp_path):
    out = tmp_path / "out"
    pydriver.run_deck(INPUTS / "six_link_static.nml", out=out)
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    bad = deck(tmp_path, "six_link_static", {"solver": {"newton_max_iter": "1"}, "clamp_b": {
        "from_start": ".false.", "position": "0.9, 0.2, 0.1", "gamma_deg": "10.0", "beta_deg": "80.0"}})
    with pytest.raises((pydriver.RunError, pydriver.DeckError)):
        pydriver.run_deck(bad, out=out)
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]


def test_files_follow_the_umask(tmp_path):
    """Result files were created mode 0600 (mkstemp); they are for others to read."""
    old = os.umask(0o022)
    try:
        pydriver.run_deck(INPUTS / "six_link_static.nml", out=tmp_path / "out")
    finally:
        os.umask(old)
    assert stat.S_IMODE((tmp_path / "out").stat().st_mode) == 0o755
    for p in (tmp_path / "out").iterdir():
        assert stat.S_IMODE(p.stat().st_mode) == 0o644, p.name


def test_unwritable_out_is_a_clear_error_and_the_batch_goes_on(tmp_path):
    """A read-only --out gave a raw OSError traceback after the computation and aborted the
    remaining decks of `run A B`.  (A path below a regular file cannot be created, whatever
    the user's rights, so the test also holds when run as root.)"""
    (tmp_path / "results").write_text("a file where the results directory should be")
    proc = subprocess.run([sys.executable, "-m", "pydriver", "run", str(INPUTS / "six_link_static.nml"),
                           str(INPUTS / "three_body.nml")], cwd=tmp_path, capture_output=True, text=True)
    assert proc.returncode == 1
    assert "Traceback" not in proc.stderr
    assert proc.stderr.count("cannot write the results") == 2, proc.stderr


def test_killed_run_leaves_nothing_and_the_next_run_cleans_up(tmp_path):
    """A run killed while it writes (SIGKILL: no clean-up possible) leaves only a hidden
    temporary directory, never a partial --out; the next run into the same --out removes it."""
    p = deck(tmp_path, "six_link_dynamic", {"solver": {"t_end": "20.0", "dt_out": "1.0e-4"}}, name="long")
    out = tmp_path / "out"
    proc = subprocess.Popen([sys.executable, "-m", "pydriver", "run", str(p), "--out", str(out)],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:           # kill once the time series is being written
        if any(list(d.glob("timeseries.*")) for d in tmp_path.glob(".out.tmp-*")):
            break
        time.sleep(0.01)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    assert not out.exists()
    assert list(tmp_path.glob(".out.tmp-*"))
    pydriver.run_deck(INPUTS / "six_link_static.nml", out=out)
    assert not list(tmp_path.glob(".out.tmp-*")) and (out / "summary.json").exists()
