"""Progress and logging of long runs (issue 22 item 4): -v writes one line per step of
progress to stderr, the default writes nothing when stderr is not a terminal, -q nothing at all;
a failure names the refinement level (n) it happened at; the printed time is the job's."""

from __future__ import annotations

import subprocess
import sys

import pytest

import pydriver
from conftest import INPUTS
from pydriver.study import override_deck

FF = INPUTS / "uh60_part2_forward_flight_cable.nml"


@pytest.fixture(scope="module")
def short_flight(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("progress")
    return override_deck(FF, tmp / "ff.nml", {"refinement": {"levels": "2"}})


def _run(deck, out, *flags):
    return subprocess.run([sys.executable, "-m", "pydriver", "run", str(deck), "--out", str(out), *flags],
                          capture_output=True, text=True, timeout=600)


@pytest.mark.whole_job
def test_verbose_names_levels_and_revolutions(short_flight, tmp_path):
    done = _run(short_flight, tmp_path / "v", "-v")
    assert done.returncode == 0, done.stderr
    lines = done.stderr.splitlines()
    assert any("refinement level 1 of 2 (n = 11): started" in ln for ln in lines)
    assert any("refinement level 2 of 2 (n = 22): flight: revolution 3" in ln for ln in lines)
    assert all(ln.startswith("[") for ln in lines)             # every line timestamped, nothing else
    # Every stage that can take a second says what it does (issue 37: 18 s of silence at the end).
    for stage in ("the hover state's modes", "loads at every joint", "integration error check",
                  "Richardson extrapolation", "writing the files"):
        assert any(stage in ln for ln in lines), stage


@pytest.mark.whole_job
def test_default_is_silent_off_a_terminal_and_quiet_is_silent(short_flight, tmp_path):
    for flags in ((), ("-q",)):
        done = _run(short_flight, tmp_path / f"o{len(flags)}", *flags)
        assert done.returncode == 0 and done.stderr == "", done.stderr


def test_a_failure_names_its_refinement_level(tmp_path):
    """max_steps = 14000 is enough at n = 11 (11564 steps) and not at n = 22 (16816 steps)."""
    deck = override_deck(FF, tmp_path / "ff.nml", {"refinement": {"levels": "2"}, "solver": {"max_steps": "14000"}})
    with pytest.raises(pydriver.RunError) as exc:
        pydriver.run_deck(deck)
    assert str(exc.value).startswith("refinement level 2 of 2 (n = 22): deck 'ff.nml'")


@pytest.mark.whole_job
def test_the_job_time_is_the_sum_of_its_levels(short_flight):
    s = pydriver.run_deck(short_flight).summary
    assert len(s["wall_time_levels_s"]) == 2
    assert s["wall_time_s"] >= sum(s["wall_time_levels_s"])
