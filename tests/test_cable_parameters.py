"""Per-body and per-joint properties and the physical cable parameters (issue 11).

* A spring on joint 1 only, and a half element at a clamp, are one-line decks.
* &cable (EI, mass per length) derives the joint constants for any n as a Hencky bar chain
  (pydriver/assembly.py): the answer converges to the Euler-Bernoulli cantilever at O(1/n^2)
  in both the tip deflection and the first frequency, where the thesis's direct constants
  (every joint c = EI/l, the first body on a pivot) converge at O(1/n) only
  (tests/test_uh60_dynamics.py::test_cantilever_converges_to_euler_bernoulli)."""

from __future__ import annotations

import numpy as np
import pytest

import pydriver
from pydriver.deckfile import deck_from_text

EI, L, MU = 0.163581, 0.59, 0.313 / 0.59       # UH-60 part 2 cable, thesis section 5.2 / Table A.2
THIN = 0.001          # diameter [m]: rotary inertia (d/L)^2 ~ 3e-6, below what these tests resolve
P = 1.0e-3            # tip force [N]: slope ~ 6e-4 rad, geometric nonlinearity ~ 4e-7 relative


def model(text: str, name="deck.nml") -> pydriver.Model:
    return pydriver.Model(deck_from_text(text, name))


def cantilever(n: int, analysis="static", springs: str | None = None, force=P) -> pydriver.Model:
    """Clamped at A along +x (the clamp frame's axis, &clamp_a beta_deg = 90; the cable leaves
    it straight), free tip; &cable parameters unless explicit springs are given."""
    constants = springs or f"&cable ei = {EI}, mass_per_length = {MU} /"
    mass = f"total_mass = {MU * L}" if springs else ""
    return model(f"""&case analysis = '{analysis}' /
&chain n_bodies = {n}, total_length = {L}, diameter = {THIN}, joint = 'xy', first_body = '{"pivot" if springs else "clamped"}' {mass} /
{constants}
&clamp_a beta_deg = 90.0 /
&shape gamma_deg = 0.0, beta_deg = 0.0 /
&loads gravity = 0.0, 0.0, 0.0, tip_force = 0.0, 0.0, {force} /""", f"cantilever{n}.nml")


F_EB = 1.8751040687119611**2 / (2 * np.pi) * np.sqrt(EI / (MU * L**4))   # first cantilever frequency
D_EB = P * L**3 / (3 * EI)                                                # tip deflection


def test_hencky_cantilever_converges_at_second_order():
    """Errors against Euler-Bernoulli for n = 8, 16, 32: each doubling divides them by 4
    (observed 4.00 for the deflection, 3.98 for the frequency; bound 4 +- 0.4, while first
    order would give 2).  The deflection error is the bar chain's closed form 1/(2 n^2)
    (joints at 0 (2c), l, ..., (n-1) l: tip = P l^3/EI (n^2/2 + (n-1) n (2n-1)/6) =
    P L^3/(3 EI) (1 + 1/(2n^2)); to 2e-6, the geometric nonlinearity of the 1 mN load)."""
    err_d, err_f = [], []
    for n in (8, 16, 32):
        tip = pydriver.run_deck(cantilever(n)).summary["tip_m"][2]
        f1 = pydriver.run_deck(cantilever(n, "modal", force=0.0)).summary["frequencies_hz"][0]
        err_d.append(tip / D_EB - 1)
        err_f.append(f1 / F_EB - 1)
        # Bar chain closed form; the geometric nonlinearity (slope^2 ~ 4e-7) is what remains.
        assert err_d[-1] == pytest.approx(1 / (2 * n**2), abs=2e-6)
    ratio_d = np.array(err_d[:-1]) / np.array(err_d[1:])
    ratio_f = np.array(err_f[:-1]) / np.array(err_f[1:])
    assert np.all(np.abs(ratio_d - 4) < 0.4) and np.all(np.abs(ratio_f - 4) < 0.4), (ratio_d, ratio_f)
    assert abs(err_f[-1]) < 1e-3


def test_physical_parameters_are_the_per_joint_springs():
    """&cable gives exactly the explicit per-joint deck of the same bar chain: joint 1 on the
    clamp 2 EI/l (a half element), the others EI/l, one line of &springs.  Same equations, so
    the same answer to round-off (1e-12 relative)."""
    n = 11
    c = EI / (L / n)
    explicit = cantilever(n, springs=f"&springs c_beta = {2 * c!r}, {n - 1}*{c!r} /")
    physical = cantilever(n)
    a = pydriver.run_deck(explicit).summary["tip_m"]
    b = pydriver.run_deck(physical).summary["tip_m"]
    assert np.allclose(a, b, rtol=1e-12, atol=1e-15)
    assert physical.description["stiffness"][0] == pytest.approx(2 * c, rel=1e-14)


