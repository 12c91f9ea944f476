"""Restart (issue 22 item 5): a finished dynamic run continued from its checkpoint reproduces
the uninterrupted run.  Both cut the integration at the same instants (&solver
checkpoint_interval: IDA starts afresh there from the state reached), so the continuation makes
exactly the calls the uninterrupted run makes: equal to 1e-12 (the test's bound; bit for bit in
practice, the written CSV round-trips exactly)."""

from __future__ import annotations

import numpy as np
import pytest

import pydriver
from conftest import INPUTS
from pydriver.study import override_deck

DECAY = INPUTS / "uh60_part2_decay.nml"


def deck(tmp_path, name, t_end, **solver):
    changes = {"solver": {"t_end": t_end, "dt_out": "1.0e-3", "checkpoint_interval": "0.1", **solver}}
    return override_deck(DECAY, tmp_path / f"{name}.nml", changes)


def test_continued_run_matches_the_uninterrupted_one(tmp_path):
    whole = pydriver.run_deck(deck(tmp_path, "whole", "0.3"), out=tmp_path / "whole")
    first = tmp_path / "first"
    pydriver.run_deck(deck(tmp_path, "part", "0.2"), out=first)
    assert (first / "checkpoint.npz").is_file()
    cont = pydriver.run_deck(deck(tmp_path, "part", "0.3"), out=tmp_path / "cont", restart=first)
    a, b = whole.timeseries, cont.timeseries
    assert set(a) == set(b) and len(a["t"]) == len(b["t"]) == 301
    worst = max(float(np.max(np.abs(a[k] - b[k]))) for k in a)
    assert worst <= 1e-12, worst
    assert cont.summary["restarted_from"]["t_s"] == 0.2
    # What follows from the whole history is the same too (decay evaluation, energy drift).
    assert cont.summary["decay"]["f_damped_hz"] == pytest.approx(whole.summary["decay"]["f_damped_hz"], rel=1e-12)
    assert cont.summary["energy_drift_rel"] == pytest.approx(whole.summary["energy_drift_rel"], rel=1e-12)


def test_continuing_into_the_same_directory_and_from_the_command_line(tmp_path):
    import subprocess
    import sys
    out = tmp_path / "run"
    pydriver.run_deck(deck(tmp_path, "d", "0.1"), out=out)
    longer = deck(tmp_path, "d", "0.2")
    done = subprocess.run([sys.executable, "-m", "pydriver", "run", str(longer), "--restart", str(out),
                           "--out", str(out)], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    ts = pydriver.load_results(out).runs
    t = next(iter(ts.values())).timeseries["t"]
    assert t[0] == 0.0 and t[-1] == 0.2 and len(t) == 201


def test_another_model_is_refused(tmp_path):
    first = tmp_path / "first"
    pydriver.run_deck(deck(tmp_path, "part", "0.1"), out=first)
    other = override_deck(deck(tmp_path, "x", "0.2"), tmp_path / "other.nml", {"springs": {"c_beta": "11*30.0"}})
    with pytest.raises(pydriver.DeckError) as exc:
        pydriver.run_deck(other, restart=first)
    assert (exc.value.group, exc.value.key) == ("springs", "c_beta") and "same model" in str(exc.value)
    with pytest.raises(pydriver.DeckError) as exc:
        pydriver.run_deck(deck(tmp_path, "early", "0.05"), restart=first)
    assert exc.value.key == "t_end"
    with pytest.raises(pydriver.DeckError) as exc:
        pydriver.run_deck(deck(tmp_path, "y", "0.2"), restart=tmp_path)       # no checkpoint there
    assert "checkpoint.npz" in str(exc.value)


@pytest.mark.parametrize("value,words", [("0.00015", "multiple of dt_out"), ("1.0e9", "allowed"),
                                         ("4.9e-324", "0 (none) or at least"), ("0.1, 0.2", "one value"),
                                         ("-0.1", "allowed")])
def test_checkpoint_interval_is_checked(tmp_path, value, words):
    """The new key's fuzz cases: not a multiple, huge, tiny, wrong count, negative."""
    with pytest.raises(pydriver.DeckError) as exc:
        pydriver.run_deck(deck(tmp_path, "bad", "0.2", checkpoint_interval=value))
    assert (exc.value.group, exc.value.key) == ("solver", "checkpoint_interval") and words in str(exc.value)
