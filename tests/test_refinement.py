"""Converged numbers with error bars (issue 13): the same cable at n, 2n, 4n bodies and
Richardson extrapolation (&refinement, ``rotorcable run --refine``).

Closed forms: the hanging chain's frequencies (j0,k / 2) sqrt(g/L) / (2 pi) (Bernoulli/Euler;
e.g. Rayleigh, Theory of Sound I, s. 200; j0,k the zeros of the Bessel function J0) and the
Euler-Bernoulli cantilever (tip deflection P L^3 / (3 EI), first frequency
1.8751^2 / (2 pi) sqrt(EI / (mu L^4)))."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

import pydriver
from conftest import INPUTS, ROOT
from pydriver.analyses.refinement import extrapolate, refined_deck
from pydriver.deckfile import deck_from_text, read_deck
from pydriver.errors import DeckError

J0_ZEROS = (2.404825557695773, 5.520078110286311)        # first zeros of J0 (Abramowitz & Stegun 9.5)
G, L = 9.81, 1.0


def hanging_chain(n: int) -> pydriver.Model:
    """A thin chain (EI ~ 0) on a pivot at the top, hanging down, free end."""
    return pydriver.Model(deck_from_text(f"""&case analysis = 'modal' /
&chain n_bodies = {n}, total_length = {L}, diameter = 1.0e-4, joint = 'xy', first_body = 'pivot' /
&cable ei = 1.0e-12, mass_per_length = 1.0 /
&clamp_a beta_deg = 180.0 /
&shape gamma_deg = 0.0, beta_deg = 0.0 /
&loads gravity = 0.0, 0.0, {-G} /
&refinement levels = 3 /""", f"hanging{n}.nml"))


def test_hanging_chain_extrapolates_to_the_bessel_frequencies():
    """n = 16, 32, 64: the first two pendulum frequencies (each twice, one per plane) converge
    at second order (observed order within 0.2 of 2) and their Richardson values lie within
    1e-5 of the closed form.  What remains after extrapolation is the n^-4 term (measured
    4e-8 and 7e-6) and EI = 1e-12 N m^2 (~1e-12 relative)."""
    s = pydriver.run_deck(hanging_chain(16)).summary
    r = s["refinement"]
    assert r["n"] == [16, 32, 64]
    for k, j0 in enumerate(J0_ZEROS):
        exact = j0 / 2 * np.sqrt(G / L) / (2 * np.pi)
        q = r["quantities"][f"f{2 * k + 1} [Hz]"]                 # f1 = f2, f3 = f4: two planes
        assert abs(q["observed_order"] - 2.0) < 0.2
        assert q["extrapolated"] == pytest.approx(exact, rel=1e-5)
        assert abs(q["extrapolated"] - exact) <= 3 * q["error_estimate"] + 1e-12
        assert not q["warning"]


def cantilever(n: int, analysis: str) -> pydriver.Model:
    force = 1.0e-3 if analysis == "static" else 0.0
    return pydriver.Model(deck_from_text(f"""&case analysis = '{analysis}' /
&chain n_bodies = {n}, total_length = 0.59, diameter = 1.0e-4, joint = 'xy', first_body = 'clamped' /
&cable ei = 0.163581, mass_per_length = 0.5305 /
&clamp_a beta_deg = 90.0 /
&shape gamma_deg = 0.0, beta_deg = 0.0 /
&loads gravity = 0.0, 0.0, 0.0, tip_force = 0.0, 0.0, {force} /
&refinement levels = 3 /""", f"cantilever{n}.nml"))


def test_cantilever_extrapolates_to_euler_bernoulli():
    """n = 8, 16, 32: tip deflection and first frequency within 1e-4 of Euler-Bernoulli.  The
    deflection error is exactly 1/(2 n^2) (bar-chain closed form), which extrapolation removes,
    leaving the 1 mN load's geometric nonlinearity (~2e-6); the frequency's n^-4 rest is ~1e-6."""
    ei, mu, length, p = 0.163581, 0.5305, 0.59, 1.0e-3
    tip = pydriver.run_deck(cantilever(8, "static")).summary["refinement"]["quantities"]["tip z [m]"]
    assert tip["extrapolated"] == pytest.approx(p * length**3 / (3 * ei), rel=1e-4)
    f = pydriver.run_deck(cantilever(8, "modal")).summary["refinement"]["quantities"]["f1 [Hz]"]
    f_eb = 1.8751040687119611**2 / (2 * np.pi) * np.sqrt(ei / (mu * length**4))
    assert f["extrapolated"] == pytest.approx(f_eb, rel=1e-4)
    assert abs(f["observed_order"] - 2.0) < 0.2


def test_refined_start_is_the_same_polygon():
    """Body j becomes two bodies continuing it straight: every second joint point of the
    refined start is a joint point of the deck's start (round-off of the rotation products)."""
    deck = deck_from_text("""&case analysis = 'static' /
&chain n_bodies = 5, total_length = 0.5, diameter = 0.01, joint = 'xyz', first_body = 'clamped' /
&cable ei = 0.2, gj = 0.15, mass_per_length = 0.5 /
&shape gamma_deg = 10.0, 30.0, -20.0, 45.0, 5.0, beta_deg = 20.0, 15.0, 25.0, -10.0, 30.0 /""", "bent.nml")
    coarse, fine = pydriver.Model(deck), pydriver.Model(refined_deck(deck, 2))
    assert fine.n_bodies == 10
    p_coarse = coarse.core.shape(coarse.q0, 0.0)["joints"]
    p_fine = fine.core.shape(fine.q0, 0.0)["joints"]
    assert np.max(np.abs(p_fine[::2] - p_coarse)) < 1e-14


def test_far_order_is_a_warning():
    """Values converging at first order against an expected second order: extrapolated with
    the expected order, a warning that names the quantity, and an error bar that still covers
    the true error: the observed order's correction (here the last change 1/32, the larger of the
    two extrapolations' distances from the fine value) times Roache's three-grid factor 1.25."""
    summaries = [{"analysis": "modal", "frequencies_hz": [10.0 + 1.0 / n]} for n in (8, 16, 32)]
    refinement, warnings = extrapolate(summaries, [8, 16, 32], expected_order=2.0)
    q = refinement["quantities"]["f1 [Hz]"]
    assert q["observed_order"] == pytest.approx(1.0, rel=1e-9)
    assert q["warning"] and len(warnings) == 1 and "undamped frequency of mode 1 [Hz]" in warnings[0]
    assert q["error_estimate"] == pytest.approx(1.25 / 32, rel=1e-12)
    assert q["asymptotic"] is False
    assert abs(q["extrapolated"] - 10.0) <= q["error_estimate"]


def test_refinement_needs_a_cable():
    """The thesis decks give per-joint constants of an 11-body chain: refining them would
    change the cable, so it is refused, naming the group and key."""
    deck = read_deck(INPUTS / "uh60_part2_modal.nml")
    with pytest.raises(DeckError, match=r"&refinement key 'levels'.*&cable"):
        pydriver.Model(deck.with_values({"refinement.levels": 3}))
    out = subprocess.run([sys.executable, "-m", "pydriver", "run", str(INPUTS / "uh60_part2_modal.nml"), "--refine",
                          "--out", "unused"], capture_output=True, text=True, cwd=ROOT / "tests")
    assert out.returncode == 1 and "levels" in out.stderr and "Traceback" not in out.stderr
    assert not (ROOT / "tests" / "unused").exists()