def test_cable_summary_reports_the_interior_bending_spring():
    """summary.json's c_beta_Nm_per_rad of a &cable run is the bending spring the model was
    built with at an interior joint, EI/l (issue 23: it had been the unused &springs default,
    0.0).  Both sides divide the same EI by the same l: equal to round-off (1e-14 relative)."""
    n = 11
    physical = cantilever(n)
    reported = pydriver.run_deck(physical).summary["c_beta_Nm_per_rad"]
    # Joint 'xy' on a clamped first body: coordinates 0, 1 are joint 1 (2 EI/l on the clamp),
    # 2, 3 joint 2, an interior joint.
    built = physical.description["stiffness"][2]
    assert reported == pytest.approx(built, rel=1e-14)
    assert reported == pytest.approx(EI / (L / n), rel=1e-14)


def test_spring_on_joint_one_only():
    """The three-body chain with its spring on joint 1 only ("free" reading of thesis 4.1):
    bodies 2 and 3 hang straight down, and joint 1 balances the chain's weight against its
    spring: (5/2) m g L sin(beta) = c (beta - beta_0) (V = m g L cos(beta) (1/2 + 1 + 1) + const
    for body 1 at beta in the y-z plane).  Newton's tolerance gives the angle to ~1e-11 rad."""
    m = model("""&case analysis = 'static' /
&chain n_bodies = 3, total_length = 0.336, diameter = 0.0086, total_mass = 0.153, first_body = 'pivot' /
&shape gamma_deg = 90.0, 0.0, 0.0, beta_deg = 153.0, 0.0, 0.0 /
&springs c_gamma = 0.010, 2*0.0, c_beta = 0.010, 2*0.0, rest_gamma_deg = 90.0, 2*0.0, rest_beta_deg = 153.0, 2*0.0 /""",
              "joint1.nml")
    res = pydriver.run_deck(m)
    beta0, c, mgl = np.radians(153.0), 0.010, 0.051 * 9.81 * 0.112
    beta = np.radians(res.table["beta_deg"][0])
    assert 2.5 * mgl * np.sin(beta) == pytest.approx(c * (beta - beta0), abs=1e-9)
    tip = np.array(res.summary["tip_m"])
    joints_y = res.table["joint_y_m"]
    assert abs(tip[1] - joints_y[1]) < 1e-10            # bodies 2 and 3 hang vertically


def test_half_element_at_clamp_b():
    """With clamp B active, &cable makes the body B holds a half element (length l/2) and the
    joint before it stands for the whole of it plus half the previous body: c = EI/l there."""
    n = 10
    m = model(f"""&case analysis = 'static' /
&chain n_bodies = {n}, total_length = {L}, diameter = {THIN}, joint = 'xy' /
&cable ei = {EI}, mass_per_length = {MU} /
&shape gamma_deg = 0.0, beta_deg = 90.0, 20.0, 8*-5.0 /
&clamp_b active = .true., from_start = .true. /""", "cc.nml")
    lengths = m.description["bodies"].lengths
    ell = L / (n - 0.5)
    assert lengths[:-1] == pytest.approx(ell, rel=1e-14) and lengths[-1] == pytest.approx(ell / 2, rel=1e-14)
    c = m.description["stiffness"]
    assert c[-1] == pytest.approx(EI / ell, rel=1e-14) and c[0] == pytest.approx(2 * EI / ell, rel=1e-14)


def test_zero_stiffness_modes_are_reported_not_refused():
    """A twist without a twist spring (c_twist = 0) is a zero-stiffness mode: reported at
    0 Hz with a warning, not as an unstable equilibrium."""
    m = model("""&case analysis = 'modal' /
&chain n_bodies = 3, total_length = 0.336, diameter = 0.0086, total_mass = 0.153, first_body = 'pivot', joint = 'xyz' /
&shape gamma_deg = 90.0, 0.0, 0.0, beta_deg = 170.0, 0.0, 0.0 /
&springs c_beta = 0.010, c_twist = 0.0 /""", "free_twist.nml")
    s = pydriver.run_deck(m).summary
    assert s["n_zero_stiffness_modes"] >= 1
    assert s["frequencies_hz"][0] == 0.0 and s["frequencies_hz"][-1] > 0.1
    assert any("zero-stiffness" in w for w in s["warnings"])
