"""Output files and the Python API (DEVELOPERS conventions)."""

import csv
import json

import numpy as np
import pytest

import pydriver
from pydriver.output_columns import bare_name
from conftest import INPUTS, ROOT


def test_static_outputs(tmp_path):
    res = pydriver.run_deck(INPUTS / "six_link_static.nml", out=tmp_path)
    s = json.loads((tmp_path / "summary.json").read_text())
    for key in ("case", "analysis", "wall_time_s", "solver", "max_constraint_violation_m", "reactions"):
        assert key in s
    assert set(s["reactions"]) == {"A", "B"} and len(s["reactions"]["B"]["M"]) == 3
    rows = [{bare_name(k): v for k, v in r.items()} for r in csv.DictReader((tmp_path / "table.csv").open())]
    # The thesis's columns first, in their order, each with its unit (issue 22); more columns
    # may follow (joint loads).
    header = (tmp_path / "table.csv").open().readline().strip().split(",")
    assert header[:6] == ["body [-]", "gamma_deg [deg]", "beta_deg [deg]", "x_m [m]", "y_m [m]", "z_m [m]"]
    assert len(rows) == 5
    # table.csv carries full precision, table.txt the thesis's 2/4 decimals.
    assert float(rows[2]["y_m"]) == pytest.approx(res.table["y_m"][2], abs=1e-15)
    txt = (tmp_path / "table.txt").read_text().splitlines()
    assert txt[0].split()[0] == "body" and len(txt[1].split()) == 6          # English by default
    assert txt[3].split() == ["3", "90.00", "90.00", "0.2000", "0.1000", "-0.2000"]
    assert txt[-1].startswith("Table: static equilibrium") and "c_beta = " in txt[-1]   # the deck's key
    assert [p.name for p in tmp_path.glob(".*")] == [".rotorcable-run.json"]    # no temporaries left


def test_table_in_the_thesis_german(tmp_path):
    """&output table_language = 'de': the thesis appendix's own form, decimal commas."""
    deck = tmp_path / "de.nml"
    deck.write_text((INPUTS / "six_link_static.nml").read_text() + "\n&output\n  table_language = 'de'\n/\n")
    pydriver.run_deck(deck, out=tmp_path / "o")
    txt = (tmp_path / "o" / "table.txt").read_text().splitlines()
    assert txt[0].split()[0] == "Körper" and txt[3].split() == ["3", "90,00", "90,00", "0,2000", "0,1000", "-0,2000"]
    assert txt[-1].startswith("Tabelle: Statische Ruhelage")


def test_dynamic_outputs(tmp_path):
    res = pydriver.run_deck(INPUTS / "six_link_dynamic.nml", out=tmp_path)
    header = [bare_name(c) for c in (tmp_path / "timeseries.csv").open().readline().strip().split(",")]
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


def test_outputs_reference_is_current():
    """docs/outputs.md is generated from pydriver/output_columns.py."""
    from pydriver.output_columns import outputs_markdown
    assert (ROOT / "docs" / "outputs.md").read_text() == outputs_markdown(), \
        "run: python -m pydriver.output_columns"


@pytest.mark.parametrize("stem", ["uh60_part2_forward_flight_cable", "uh60_part2_campbell", "uh60_part2_modal",
                                  "six_link_dynamic", "six_link_static"])
def test_every_written_column_has_a_unit_and_a_meaning(tmp_path, stem):
    """Each CSV header cell is 'name [unit]', and each name has a row in docs/outputs.md."""
    from pydriver.output_columns import _UNIT, column_of
    deck = INPUTS / f"{stem}.nml"
    model = pydriver.Model.from_deck(deck)
    if model.deck["refinement.levels"] > 1:
        model = model.with_changes({"refinement.levels": 2})
    pydriver.run_deck(model, out=tmp_path / "o")
    for csv_file in (tmp_path / "o").glob("*.csv"):
        cells = csv_file.open().readline().strip().split(",")
        for cell in cells:
            m = _UNIT.match(cell)
            assert m, (csv_file.name, cell)
            assert column_of(csv_file.name, m.group(1)) is not None, (csv_file.name, cell)


@pytest.mark.parametrize("value,words", [("'fr'", "'en' | 'de'"), ("'en', 'de'", "one value"),
                                         ("2000000000*'en'", "repeat count"), ("1.0", "not a string")])
def test_table_language_is_checked(tmp_path, value, words):
    """The new key's fuzz cases: unknown, wrong count, huge repeat, wrong type."""
    deck = tmp_path / "bad.nml"
    deck.write_text((INPUTS / "six_link_static.nml").read_text() + f"\n&output\n  table_language = {value}\n/\n")
    with pytest.raises(pydriver.DeckError) as exc:
        pydriver.run_deck(deck)
    assert (exc.value.group, exc.value.key) == ("output", "table_language") and words in str(exc.value)
