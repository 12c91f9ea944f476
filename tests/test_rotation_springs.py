"""Springs on the joints' rotation vectors (&cable with joint = 'xyz', loads/rotation_springs.f90):
closed forms, the force as the potential's gradient, energy conservation, and the second-order
convergence in 1/n they exist for (the Cardan-angle springs converge at first order)."""

from __future__ import annotations

import re

import numpy as np
import pytest

import pydriver
from pydriver import core_probes as probes
from conftest import INPUTS
from pydriver.deckfile import deck_from_text

EI, GJ, MU, L = 0.8, 0.5, 0.4, 0.6
RNG = np.random.default_rng(2026)


def free_cable(n=4, extra="", gravity="0.0, 0.0, 0.0", damping=0.0) -> pydriver.Model:
    """A cable on clamp A along +x (joint 1 with 2 EI/l, half an element), free end."""
    return pydriver.Model(deck_from_text(f"""&case analysis = 'dynamic' /
&chain n_bodies = {n}, total_length = {L}, diameter = 0.01, joint = 'xyz', first_body = 'clamped' /
&cable ei = {EI}, gj = {GJ}, mass_per_length = {MU}, damping_time = {damping} {extra} /
&clamp_a beta_deg = 90.0 /
&shape gamma_deg = 0.0, beta_deg = 0.0 /
&loads gravity = {gravity} /""", "cable.nml"))


def test_one_joint_closed_forms():
    """Joint 2 alone bent about its x axis by a, or twisted by t: the generalized force is
    exactly -k a (k = EI/l) or -k_t t on that coordinate and 0 elsewhere; the potential
    k a^2 / 2 (one axis: rotation vector = Cardan angle).  Round-off: 1e-13."""
    m = free_cable()
    ell = L / 4
    for axis, k in ((0, EI / ell), (2, GJ / ell)):
        q = np.zeros(m.nq)
        q[3 + axis] = 0.3
        e = probes.evaluate_model(m, q)
        want = np.zeros(m.nq)
        want[3 + axis] = -k * 0.3
        assert np.max(np.abs(e["k"] - want)) < 1e-13 * k
        assert e["energy"] == pytest.approx(0.5 * k * 0.3**2, rel=1e-13)


def test_generalized_force_is_minus_the_potential_gradient():
    """At random bent and twisted shapes (angles up to 0.6 rad, so the J_r^-1 terms count),
    no gravity, at rest: k = -dV/dq.  Central differences, h = 1e-6: truncation h^2 V''' and
    round-off eps V / h, both below 1e-7 relative to |k|."""
    m = free_cable(n=5)
    for _ in range(4):
        q = RNG.uniform(-0.6, 0.6, m.nq)
        k = probes.evaluate_model(m, q)["k"]
        h = 1e-6
        grad = np.array([(probes.evaluate_model(m, q + h * e)["energy"]
                          - probes.evaluate_model(m, q - h * e)["energy"]) / (2 * h) for e in np.eye(m.nq)])
        assert np.max(np.abs(k + grad)) < 1e-7 * np.max(np.abs(k))


def test_dampers_dissipate_as_the_relative_angular_velocity_says():
    """D = damping_time K on the relative angular velocity w: the damper's power -w^T D w is
    never positive; at a straight shape (A = I) it is exactly -sum d v^2 per coordinate."""
    tau = 0.01
    m = free_cable(n=4, damping=tau)
    ell = L / 4
    d = tau * np.array([2 * EI / ell, 2 * EI / ell, 2 * GJ / ell] + [EI / ell, EI / ell, GJ / ell] * 3)
    for _ in range(4):
        q = RNG.uniform(-0.6, 0.6, m.nq)
        v = RNG.normal(0.0, 2.0, m.nq)
        # k holds the velocity terms of the inertia too: the same state without dampers
        # leaves the dampers' generalized force alone.
        damper = probes.evaluate_model(m, q, v)["k"] - probes.evaluate_model(free_cable(n=4), q, v)["k"]
        assert v @ damper <= 0.0
    v = RNG.normal(0.0, 2.0, m.nq)
    q0 = np.zeros(m.nq)
    damper = probes.evaluate_model(m, q0, v)["k"] - probes.evaluate_model(free_cable(n=4), q0, v)["k"]
    assert np.max(np.abs(damper + d * v)) < 1e-12 * np.max(np.abs(d * v))


def test_energy_is_conserved_without_dampers():
    """A bent, twisted cable released from rest swings in 3-D: the drift of kinetic + spring
    energy is the integrator's (BDF dissipates a little) and goes to zero with the tolerance.
    A force that were not the potential's gradient along the path would leave a drift that no
    tolerance removes (slope 0).  Over rtol 1e-9, 1e-10, 1e-11 (0.5 s) the fitted log-log slope
    of the drift must be at least 0.4 and the drift at 1e-11 below 1e-8 relative (measured:
    slopes 0.75 to 0.93, 1e-9 to 2.3e-9 at 1e-11).  At one tolerance the drift scatters by a
    factor of ~3 with the step sequence (the Newton matrix, the rounding order): a ratio of two
    tolerances is no robust check, the slope over three is."""
    drift = []
    rtols = (1e-9, 1e-10, 1e-11)
    for rtol in rtols:
        m = free_cable(n=4).with_changes({"shape.gamma_deg": "0.0, 40.0, -30.0, 60.0",
                                          "shape.beta_deg": "0.0, 25.0, 30.0, 20.0",
                                          "solver.t_end": 0.5, "solver.dt_out": 0.005,
                                          "solver.rtol": rtol, "solver.atol": rtol * 1e-2})
        res = pydriver.run_deck(m)
        e = res.extra["energy"]
        assert np.ptp(res.timeseries["E_kin_J"]) > 0.1 * abs(e[0])            # the cable moves
        drift.append(np.max(np.abs(e - e[0])) / np.max(np.abs(res.timeseries["E_pot_J"])))
    slope = np.polyfit(np.log(rtols), np.log(drift), 1)[0]
    assert drift[-1] < 1e-8 and slope >= 0.4, (drift, slope)


def test_forward_flight_cable_converges_at_second_order():
    """The hover equilibrium of the UH-60 cable (3-D bend and twist) at n = 11, 22, 44: the
    clamp moments converge at order 2 (within 0.3; measured 2.01-2.05), where the Cardan-angle
    springs (spring_measure = 'joint_angles') give about 1 (measured 0.7-1.2)."""
    text = (INPUTS / "uh60_part2_forward_flight_cable.nml").read_text()
    text = re.sub(r"&fatigue.*?\n/\n", "", text, flags=re.S)
    text = text.replace("analysis = 'flight'", "analysis = 'static'").replace("forward_speed = 80.0",
                                                                              "forward_speed = 0.0")
    orders = {}
    for measure in ("rotation_vector", "joint_angles"):
        t = text.replace("damping_time = 1.407e-3", f"damping_time = 1.407e-3, spring_measure = '{measure}'")
        q = pydriver.run_deck(pydriver.Model(deck_from_text(t, "hover.nml"))).summary["refinement"]["quantities"]
        orders[measure] = [q[f"M_{s} {c} [Nm]"]["observed_order"] for s in "AB" for c in "xyz"]
    assert all(abs(p - 2.0) < 0.3 for p in orders["rotation_vector"]), orders
    assert np.median(orders["joint_angles"]) < 1.5, orders
