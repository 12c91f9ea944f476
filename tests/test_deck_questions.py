"""A run answers the question its deck asks, or refuses it (issue 20): a pulse does not leak
into an equilibrium, angles beyond one turn are not wound springs, a lone scalar does not mean
something else than in Fortran, a malformed number is not two numbers, and absurd or
overflowing values fail at once with the key named."""

from __future__ import annotations

import time

import numpy as np
import pytest

import pydriver
from conftest import INPUTS
from pydriver.study import override_deck


def deck(tmp_path, stem, changes, name="case"):
    return override_deck(INPUTS / f"{stem}.nml", tmp_path / f"{name}.nml", changes)


def refused(path, group, key, *words):
    t0 = time.perf_counter()
    with pytest.raises(pydriver.DeckError) as exc:
        pydriver.run_deck(path)
    # Refused at once: before any model is built or memory allocated (1 s bounds a slow CI).
    assert time.perf_counter() - t0 < 1.0
    err = exc.value
    assert (err.group, err.key) == (group, key), str(err)
    for w in words:
        assert w in str(err), str(err)
    return err


def test_pulse_does_not_leak_into_statics(tmp_path):
    """A 100 N pulse active at t = 0 gave F_A,z = 25.1 N instead of 75.1 N (six-link case)."""
    base = pydriver.run_deck(INPUTS / "six_link_static.nml")
    p = deck(tmp_path, "six_link_static", {"loads": {"pulse_body": "3", "pulse_force": "0.0, 0.0, 100.0",
                                                     "pulse_start": "0.0", "pulse_end": "1.0"}})
    res = pydriver.run_deck(p)
    # Identical problem once the pulse is left out: the same Newton iterates, so round-off only.
    assert res.summary["reactions"]["A"]["F"][2] == pytest.approx(base.summary["reactions"]["A"]["F"][2],
                                                                   rel=1e-12)
    assert any("unforced" in w for w in res.summary["warnings"])


def test_pulse_does_not_leak_into_modal(tmp_path):
    """uh60_part2_decay as a modal run gave f1 = 26.10 Hz; without its pulse 26.25 Hz."""
    p = deck(tmp_path, "uh60_part2_decay", {"case": {"analysis": "'modal'"}})
    q = deck(tmp_path, "uh60_part2_decay", {"case": {"analysis": "'modal'"}, "loads": {"pulse_body": "0"}},
             name="nopulse")
    with_pulse, without = pydriver.run_deck(p), pydriver.run_deck(q)
    np.testing.assert_allclose(with_pulse.summary["frequencies_hz"], without.summary["frequencies_hz"],
                               rtol=1e-12)
    assert with_pulse.summary["frequencies_hz"][0] == pytest.approx(26.25, abs=0.01)   # issue 20's value
    assert any("unforced" in w for w in with_pulse.summary["warnings"])


@pytest.mark.parametrize("group,key,value", [
    ("shape", "beta_deg", "70.0, 372.0, 9*12.0"),         # the shape of 12 deg, a spring wound once
    ("shape", "gamma_deg", "90.0, 90.0, 9*-190.0"),
    ("springs", "rest_beta_deg", "11*200.0"),
    ("shape", "beta_deg", "70.0, 2147483648.0, 9*12.0"),  # ran 4 min before a RunError
])
def test_angles_beyond_one_turn_are_refused(tmp_path, group, key, value):
    changes = {group: {key: value}}
    if group == "springs":
        changes[group]["c_beta"] = "11*35.531"
    p = deck(tmp_path, "uh60_part2_modal", changes)
    refused(p, group, key, "wound", "180")


@pytest.mark.parametrize("group,key", [("shape", "beta_deg"), ("springs", "rest_beta_deg"),
                                       ("shape", "gamma_rate_deg")])
def test_lone_scalar_on_a_shape_key_is_refused(tmp_path, group, key):
    """``rest_beta_deg = 90.0`` set every joint here but only joint 1 in a Fortran read."""
    p = deck(tmp_path, "uh60_part2_modal", {group: {key: "90.0"}})
    refused(p, group, key, "11*90", "Fortran")


def test_lone_zero_and_per_body_forms_stay_valid(tmp_path):
    """0 reads the same in both semantics; n*value is the explicit broadcast."""
    p = deck(tmp_path, "uh60_part2_modal", {"springs": {"rest_beta_deg": "0.0"},
                                            "shape": {"gamma_rate_deg": "11*0.0"}})
    assert pydriver.Model.from_deck(p).deck["springs.rest_beta_deg"].tolist() == [0.0] * 11


def test_spring_constants_still_broadcast(tmp_path):
    p = deck(tmp_path, "uh60_part2_modal", {"springs": {"c_beta": "35.531"}})
    assert pydriver.Model.from_deck(p).deck["springs.c_beta"].tolist() == [35.531] * 11


@pytest.mark.parametrize("text,words", [("1.2.3", "decimal point"), ("1-70", "1e-70"), ("1+2", "1e+2"),
                                        ("1e", "not a number"), ("0.0, 1.2.3", "decimal point")])
def test_malformed_reals_are_refused(tmp_path, text, words):
    p = deck(tmp_path, "uh60_part2_forward_flight_cable", {})
    src = p.read_text()
    assert "pitch_deg" in src
    import re
    p.write_text(re.sub(r"pitch_deg\s*=[^\n]*", f"pitch_deg = {text}", src))
    refused(p, "blade", "pitch_deg", words)


@pytest.mark.parametrize("group,key,value,words", [
    ("solver", "max_steps", "3000000000", "32-bit"),
    ("solver", "jacobian_max_age", "3000000000", "32-bit"),
    ("solver", "newton_max_iter", "3000000000", "32-bit"),
    ("solver", "samples_per_rev", "3000000000", "32-bit"),
    ("solver", "samples_per_rev", "1000000", "at most"),
    ("springs", "d_beta", "11*1.0e300", "out of range"),
    ("chain", "diameter", "4.9e-324", "out of range"),
])
def test_out_of_range_values_are_refused(tmp_path, group, key, value, words):
    p = deck(tmp_path, "uh60_part2_modal", {group: {key: value}})
    refused(p, group, key, words)


def test_denormal_rotor_speed_is_refused(tmp_path):
    """rpm = 4.9e-324 gave a ZeroDivisionError (a period of 1e322 s)."""
    p = deck(tmp_path, "uh60_part2_forward_flight_cable", {"rotor": {"rpm": "4.9e-324"}})
    refused(p, "rotor", "rpm", "0 (none) or at least")


def test_huge_repeat_count_is_refused_at_once(tmp_path):
    """``beta_deg = 2000000000*1.0`` expanded two billion floats: MemoryError after 24 s."""
    p = tmp_path / "case.nml"
    p.write_text((INPUTS / "uh60_part2_modal.nml").read_text().replace("beta_deg  = 70.0, 10*12.0",
                                                                       "beta_deg = 2000000000*1.0"))
    assert "2000000000*" in p.read_text()
    refused(p, "shape", "beta_deg", "repeat count")


def test_memory_budget_names_the_number(tmp_path):
    p = deck(tmp_path, "uh60_part2_forward_flight_cable", {"solver": {"samples_per_rev": "36000"},
                                                           "chain": {"n_bodies": "400"},
                                                           "shape": {"gamma_deg": "0.0, 90.0, 398*0.0",
                                                                     "beta_deg": "0.0, 399*12.0"}})
    err = refused(p, "solver", "samples_per_rev", "budget")
    assert "values in memory" in str(err)
