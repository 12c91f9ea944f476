"""Output files and the Python API (DEVELOPERS conventions)."""

import csv
import json

import numpy as np
import pytest

import pydriver
from conftest import INPUTS


def test_static_outputs(tmp_path):
    res = pydriver.run_deck(INPUTS / "six_link_static.nml", out=tmp_path)
    s = json.loads((tmp_path / "summary.json").read_text())
    for key in ("case", "analysis", "wall_time_s", "solver", "max_constraint_violation_m", "reactions"):
        assert key in s
    assert set(s["reactions"]) == {"A", "B"} and len(s["reactions"]["B"]["M"]) == 3
    rows = list(csv.DictReader((tmp_path / "table.csv").open()))
    # The thesis's columns first, in their order; more columns may follow (joint loads).
    assert list(rows[0])[:6] == ["body", "gamma_deg", "beta_deg", "x_m", "y_m", "z_m"]
    assert len(rows) == 5
    # table.csv carries full precision, table.txt the thesis's 2/4 decimals.
    assert float(rows[2]["y_m"]) == pytest.approx(res.table["y_m"][2], abs=1e-15)
    txt = (tmp_path / "table.txt").read_text().splitlines()
    assert txt[0].split()[0] == "Körper" and len(txt[1].split()) == 6
    assert txt[3].split() == ["3", "90.00", "90.00", "0.2000", "0.1000", "-0.2000"]
    assert "c_y" in txt[-1]
    assert [p.name for p in tmp_path.glob(".*")] == [".rotorcable-run.json"]    # no temporaries left


def test_dynamic_outputs(tmp_path):
    res = pydriver.run_deck(INPUTS / "six_link_dynamic.nml", out=tmp_path)
    header = (tmp_path / "timeseries.csv").open().readline().strip().split(",")
    n = 5
    expect = (["t"] + [f"{c}{j}" for j in range(1, n + 1) for c in "xyz"]
              + [f"{a}{j}_deg" for j in range(1, n + 1) for a in ("gamma", "beta")]
              + ["FA_x", "FA_y", "FA_z", "MA_x", "MA_y", "MA_z", "FB_x", "FB_y", "FB_z", "MB_x", "MB_y", "MB_z"])
    assert header[:len(expect)] == expect          # more columns may follow (joint loads, ...)
    data = np.loadtxt(tmp_path / "timeseries.csv", delimiter=",", skiprows=1)
    assert data.shape == (2001, len(header))
    assert np.allclose(data[:, expect.index("FB_z")], res.timeseries["FB_z"], rtol=0, atol=1e-12)
    s = json.loads((tmp_path / "summary.json").read_text())
    for key in ("steps", "residual_evals", "jacobian_evals", "error_test_failures", "convergence_failures"):
        assert s["solver"][key] >= 0
    assert s["solver"]["steps"] > 100


def test_open_chain_has_no_clamp_b_columns():
    res = pydriver.run_deck(INPUTS / "three_body.nml")
    assert "FB_x" not in res.timeseries and "FA_x" in res.timeseries
    assert "B" not in res.summary["reactions"]
    assert res.summary["n_constraints"] == 0


def test_plots_are_written(tmp_path):
    pytest.importorskip("matplotlib")
    pydriver.run_deck(INPUTS / "six_link_static.nml", out=tmp_path, plots=True)
    assert (tmp_path / "shape.png").stat().st_size > 1000


def test_study_plots_and_decay_plot(tmp_path):
    pytest.importorskip("matplotlib")
    from pydriver.study import run_study
    run_study("shapes", tmp_path, inputs=INPUTS)
    for part in (1, 2):
        assert (tmp_path / f"uh60_part{part}_rest_vs_hover.png").stat().st_size > 10000
    res = pydriver.run_deck(INPUTS / "uh60_part2_decay.nml", out=tmp_path / "decay", plots=True)
    assert (tmp_path / "decay" / "decay.png").stat().st_size > 10000
    assert json.loads((tmp_path / "decay" / "summary.json").read_text())["decay"]["f_damped_hz"] == \
        pytest.approx(res.summary["decay"]["f_damped_hz"])
