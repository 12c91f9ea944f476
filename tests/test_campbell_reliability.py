"""Campbell diagram reliability (review findings): the operating range in any order or as one
speed, the MAC warning on a coarse speed grid, the lead-lag band, a cable without stiffness at
rest, runaway counts, and a force pulse that must not reach the modes.

Decks are edits of inputs/uh60_part2_campbell.nml (14 modes, 6 crossings of the harmonics in
0 ... 500 rpm at 26 speeds, ~0.1 s a run) or a small radial chain."""

from __future__ import annotations

import json
import time

import numpy as np
import pytest

import pydriver
from conftest import INPUTS
from pydriver.deckfile import deck_from_text

REFERENCE = (INPUTS / "uh60_part2_campbell.nml").read_text()


def reference(campbell: dict | None = None, replace: dict | None = None, loads: str = "") -> pydriver.Model:
    """The reference Campbell deck with &campbell keys set (added or replaced), other texts
    replaced, and lines added to &loads."""
    text = REFERENCE
    for old, new in (replace or {}).items():
        assert old in text, old
        text = text.replace(old, new)
    body = "".join(f"  {k} = {v}\n" for k, v in (campbell or {}).items())
    head, tail = text.split("&campbell\n")
    kept = [line for line in tail.split("\n") if line.split("=")[0].strip() not in (campbell or {})]
    text = head + "&campbell\n" + body + "\n".join(kept)
    text = text.replace("  gravity = 0.0, 0.0, -9.81\n", "  gravity = 0.0, 0.0, -9.81\n" + loads)
    return pydriver.Model(deck_from_text(text, "campbell_variant.nml"))


def summary(model) -> dict:
    return pydriver.run_deck(model).summary


def deck_error(model_or_factory) -> pydriver.DeckError:
    with pytest.raises(pydriver.DeckError) as exc:
        model = model_or_factory() if callable(model_or_factory) else model_or_factory
        pydriver.run_deck(model)
    return exc.value


@pytest.fixture(scope="module")
def sorted_range() -> dict:
    return summary(reference())


# -- 1. operating range -------------------------------------------------------------------------

def test_a_reversed_range_gives_the_sorted_ranges_crossings_exactly(sorted_range):
    """500, 0 was read as an empty range (0 crossings, lowest frequency 0 Hz); it is the range
    0 ... 500 rpm, with a warning: the same numbers exactly (the same computation)."""
    s = summary(reference({"operating_rpm": "500.0, 0.0"}))
    assert len(sorted_range["crossings"]) == 6
    assert s["crossings"] == sorted_range["crossings"]
    assert s["lowest_frequency_hz"] == sorted_range["lowest_frequency_hz"]
    assert s["operating_rpm"] == [0.0, 500.0]
    assert any("operating_rpm" in w and "high to low" in w for w in s["warnings"])
    assert not any("operating_rpm" in w for w in sorted_range["warnings"])


def test_one_value_is_one_operating_speed_with_a_5_percent_band(sorted_range):
    """operating_rpm = v (an IndexError before) is v +- 5 %: the crossings reported are those of
    the explicit range [0.95 v, 1.05 v], exactly.  v is put 2 % above a known crossing so the
    band holds one."""
    c = sorted_range["crossings"][2]
    v = 1.02 * c["rpm"]
    s = summary(reference({"operating_rpm": f"{v!r}"}))
    assert s["operating_speed_rpm"] == v
    assert s["operating_rpm"] == [0.95 * v, 1.05 * v]
    explicit = summary(reference({"operating_rpm": f"{0.95 * v!r}, {1.05 * v!r}"}))
    assert s["crossings"] == explicit["crossings"]
    assert c in s["crossings"]


def test_one_speed_between_grid_speeds_still_has_its_lowest_frequency():
    """258 rpm +- 5 % on a 100 rpm grid holds no grid speed: the lowest frequency there came
    out as 0 Hz (and "below 1/rev").  It is interpolated at the band's ends: within 1 % of the
    101-speed value (measured 0.16 %: linear interpolation over a 100 rpm step)."""
    coarse = summary(reference({"operating_rpm": "258.0", "n_speeds": "6"}))
    fine = summary(reference({"operating_rpm": "258.0", "n_speeds": "101"}))
    assert coarse["lowest_frequency_hz"] == pytest.approx(fine["lowest_frequency_hz"], rel=0.01)
    assert not coarse["below_1rev_in_operating_range"]


def test_one_value_at_rpm_max_is_cut_at_rpm_max():
    s = summary(reference({"operating_rpm": "500.0", "n_speeds": "6"}))
    assert s["operating_rpm"] == [475.0, 500.0]


