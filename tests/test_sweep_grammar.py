"""A swept value parses as one of the documented forms or the sweep stops before writing
anything, naming the --set option (issue 22: `c_beta=1-70` ran a sweep at 1e-70 and reported
"1 ok"; `1+2` became 100.0)."""

from __future__ import annotations

import subprocess
import sys

import pytest

from conftest import INPUTS


@pytest.mark.parametrize("value,words", [("1-70", "1e-70"), ("1+2", "1e+2"), ("1e", "not a number"),
                                         ("1.2.3", "decimal point"), ("2000000000*1.0", "repeat count")])
def test_malformed_sweep_value_is_refused_before_anything_is_written(tmp_path, value, words):
    out = tmp_path / "sweep"
    done = subprocess.run([sys.executable, "-m", "pydriver", "sweep", str(INPUTS / "uh60_part2_modal.nml"),
                           "--set", f"springs.c_beta={value}", "--out", str(out), "--jobs", "1"],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 2 and "Traceback" not in done.stderr
    assert f"--set springs.c_beta={value}" in done.stderr and words in done.stderr, done.stderr
    assert not out.exists()


def test_documented_forms_still_parse():
    from pydriver.sweep import parse_set
    assert parse_set("springs.c_beta=1e-7")[1] == ["1e-7"]
    assert len(parse_set("springs.c_beta=1:70:24")[1]) == 24
    assert parse_set("springs.c_beta=20,35")[1] == ["20", "35"]
