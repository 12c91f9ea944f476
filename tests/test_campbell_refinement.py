"""Converged Campbell diagram (issue 21 item 1): ``&refinement levels = 3`` runs the diagram at
n, 2n, 4n bodies and gives every tracked frequency at each speed and every crossing speed in
the operating range its Richardson value, observed order and error bar.

Case: the uniform radial cantilever of tests/test_campbell.py (Hencky chain in one plane,
&cable, no gravity: second order in 1/n, docs/model.md "Converged numbers").  Its lead-lag
mode, w^2 = w0^2 + (K - 1) Omega^2 with Southwell's K = 1.193, meets 1/rev near 52 rpm."""

from __future__ import annotations

import numpy as np
import pytest

import pydriver
from pydriver.analyses.campbell import refine_crossings
from pydriver.deckfile import deck_from_text
from pydriver.errors import DeckError

EI, MU, L = 1.0, 0.5, 1.0
RPM_MAX, N_SPEEDS = 80.0, 9          # 10 rpm steps; the 1/rev crossing lies in 50 ... 60 at every n


def radial(n: int, levels: int, cable: bool = True) -> pydriver.Model:
    stiffness = f"&cable ei = {EI}, mass_per_length = {MU} /" if cable else \
        "&springs c_beta = 10.0 /"
    mass = "" if cable else ", total_mass = 0.5"
    return pydriver.Model(deck_from_text(f"""&case analysis = 'campbell' /
&chain n_bodies = {n}, total_length = {L}, diameter = 1.0e-4, joint = 'xy', first_body = 'clamped'{mass} /
{stiffness}
&clamp_a beta_deg = 90.0 /
&shape gamma_deg = 0.0, beta_deg = 0.0 /
&loads gravity = 0.0, 0.0, 0.0 /
&rotor rpm = {RPM_MAX}, centre = 0.0, 0.0, 0.0 /
&campbell rpm_max = {RPM_MAX}, n_speeds = {N_SPEEDS}, n_modes = 4, harmonics = 2, operating_rpm = 40.0, 70.0 /
&refinement levels = {levels} /""", f"radial{n}.nml"))


@pytest.fixture(scope="module")
def refined():
    return pydriver.run_deck(radial(8, 3))


@pytest.fixture(scope="module")
def fine64():
    """The same diagram at n = 64, one level: its values differ from the limit by ~1/16 of the
    n = 16 -> 32 error (second order), well inside the error bars of the n = 8, 16, 32 run."""
    return pydriver.run_deck(radial(64, 1))


def test_crossing_speed_converges_at_second_order(refined, fine64):
    """The lag mode's 1/rev crossing at n = 8, 16, 32: observed order within 0.2 of 2 (measured
    1.94), and the extrapolated speed agrees with n = 64 on the same speed grid within the
    error bar (measured: 52.384 +- 0.057 rpm; n = 64 gives 52.37, n = 128 52.378).  The speed
    grid's interpolation error is the same at every n and is not part of this comparison."""
    s = refined.summary
    assert s["refinement"]["n"] == [8, 16, 32]
    (c,) = [c for c in s["crossings"] if (c["mode"], c["harmonic"]) == (1, 1)]
    assert c["matched"] and not c["warning"]
    assert abs(c["rpm_order"] - 2.0) < 0.2
    assert [c["rpm_n8"], c["rpm_n16"], c["rpm_n32"]] == sorted([c["rpm_n8"], c["rpm_n16"], c["rpm_n32"]])
    (ref,) = [x for x in fine64.summary["crossings"] if (x["mode"], x["harmonic"]) == (1, 1)]
    assert abs(c["rpm_extrapolated"] - ref["rpm"]) <= c["rpm_error"]
    assert c["f_extrapolated_hz"] == pytest.approx(c["rpm_extrapolated"] / 60.0, rel=1e-12)
    assert c["f_error_hz"] == pytest.approx(c["rpm_error"] / 60.0, rel=1e-12)
    q = s["refinement"]["quantities"]["mode 1 x 1/rev [rpm]"]
    assert q["extrapolated"] == c["rpm_extrapolated"] and q["order_observed"]
    table = refined.extra["tables"]["campbell_crossings.csv"]
    for col in ("rpm_extrapolated", "rpm_error", "rpm_order", "f_extrapolated_hz", "f_error_hz", "f_order",
                "rpm_n8", "rpm_n16", "rpm_n32"):
        assert col in table