@pytest.mark.parametrize("value,words", [("0.0, 250.0, 500.0", "got 3 values"),
                                         ("0.0, 600.0", "above the diagram's rpm_max"),
                                         ("-10.0, 400.0", "")])
def test_a_malformed_operating_range_is_a_deck_error(value, words):
    err = deck_error(lambda: reference({"operating_rpm": value}))
    assert (err.group, err.key) == ("campbell", "operating_rpm") and words in err.reason


# -- 2. MAC tracking on a coarse grid ----------------------------------------------------------

def test_a_coarse_grid_warns_with_the_modes_the_speeds_and_a_finer_n_speeds():
    """11 speeds to 5000 rpm follow modes across a MAC of 0.07 (measured): below 0.9, the
    warning names each mode and its worst step and asks for 21 speeds (half the step)."""
    s = summary(reference({"rpm_max": "5000.0", "n_speeds": "11", "operating_rpm": "0.0, 5000.0"}))
    assert s["min_mac"] < 0.1 and s["mac_threshold"] == 0.9
    [w] = [w for w in s["warnings"] if "MAC" in w]
    assert "mode 2 from 0 to 500 rpm" in w and "n_speeds = 21" in w


def test_a_fine_grid_does_not_warn(sorted_range):
    """The reference grid (26 speeds to 500 rpm: min MAC 0.957) and a fine grid to 5000 rpm
    (201 speeds, measured min MAC above 0.9) give no MAC warning."""
    assert sorted_range["min_mac"] > 0.9
    assert not any("MAC" in w for w in sorted_range["warnings"])
    s = summary(reference({"rpm_max": "5000.0", "n_speeds": "201", "operating_rpm": "0.0, 5000.0"}))
    assert s["min_mac"] >= 0.9
    assert not any("MAC" in w for w in s["warnings"])


# -- 3. lead-lag band --------------------------------------------------------------------------

@pytest.mark.parametrize("band", ["1.1", "1.1, 1.2, 1.4"])
def test_a_malformed_lag_band_is_a_deck_error(band):
    err = deck_error(lambda: reference({"lag_band_hz": band}))
    assert (err.group, err.key) == ("campbell", "lag_band_hz") and "two values" in err.reason


def test_a_negative_lag_band_is_a_deck_error():
    err = deck_error(lambda: reference({"lag_band_hz": "-1.0, 1.4"}))
    assert (err.group, err.key) == ("campbell", "lag_band_hz")


def test_a_reversed_lag_band_is_sorted_and_plotted(tmp_path):
    pytest.importorskip("matplotlib")
    result = pydriver.run_deck(reference({"lag_band_hz": "1.4, 1.1", "n_speeds": "4"}),
                               out=tmp_path / "run", plots=True)
    assert result.summary["lag_band_hz"] == [1.1, 1.4]
    assert any("lag_band_hz" in w for w in result.summary["warnings"])
    assert (tmp_path / "run" / "campbell.png").stat().st_size > 0


@pytest.mark.parametrize("band", [[1.1], [1.4, 1.1], [1.1, 1.2, 1.4], []])
def test_the_plot_takes_any_band_a_summary_holds(tmp_path, band):
    """A summary written elsewhere (or before the deck check) may hold any band: the plot draws
    a two-value band in either order and leaves any other out (an IndexError before)."""
    pytest.importorskip("matplotlib")
    from pydriver import plots
    result = pydriver.run_deck(reference({"n_speeds": "3"}))
    result.summary["lag_band_hz"] = band
    assert list(plots.plot_campbell(result, tmp_path)) == ["campbell.png"]


# -- 4. no stiffness at rest -------------------------------------------------------------------

def _all_finite(result) -> bool:
    json.dumps(result.summary, allow_nan=False)                 # raises on NaN or Inf
    return all(np.all(np.isfinite(np.asarray(v, float)))
               for table in result.extra["tables"].values() for v in table.values())


def test_no_springs_no_gravity_gives_zero_hz_at_rest_and_a_warning():
    """The UH-60 cable without springs and gravity (numpy's LinAlgError before: at rest the
    state matrix is nilpotent and eig returns parallel eigenvectors): at 0 rpm every mode has
    zero stiffness and is drawn at 0 Hz with a warning; turning, the centrifugal load stiffens
    it (the joint dampers, kept, leave most modes overdamped at these speeds: 0 Hz with their
    own warning).  Every number finite."""
    model = reference({"n_speeds": "6"}, {"c_beta = 35.531": "c_beta = 0.0", "c_gamma = 1.0e-4": "c_gamma = 0.0",
                                          "gravity = 0.0, 0.0, -9.81": "gravity = 0.0, 0.0, 0.0"})
    result = pydriver.run_deck(model)
    s = result.summary
    f = np.array(s["frequencies_hz"])
    assert np.all(f[0] == 0.0) and np.any(f[1:] > 0.0)
    assert sum("zero stiffness" in w for w in s["warnings"]) == 6
    assert _all_finite(result)


