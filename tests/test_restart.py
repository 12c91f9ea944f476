"""Restart (issue 22 item 5, issue 35): a finished dynamic run continued from its checkpoint
reproduces the uninterrupted run.  Both cut the integration at the same instants (&solver
checkpoint_interval: IDA starts afresh there from the state reached), so the continuation makes
exactly the calls the uninterrupted run makes: the same doubles, and the same bytes in the
written time series, for decimal intervals and end times too (sample times are counted in whole
steps of the decimal dt_out, pydriver/analyses/output_grid.py).  A continuation from any other
instant says that it is not bit for bit.  Damaged or crafted restart directories:
tests/test_restart_faults.py."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest

import pydriver
from conftest import INPUTS
from pydriver.analyses.output_grid import is_segment_start, output_grid, output_times
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


@pytest.mark.parametrize("interval,t_source,t_end", [("0.05", "0.15", "0.3"), ("0.05", "0.25", "0.3"),
                                                     ("0.1", "0.3", "0.7"), ("0.1", "0.2", "0.3")])
def test_decimal_intervals_continue_bit_for_bit(tmp_path, interval, t_source, t_end):
    """Issue 35: with the samples at k * dt_out accumulated in binary, 3 * 0.05 s was
    0.15000000000000002 and the continuation from t_end = 0.15 started IDA 2.8e-17 s away from
    the uninterrupted run's cut: 2.5e-4 deg/s apart.  Now the written files are equal byte for
    byte (exact: both runs make the same calls on the same doubles)."""
    whole = tmp_path / "whole"
    pydriver.run_deck(deck(tmp_path, "whole", t_end, checkpoint_interval=interval), out=whole)
    first = tmp_path / "first"
    pydriver.run_deck(deck(tmp_path, "part", t_source, checkpoint_interval=interval), out=first)
    cont = tmp_path / "cont"
    res = pydriver.run_deck(deck(tmp_path, "part", t_end, checkpoint_interval=interval), out=cont, restart=first)
    assert (cont / "timeseries.csv").read_bytes() == (whole / "timeseries.csv").read_bytes()
    assert res.summary["restarted_from"]["same_as_uninterrupted_run"] is True
    assert not any("bit for bit" in w for w in res.summary.get("warnings", []))


@pytest.mark.parametrize("interval,t_source", [("0.1", "0.17"), ("0", "0.2")])
def test_a_continuation_off_the_interval_says_it_is_not_bit_for_bit(tmp_path, interval, t_source):
    """From an instant where the uninterrupted run does not start IDA afresh, the continuation
    restarts IDA's step history there: as close as the integration (rtol 1e-6: the centres of
    mass within 1e-7 m, a thousandth of the pulse's 0.1 mm motion; 4e-11 m measured), and the
    summary and a warning say it is not the same run bit for bit."""
    whole = pydriver.run_deck(deck(tmp_path, "whole", "0.3", checkpoint_interval=interval))
    first = tmp_path / "first"
    pydriver.run_deck(deck(tmp_path, "part", t_source, checkpoint_interval=interval), out=first)
    cont = pydriver.run_deck(deck(tmp_path, "part", "0.3", checkpoint_interval=interval), restart=first)
    assert cont.summary["restarted_from"]["same_as_uninterrupted_run"] is False
    assert any("not bit for bit" in w for w in cont.summary["warnings"])
    a, b = whole.timeseries, cont.timeseries
    assert np.array_equal(a["t"], b["t"])
    positions = [k for k in a if k[0] in "xyz" and k[1:].isdigit()]
    assert max(float(np.max(np.abs(a[k] - b[k]))) for k in positions) <= 1e-7


DT_TEXTS = ["0.001", "0.0002", "0.05", "0.1", "0.3", "2.5e-5", "0.007", "1.0", "60"]


@pytest.mark.parametrize("dt_text", DT_TEXTS)
def test_sample_times_are_the_doubles_of_their_decimal_values(dt_text):
    """Sample i lies at the double nearest to i * dt_out in decimal (checked against Python's
    exact fractions, whose float() rounds once), and t_end written as a decimal multiple of
    dt_out is its last sample exactly."""
    dt = float(dt_text)
    for steps in (1, 3, 7, 150, 300, 1001):
        t_end = float(Fraction(dt_text) * steps)
        t = output_times(t_end, dt)
        assert len(t) == steps + 1 and t[-1] == t_end
        assert all(t[i] == float(Fraction(dt_text) * i) for i in range(len(t)))


def test_segment_starts_are_the_doubles_of_the_decimal_multiples_of_the_interval():
    t, starts = output_grid(0.7, 0.001, 0.05)
    assert starts == list(range(0, 700, 50))
    assert [t[i] for i in starts] == [float(Fraction("0.05") * k) for k in range(14)]
    assert t[150] == 0.15 and t[300] == 0.3 and t[700] == 0.7            # the doubles of the decks' text
    assert is_segment_start(0.7, 0.001, 0.05, 0.15) and is_segment_start(0.7, 0.001, 0.1, 0.3)
    assert not is_segment_start(0.7, 0.001, 0.05, 3 * 0.05)              # 0.15000000000000002: no sample
    assert not is_segment_start(0.7, 0.001, 0.1, 0.17) and not is_segment_start(0.7, 0.001, 0.0, 0.3)
    # A t_end off the dt_out grid is the last sample, after the last whole step.
    t = output_times(0.1505, 0.001)
    assert len(t) == 152 and t[-2] == 0.15 and t[-1] == 0.1505
    # A dt_out with no short decimal form: binary multiples, t_end still exactly last.
    t = output_times(1.0, 1.0 / 3.0)
    assert len(t) == 4 and t[-1] == 1.0 and t[1] == 1.0 / 3.0
    # A continuation's start must be a sample.
    with pytest.raises(ValueError, match="not on the output grid"):
        output_grid(0.3, 0.001, 0.05, restart_at=0.1505)


def test_a_deck_of_another_analysis_is_refused_before_the_files_are_read(tmp_path):
    """A static deck of another size asking to continue: its analysis is named, not the
    checkpoint's number of coordinates."""
    first = tmp_path / "first"
    pydriver.run_deck(deck(tmp_path, "part", "0.1"), out=first)
    with pytest.raises(pydriver.DeckError) as exc:
        pydriver.run_deck(INPUTS / "six_link_static.nml", restart=first)
    assert (exc.value.group, exc.value.key) == ("case", "analysis")
