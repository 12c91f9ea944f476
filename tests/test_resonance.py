"""Resonance margins in every modal, Campbell and flight run (issue 21 item 2): the distance of
each mode from the nearest k/rev harmonic at the operating speed, flagged below the deck's
margin."""

from __future__ import annotations

import numpy as np
import pytest

import pydriver
from conftest import INPUTS
from pydriver.analyses.hover_modes import hover_model
from pydriver.analyses.resonance import harmonic_margin

FLIGHT = INPUTS / "uh60_part2_forward_flight_cable.nml"


def test_margin_in_closed_form():
    """16.5 Hz at 260 rpm: 4/rev = 17.333 Hz, margin |16.5 - 17.333| / 17.333 = 4.808 %; an error
    bar of 0.5 Hz narrows it to 0.3333 / 17.333 = 1.923 %, one of 1 Hz covers the harmonic."""
    m = harmonic_margin(16.5, 0.0, 260.0, 8)
    assert m["harmonic"] == 4 and m["harmonic_hz"] == pytest.approx(260.0 * 4 / 60.0, rel=1e-15)
    assert m["margin_percent"] == pytest.approx(100 * (52 / 3 - 16.5) / (52 / 3), rel=1e-12)
    assert harmonic_margin(16.5, 0.5, 260.0, 8)["worst_margin_percent"] == pytest.approx(
        100 * (52 / 3 - 17.0) / (52 / 3), rel=1e-12)
    assert harmonic_margin(16.5, 1.0, 260.0, 8)["worst_margin_percent"] == 0.0
    # Above the highest harmonic the nearest is the highest one.
    assert harmonic_margin(100.0, 0.0, 260.0, 2)["harmonic"] == 2


@pytest.fixture(scope="module")
def flight_n11():
    """The README's main job at its base n (the refined run repeats it at 22 and 44)."""
    model = pydriver.Model.from_deck(FLIGHT).with_changes({"refinement.levels": 1})
    return model, pydriver.run_deck(model)


def test_the_main_job_says_its_first_mode_is_near_4_per_rev(flight_n11):
    """The converged cable's first mode sits next to 4/rev at 260 rpm; the flight run must say
    so (issue 21).  At n = 11 the hover mode is 16.34 Hz, 5.7 % below 4/rev = 17.33 Hz."""
    _, res = flight_n11
    block = res.summary["resonance"]
    assert block["operating_rpm"] == [260.0] and block["required_margin_percent"] == 10.0
    first = block["modes"][0]
    assert first["mode"] == 1 and first["harmonic"] == 4 and first["within_margin"]
    assert 3.0 < first["margin_percent"] < 8.0
    assert any("mode 1" in w and "4/rev" in w for w in res.summary["warnings"])


def test_hover_modes_agree_with_the_campbell_diagram_at_that_speed(flight_n11):
    """Two routes to the same modes: the Fortran modal analysis (dggev on the reduced pencil) of
    the hover state, and the Campbell analysis (numpy eig of the state matrix, its own
    equilibrium continuation from 0 rpm).  Both solve the same linearisation, so they agree to
    the eigen-solvers' round-off; 1e-7 relative allows for the two equilibria's Newton tolerances."""
    model, res = flight_n11
    camp = hover_model(model).with_changes({"case.analysis": "campbell", "campbell.rpm_max": 260.0,
                                            "campbell.n_speeds": 3, "campbell.n_modes": 4})
    c = pydriver.run_deck(camp)
    at_260 = np.asarray(c.summary["frequencies_hz"][-1])
    fd = np.asarray(res.summary["damped_frequencies_hz"][:4])
    np.testing.assert_allclose(np.sort(at_260), np.sort(fd), rtol=1e-7)


def test_the_deck_sets_the_margin_and_the_speed(flight_n11):
    model, _ = flight_n11
    relaxed = pydriver.run_deck(model.with_changes({"resonance.margin_percent": 2.0}))
    assert not relaxed.summary["resonance"]["flagged"]
    assert not any(w.startswith("resonance") for w in relaxed.summary.get("warnings", []))
    # At 240 rpm (4/rev = 16 Hz) the 16.34 Hz mode is 2.1 % above 4/rev.
    other = pydriver.run_deck(model.with_changes({"resonance.operating_rpm": [240.0]}))
    row = other.summary["resonance"]["modes"][0]
    assert row["harmonic"] == 4 and row["operating_rpm"] == 240.0
    assert row["margin_percent"] == pytest.approx(100 * abs(row["frequency_hz"] - 16.0) / 16.0, rel=1e-12)


def test_refined_margins_carry_error_bars(tmp_path):
    """With &refinement the margins use the extrapolated frequency and its error bar."""
    model = pydriver.Model.from_deck(FLIGHT).with_changes({"refinement.levels": 2, "case.analysis": "modal"})
    res = pydriver.run_deck(model.with_changes({"resonance.operating_rpm": [260.0]}), out=tmp_path / "o")
    first = res.summary["resonance"]["modes"][0]
    q = res.summary["refinement"]["quantities"]["fd1 [Hz]"]
    assert first["frequency_hz"] == q["extrapolated"] and first["error_hz"] == q["error_estimate"] > 0
    assert (tmp_path / "o" / "resonance.csv").is_file()


