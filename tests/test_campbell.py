"""Campbell diagram (issue 13): modes against rotor speed with the full rotating-frame terms,
followed across speeds by the modal assurance criterion, and the crossings with the rotor
harmonics inside the operating range."""

from __future__ import annotations

import numpy as np
import pytest

import pydriver
from conftest import INPUTS
from pydriver.analyses.campbell import crossings
from pydriver.analyses.linear_modes import complex_modes
from pydriver.analyses.statics import equilibrium
from pydriver.deckfile import deck_from_text

EI, MU, L = 1.0, 0.5, 1.0


def radial_cantilever(rpm_max: float, n: int = 24, n_speeds: int = 5) -> pydriver.Model:
    """A uniform cantilever along the rotor's radius from its centre (clamp A at the axis),
    isotropic, no gravity: the standard rotating beam."""
    return pydriver.Model(deck_from_text(f"""&case analysis = 'campbell' /
&chain n_bodies = {n}, total_length = {L}, diameter = 1.0e-4, joint = 'xy', first_body = 'clamped' /
&cable ei = {EI}, mass_per_length = {MU} /
&clamp_a beta_deg = 90.0 /
&shape gamma_deg = 0.0, beta_deg = 0.0 /
&loads gravity = 0.0, 0.0, 0.0 /
&rotor rpm = {rpm_max}, centre = 0.0, 0.0, 0.0 /
&campbell rpm_max = {rpm_max}, n_speeds = {n_speeds}, n_modes = 4 /""", "radial.nml"))


def test_flap_and_lag_split_by_the_rotor_speed():
    """At rest the flap and lead-lag bending modes of an isotropic cable coincide.  Turning,
    the flap mode stiffens with the centrifugal tension and the lag mode less by exactly the
    in-plane centrifugal term -m Omega^2: w_flap^2 - w_lag^2 = Omega^2 for every speed (the
    shapes are the same; Coriolis couples lag only to the axial motion an inextensible chain
    does not have).  To 1e-6 relative (eigen-solver round-off ~1e-10).

    At rest the pair is degenerate and LAPACK returns an arbitrary, CPU-dependent basis of it;
    the diagram numbers the pair as the rotor splits it (ascending frequency at the next
    speed), so mode 1 is the lag mode and mode 2 the flap mode on every machine."""
    s = pydriver.run_deck(radial_cantilever(60.0)).summary
    rpm = np.array(s["rpm"])
    w = 2 * np.pi * np.array(s["frequencies_hz"])
    omega = rpm * 2 * np.pi / 60
    assert w[0, 0] == pytest.approx(w[0, 1], rel=1e-9)
    split = w[1:, 1]**2 - w[1:, 0]**2
    assert np.max(np.abs(split / omega[1:]**2 - 1)) < 1e-6
    assert s["min_mac"] > 0.99


def test_southwell_coefficient_of_the_first_flap_mode():
    """Centrifugal stiffening, w^2 = w0^2 + K Omega^2 with Southwell's K = 1.193 for the first
    mode of a uniform cantilever from the axis (small Omega; e.g. Bramwell, Helicopter
    Dynamics, 2001, ch. 10).  The 24-body chain at Omega = w0/10: within 1 % (discretisation
    ~0.2 %, the Omega^4 term ~0.1 %)."""
    w0 = 1.8751040687119611**2 * np.sqrt(EI / (MU * L**4))
    rpm = 0.1 * w0 * 60 / (2 * np.pi)
    s = pydriver.run_deck(radial_cantilever(rpm, n_speeds=2)).summary
    w = 2 * np.pi * np.array(s["frequencies_hz"])
    k = (w[1, 1]**2 - w[0, 1]**2) / (rpm * 2 * np.pi / 60)**2     # mode 2: flap (see above)
    assert k == pytest.approx(1.193, rel=0.01)


def test_crossings_are_found_where_frequency_meets_a_harmonic():
    """A mode at a constant 10 Hz meets k/rev at 600/k rpm; only those in the operating range
    are reported, at the linear interpolation of the grid (exact for straight lines)."""
    rpm = np.linspace(0, 700, 15)
    freqs = np.full((15, 1), 10.0)
    found = crossings(rpm, freqs, 8, (250.0, 650.0))
    assert [(c["harmonic"], round(c["rpm"], 9)) for c in found] == [(2, 300.0), (1, 600.0)]


def test_part2_has_no_mode_in_the_1rev_band_up_to_500_rpm():
    """Thesis section 5.5 on the reference test [9]: no resonance between 0 and 500 rpm in the
    0-8.33 Hz band (1/rev).  At 0 rpm the diagram's first frequency is the modal analysis's
    damped 26.318 Hz (same linearisation: 1e-8 relative)."""
    s = pydriver.run_deck(INPUTS / "uh60_part2_campbell.nml").summary
    assert not s["below_1rev_in_operating_range"] and s["lowest_frequency_hz"] > 8.33
    assert not [c for c in s["crossings"] if c["harmonic"] == 1]
    modal = pydriver.run_deck(INPUTS / "uh60_part2_modal.nml").summary
    assert s["frequencies_hz"][0][0] == pytest.approx(modal["damped_frequencies_hz"][0], rel=1e-8)
    assert s["min_mac"] > 0.9