def pendulum(n_speeds: int = 3) -> pydriver.Model:
    """Two bodies along the rotor radius from its axis: body 1 locked (clamped, the hinge at
    e = l), body 2 hinged without springs (xy joint: lag and flap), no gravity."""
    return pydriver.Model(deck_from_text(f"""&case analysis = 'campbell' /
&chain n_bodies = 2, total_length = 2.0, diameter = 1.0e-4, total_mass = 1.0, joint = 'xy',
  first_body = 'clamped' /
&clamp_a beta_deg = 90.0 /
&shape gamma_deg = 0.0, beta_deg = 0.0 /
&loads gravity = 0.0, 0.0, 0.0 /
&rotor rpm = 300.0, centre = 0.0, 0.0, 0.0 /
&campbell rpm_max = 300.0, n_speeds = {n_speeds}, n_modes = 2 /""", "pendulum.nml"))


def test_the_centrifugal_pendulum_has_zero_stiffness_at_rest_and_its_textbook_frequencies():
    """A uniform rod hinged at e from the axis, length L: lag nu^2 = 3e/(2L), flap
    nu^2 = 1 + 3e/(2L) per rev (Johnson, Helicopter Theory, 1980, sections 9.2-9.3; e = L:
    1.5 and 2.5).  At rest both are zero-stiffness modes at 0 Hz, zeta 0 throughout.  To 1e-6
    (the rod's diameter adds (d/L)^2 ~ 1e-8)."""
    result = pydriver.run_deck(pendulum())
    s = result.summary
    f = np.array(s["frequencies_hz"])
    rev = np.array(s["rpm"]) / 60.0
    assert np.all(f[0] == 0.0)
    assert f[1:, 0] / rev[1:] == pytest.approx(np.sqrt(1.5), rel=1e-6)
    assert f[1:, 1] / rev[1:] == pytest.approx(np.sqrt(2.5), rel=1e-6)
    assert np.max(np.abs(result.extra["tables"]["campbell.csv"]["zeta"])) < 1e-12    # undamped
    assert [w for w in s["warnings"] if "zero stiffness" in w] and _all_finite(result)


# -- 5. bounds on the counts -------------------------------------------------------------------

@pytest.mark.parametrize("key", ["harmonics", "n_speeds", "n_modes"])
def test_a_runaway_count_is_a_deck_error_within_a_second(key):
    """harmonics = 1e8 ran for hours; every count has a schema bound, so the deck fails when it
    is read (1 s: generous for a parse, 0.01 s measured)."""
    t0 = time.perf_counter()
    err = deck_error(lambda: reference({key: "100000000"}))
    assert time.perf_counter() - t0 < 1.0
    assert (err.group, err.key) == ("campbell", key) and "at most" in err.reason


def test_more_modes_than_the_model_has_is_a_deck_error_before_any_solve():
    """The reference model has 14 modes (coordinates minus constraints): 15 is refused at once."""
    t0 = time.perf_counter()
    err = deck_error(lambda: reference({"n_modes": "15"}))
    assert time.perf_counter() - t0 < 1.0
    assert (err.group, err.key) == ("campbell", "n_modes") and "14 modes" in err.reason


# -- 6. a force pulse stays out of the modes ---------------------------------------------------

def test_a_pulse_does_not_change_the_modes(sorted_range):
    """A pulse active at t = 0 had been solved into every equilibrium (frequencies off by up
    to 360 %, and an unstable equilibrium reported at every speed).  The diagram is that of
    the steady loads: the same frequencies as without the pulse to 1e-9 relative (it is the
    same computation), and a note says the pulse was left out."""
    s = summary(reference(loads="  pulse_body = 6\n  pulse_force = 0.0, 0.0, 50.0\n"
                                "  pulse_start = 0.0\n  pulse_end = 0.1\n"))
    f, f0 = np.array(s["frequencies_hz"]), np.array(sorted_range["frequencies_hz"])
    assert np.max(np.abs(f - f0) / f0) <= 1e-9
    assert s["crossings"] == sorted_range["crossings"] and not s["unstable_rpm"]
    assert any("pulse" in w and "unforced" in w for w in s["warnings"])