def test_a_still_rotor_without_an_operating_speed_says_so():
    res = pydriver.run_deck(INPUTS / "uh60_part2_modal.nml")
    assert res.summary["resonance"]["operating_rpm"] == [] and "operating_rpm" in res.summary["resonance"]["note"]


def test_campbell_margins_over_the_operating_range_find_the_crossings():
    """Over a range, a mode crossing a harmonic inside it has margin 0 at the crossing."""
    res = pydriver.run_deck(INPUTS / "uh60_part2_campbell.nml")
    block = res.summary["resonance"]
    crossed = {c["mode"] for c in res.summary["crossings"]}
    for row in block["modes"]:
        if row["mode"] in crossed:
            assert row["worst_margin_percent"] < 0.5     # the fine sampling (401 speeds) of the range
    assert crossed <= {r["mode"] for r in block["flagged"]}


@pytest.mark.parametrize("key,value,words", [
    ("margin_percent", "1.0e9", "out of range"),            # huge
    ("margin_percent", "-4.9e-324", "allowed"),             # tiny, below the range
    ("harmonics", "100000000", "at most"),                  # huge count
    ("harmonics", "0", "at least"),
    ("operating_rpm", "-260.0", "allowed"),
    ("margin_percent", "10.0, 20.0", "one value"),          # wrong count
    ("operating_rpm", "1.0e9", "out of range"),
    ("excitation", "'fixed'", "'every' | 'blade_passage'"),
    ("blades", "0", "at least 1"),
    ("blades", "9", "at most 8"),
    ("harmonics", "3\n  excitation = 'blade_passage'", "below &resonance blades = 4"),   # no harmonic left
])
def test_resonance_keys_are_checked(tmp_path, key, value, words):
    text = FLIGHT.read_text() + f"\n&resonance\n  {key} = {value}\n/\n"
    p = tmp_path / "deck.nml"
    p.write_text(text)
    with pytest.raises(pydriver.DeckError) as exc:
        pydriver.run_deck(p)
    assert (exc.value.group, exc.value.key) == ("resonance", key) and words in str(exc.value)


def test_blade_passage_excitation_checks_the_multiples_of_the_blade_count(flight_n11):
    """excitation = 'blade_passage' checks k = blades, 2 blades, ... <= harmonics.  The main job's
    first mode (16.22 Hz damped at n = 11) with 3 blades: 3/rev = 13 Hz and 6/rev = 26 Hz, the
    nearest 3/rev, (16.22 - 13)/13; with 4 blades 4/rev as with every harmonic; and a mode is
    listed up to one harmonic above the highest checked, 9/rev = 39 Hz with 8 (4, 8) as with
    every harmonic, 10/rev = 43.3 Hz with 9 (3, 6, 9)."""
    model, every = flight_n11
    f1 = every.summary["damped_frequencies_hz"][0]
    three = pydriver.run_deck(model.with_changes({"resonance.excitation": "blade_passage", "resonance.blades": 3,
                                                  "resonance.harmonics": 9})).summary["resonance"]
    assert three["excited_harmonics"] == [3, 6, 9] and three["excitation"] == "blade_passage"
    row = three["modes"][0]
    assert row["harmonic"] == 3
    assert row["margin_percent"] == pytest.approx(100 * (f1 - 13.0) / 13.0, rel=1e-12)
    assert max(r["frequency_hz"] for r in three["modes"]) <= 10 * 260.0 / 60.0
    four = pydriver.run_deck(model.with_changes({"resonance.excitation": "blade_passage"})).summary["resonance"]
    assert four["excited_harmonics"] == [4, 8]
    assert four["modes"] == every.summary["resonance"]["modes"]            # mode 1's nearest is 4/rev either way


def test_campbell_crossings_follow_the_excitation():
    """The Campbell diagram counts crossings with the excited harmonics only: with 'blade_passage'
    (4 blades) exactly the crossings with 4/rev and 8/rev of the diagram that counts every k/rev."""
    every = pydriver.run_deck(INPUTS / "uh60_part2_campbell.nml").summary
    deck = pydriver.Model.from_deck(INPUTS / "uh60_part2_campbell.nml")
    passage = pydriver.run_deck(deck.with_changes({"resonance.excitation": "blade_passage"})).summary
    assert passage["excited_harmonics"] == [4, 8] and every["excited_harmonics"] == list(range(1, 9))
    assert {c["harmonic"] for c in every["crossings"]} - {4, 8}       # the test has something to remove
    assert passage["crossings"] == [c for c in every["crossings"] if c["harmonic"] in (4, 8)]


def test_reversed_operating_speeds_give_the_same_margins(flight_n11):
    model, _ = flight_n11
    a = pydriver.run_deck(model.with_changes({"resonance.operating_rpm": [250.0, 270.0]}))
    b = pydriver.run_deck(model.with_changes({"resonance.operating_rpm": [270.0, 250.0]}))
    key = lambda r: (r["operating_rpm"], r["mode"])          # noqa: E731
    assert sorted(a.summary["resonance"]["modes"], key=key) == sorted(b.summary["resonance"]["modes"], key=key)