def test_every_tracked_frequency_is_extrapolated(refined, fine64):
    """campbell.csv gains f_extrapolated_hz, f_error_hz and f_order at every (speed, mode);
    every order lies within 0.2 of 2 (measured 1.89 ... 1.99) and every extrapolated value is
    within its error bar of the n = 64 diagram."""
    t = refined.extra["tables"]["campbell.csv"]
    ext, err, order = (np.asarray(t[k], float) for k in ("f_extrapolated_hz", "f_error_hz", "f_order"))
    assert len(ext) == N_SPEEDS * 4 and np.all(np.isfinite(ext))
    assert np.all(np.abs(order - 2.0) < 0.2)
    f64 = np.asarray(fine64.extra["campbell"]["f"], float).reshape(-1)
    assert np.all(np.abs(ext - f64) <= err)
    assert not [w for w in refined.summary.get("warnings", []) if w.startswith("refinement")]


def test_margins_use_the_extrapolated_frequencies(refined):
    """The resonance margins of a refined diagram carry the error bars of its frequencies."""
    rows = refined.summary["resonance"]["modes"]
    assert rows and all(r["error_hz"] is not None and r["error_hz"] > 0.0 for r in rows)
    lag = [r for r in rows if r["mode"] == 1][0]
    assert lag["worst_margin_percent"] == 0.0          # the 1/rev crossing lies in the range


def test_a_crossing_at_one_level_only_is_reported_with_a_warning():
    """Level n crosses 2/rev at 55 rpm, 2n and 4n stay above it: the crossing is listed (its
    extrapolation NaN, the levels' speeds given) and warned about, not dropped."""
    rpm = np.linspace(0.0, 100.0, 11)
    crossing = np.full((11, 1), 1.0) + rpm[:, None] / 60.0        # meets 2/rev at 60 rpm
    above = np.full((11, 1), 5.0)
    rows, warnings = refine_crossings([(rpm, crossing), (rpm, above), (rpm, above)], [4, 8, 16], 2, (40.0, 80.0), 2.0)
    (row,) = rows
    assert not row["matched"] and row["rpm_n4"] == pytest.approx(60.0) and np.isnan(row["rpm_n16"])
    assert np.isnan(row["rpm_extrapolated"])
    assert len(warnings) == 1 and "none at n = 8, 16" in warnings[0]


def test_refinement_still_needs_the_cable_parameters():
    with pytest.raises(DeckError, match="physical cable parameters"):
        radial(8, 3, cable=False)


# -- the physical range (issue 35) ---------------------------------------------------------------

def test_a_crossing_extrapolated_below_zero_is_no_result():
    """The forward-flight cable as a refined Campbell diagram crossed 4/rev at 234.4, 236.1 and
    0.0119 rpm at n = 11, 22, 44 and wrote the extrapolation -78.7 +- 236 rpm.  Such a crossing
    keeps its levels' speeds, has no extrapolation (NaN: a blank cell) and, its finest level
    being the one that departs, no speed of its own; the warning names that level."""
    rpm = np.linspace(0.0, 300.0, 31)
    levels = [np.full((31, 1), 4.0 * r / 60.0) for r in (234.4, 236.1, 0.0119)]    # meets 4/rev at r
    rows, warnings = refine_crossings([(rpm, f) for f in levels], [11, 22, 44], 4, (0.0, 260.0), 2.0)
    (row,) = [r for r in rows if r["harmonic"] == 4]
    assert [row["rpm_n11"], row["rpm_n22"], row["rpm_n44"]] == pytest.approx([234.4, 236.1, 0.0119], rel=1e-9)
    assert np.isnan(row["rpm_extrapolated"]) and np.isnan(row["rpm_error"]) and np.isnan(row["rpm"])
    (said,) = [w for w in warnings if "physical range" in w]
    assert "mode 1 x 4/rev" in said and "n = 44 departs" in said and "below 0" in said


def test_an_error_bar_larger_than_the_value_is_no_result_and_the_coarse_level_is_named():
    """Levels 4, 2, 1 Hz halve at every refinement: observed order 1, far from 2, so Richardson
    extrapolates with the expected order to 0.667 Hz with an error estimate of at least the last
    change, 1 Hz: larger than the value, no result; the coarse level is farthest from the median.
    Converging levels 15.0, 15.8, 16.0 Hz (order 2) give 16.067 Hz as before."""
    from pydriver.analyses.campbell import refine_frequencies
    conv = refine_frequencies([np.array([[4.0]]), np.array([[2.0]]), np.array([[1.0]])], 2.0)
    assert np.isnan(conv["extrapolated"][0, 0]) and np.isnan(conv["error"][0, 0]) and conv["refused"][0, 0] == 0
    fine = refine_frequencies([np.array([[15.0]]), np.array([[15.8]]), np.array([[16.0]])], 2.0)
    assert fine["refused"][0, 0] == -1 and fine["extrapolated"][0, 0] == pytest.approx(16.0 + 0.2 / 3.0, rel=1e-12)