def test_a_ten_times_softer_cable_meets_the_1rev_band():
    """The same cable ten times softer in bending (c_y / 10): its first mode starts at
    26.3/sqrt(10) = 8.3 Hz, at the 1/rev line of 500 rpm, and its modes cross the rotor
    harmonics inside the range where the modal analysis at that speed says they do.

    Each crossing is the linear interpolation of its tracked frequency between two grid speeds,
    so its frequency k rpm/60 is off the mode's by at most the interpolation error,
    h^2/8 max|f''| (h the speed step; f'' from the diagram's second differences at the two grid
    speeds, doubled for its change within the step).  The modal analysis at the crossing's speed
    (a model built at that speed, its own equilibrium from the deck's start, all its damped
    modes) must have a mode there within that error.  The deck's 20 rpm step cannot resolve
    the veering of modes 2 and 3 near 237 rpm (the tracked frequency turns within one step: the
    crossing of mode 3 with 6/rev beside it is 0.2 Hz off, twice the estimate), so the diagram is
    taken at 5 rpm (n_speeds = 101); every crossing then uses at most half its tolerance."""
    soft = pydriver.Model.from_deck(INPUTS / "uh60_part2_campbell_soft.nml").with_changes({"campbell.n_speeds": 101})
    s = pydriver.run_deck(soft).summary
    assert s["frequencies_hz"][0][0] == pytest.approx(26.318 / np.sqrt(10), rel=0.02)
    assert s["below_1rev_in_operating_range"]
    rpm, f = np.array(s["rpm"]), np.array(s["frequencies_hz"])
    h = rpm[1] - rpm[0]
    assert len(s["crossings"]) > 5
    for c in s["crossings"]:
        i = int(np.clip(np.searchsorted(rpm, c["rpm"]) - 1, 1, len(rpm) - 3))    # rpm[i] <= c <= rpm[i + 1]
        track = f[i - 1:i + 3, c["mode"] - 1]
        tolerance = 2.0 * np.max(np.abs(np.diff(track, 2))) / 8.0                   # 2 h^2/8 |f''|, f'' = diff2 / h^2
        at_speed = soft.with_changes({"case.analysis": "modal", "rotor.rpm": c["rpm"]})
        q, lam, _ = equilibrium(at_speed)
        sv, _, oscillating, _ = complex_modes(at_speed.core.modal_matrices(q, lam))
        modal = sv.imag[oscillating] / (2.0 * np.pi)
        assert np.min(np.abs(modal - c["frequency_hz"])) <= tolerance, (c, h, tolerance)


def test_an_overdamped_mode_has_no_crossings():
    """A mode that stops oscillating (frequency 0, zeta >= 1) between two speeds would cross
    1/rev by interpolation towards its 0; that is no resonance and is not reported.  The same
    mode meeting 1/rev while it oscillates is."""
    rpm = np.array([0.0, 100.0, 200.0, 300.0])
    going_overdamped = np.array([[5.0], [3.0], [0.0], [0.0]])      # 1/rev: 0, 1.67, 3.33, 5 Hz
    assert crossings(rpm, going_overdamped, 1, (0.0, 300.0)) == []
    oscillating = np.array([[5.0], [3.0], [2.0], [1.0]])
    found = crossings(rpm, oscillating, 1, (0.0, 300.0))
    assert [c["harmonic"] for c in found] == [1] and 100.0 < found[0]["rpm"] < 200.0


@pytest.mark.parametrize("angle", [0.0, 0.3, 1.2, 2.9])
def test_a_degenerate_pair_is_numbered_as_the_next_speed_splits_it(angle):
    """Whatever basis the eigen-solver returns for a degenerate pair (here: the pair turned by
    any angle inside its plane), the resolved shapes are the next speed's modes projected onto
    the pair's space, in the next speed's ascending order: exact up to round-off (1e-12)."""
    from pydriver.analyses.campbell import resolve_degenerate
    m = np.diag([2.0, 2.0, 1.0, 1.0])
    c, s_ = np.cos(angle), np.sin(angle)
    shapes = np.array([[c, -s_, 0, 0], [s_, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], complex)
    sv = np.array([1j, 1j, 2j, 3j])
    next_shapes = np.array([[0, 1, 0, 0], [1, 0, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], complex)
    next_sv = np.array([0.9j, 1.1j, 2j, 3j])
    out = resolve_degenerate(shapes, sv, 3, next_shapes, next_sv, m)
    assert np.allclose(out, next_shapes, atol=1e-12)