def test_the_forward_flight_cable_as_a_refined_campbell_diagram_writes_no_unphysical_number(tmp_path):
    """The issue's run (uh60_part2_forward_flight_cable.nml as analysis = 'campbell', n = 11, 22,
    44): every extrapolated frequency and crossing speed written (campbell.csv,
    campbell_crossings.csv, summary.json, refinement.csv) is at least 0 with an error estimate
    no larger than itself (at n = 44 two roots of a nearly critically damped pair, zeta = 1 -
    2e-11, had come first as a 1 mHz mode, so the modes were numbered differently there).  The failed run of the issue wrote -78.7 +- 236 rpm and -5.0 +- 15 Hz."""
    import json

    import csv

    from conftest import INPUTS

    def read_csv(path):                 # blank cells (no value) as NaN
        with open(path, newline="") as fh:
            rows = list(csv.reader(fh))
        names = [h.split(" [")[0] for h in rows[0]]
        return {n: np.array([float(r[i]) if r[i] else np.nan for r in rows[1:]]) for i, n in enumerate(names)}
    model = pydriver.Model.from_deck(INPUTS / "uh60_part2_forward_flight_cable.nml").with_changes(
        {"case.analysis": "campbell", "solver.floquet": False})
    res = pydriver.run_deck(model, out=tmp_path / "run")
    out = tmp_path / "run"
    s = json.loads((out / "summary.json").read_text())
    pairs = []
    table = read_csv(out / "campbell.csv")
    pairs += list(zip(table["f_extrapolated_hz"], table["f_error_hz"]))
    if (out / "campbell_crossings.csv").exists():
        cross = read_csv(out / "campbell_crossings.csv")
        pairs += list(zip(cross["rpm_extrapolated"], cross["rpm_error"]))
    pairs += [(c["rpm_extrapolated"], c["rpm_error"]) for c in s["crossings"] if c.get("rpm_extrapolated") is not None]
    pairs += [(q["extrapolated"], q["error_estimate"]) for q in s["refinement"]["quantities"].values()]
    written = [(v, e) for v, e in pairs if np.isfinite(v)]
    assert all(v >= 0.0 and e <= v for v, e in written), [p for p in written if not (p[0] >= 0 and p[1] <= p[0])]
    assert all(c["rpm"] >= 0.0 for c in s["crossings"]) and not any(c["rpm"] == pytest.approx(0.0119, rel=0.01)
                                                                      for c in s["crossings"])
    # The nearly critically damped pair is no longer counted as oscillating (linear_modes.
    # CRITICAL_SHARE): the modes are numbered alike at every level and no number leaves the
    # physical range; the rule that drops one that would is checked in test_richardson.py.
    said = [w for w in res.summary.get("warnings", []) if "physical range" in w]
    assert not said, said


def test_a_flight_decks_diagram_is_of_its_hover_state():
    """A Campbell run of a flight deck is of the state its resonance margins are judged about
    (issue 36): the blade at its mean angles, the same drag in still air.  Its frequencies at the
    operating speed are then the flight's own hover modes (modal_analysis of hover_model): the
    same linearisation solved twice, so to the eigen-solver's round-off (1e-9 relative leaves
    four decades)."""
    from pydriver.analyses import run
    from pydriver.analyses.hover_modes import hover_modes
    from conftest import INPUTS
    flight = pydriver.Model.from_deck(INPUTS / "uh60_part2_forward_flight_cable.nml").with_changes(
        {"refinement.levels": 1, "solver.floquet": False})
    hover = np.asarray(hover_modes(flight).summary["damped_frequencies_hz"][:3])
    diagram = run(flight.with_changes({"case.analysis": "campbell", "campbell.rpm_max": 260.0,
                                       "campbell.n_speeds": 2, "campbell.operating_rpm": [250.0, 260.0]}))
    assert np.asarray(diagram.extra["campbell"]["f"])[-1][:3] == pytest.approx(hover, rel=1e-9)
    assert any("hover state" in w for w in diagram.summary["warnings"])
