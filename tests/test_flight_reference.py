"""The Fortran core on the flight and run-up decks against the independent maximal-coordinate
reference (tests/reference_maximal.py), the deck translated independently of pydriver.assembly
(tests/reference_from_deck.py).

What is compared, at random inconsistent states (g != 0, G v + g_t != 0) and at consistent
ones (closed by Levenberg-Marquardt on (P_tip - p_B, R_n - R_B), then projected onto g = 0,
G v + g_t = 0, all with the reference's own kinematics), at several times
(before, during and after a run-up, with Omega' != 0; with clamp B moving with the blade):
g, G, G v + g_t, the acceleration bias, M, k, the residual M vdot - k - G^T lambda, the
accelerations and multipliers of eq. 3.55, the support wrenches (F_A, M_A, F_B, M_B) and the
energy (Jacobi integral in the hub frame).  The reference routes are independent of the
core's: positions, velocities and accelerations from Taylor jets and the complex step of one
position-level kinematics routine; k and the residual by virtual power from body-level
Newton-Euler residuals; M by virtual power too (exact: the residual is linear in vdot);
vdot, lambda and the wrenches from one square maximal-coordinate Newton-Euler system with
joint reaction unknowns.

Tolerances.  Both sides are exact to round-off, so every difference is measured relative to
the scale of the quantity's own terms and must stay below 1e-10 (observed: 1e-15 for the
kinematic quantities, up to a few 1e-11 for the solved ones, see below):

* g, G: position rows against the cable length L, rotation rows against 1;
* G v + g_t: row by row against the sum of the magnitudes of its terms, |G| |v| + |g_t| (at a
  consistent state the value itself is zero and only its terms set the round-off);
* bias, M, k, vdot: against the largest entry of the reference's value;
* residual: against the largest of |M vdot|, |k|, |G^T lambda|;
* lambda and wrenches: forces against the largest support force F, moments against the
  largest of the support moments and F L (a moment's round-off comes from forces at lever
  arms up to L);
* energy: against |kinetic| + |potential|.

The solved quantities (vdot, lambda, wrenches) carry round-off amplified by the condition of
the acceleration-level system: cond(M) ~ 3e5 here (the bodies' tiny polar inertia under
the twist coordinates), so errors up to ~1e-11 are expected and 1e-10 is still met.  The
reference's own ``mass_matrix`` forms M as the inverse of M^-1 (unit-torque responses), which
carries cond(M) eps ~ 1e-10 by construction; it is compared once with that bound
(10 cond(M) eps), while the virtual-power M is compared at 1e-10 in every case.
"""

from __future__ import annotations

import re

import numpy as np
import pytest

import pydriver
from pydriver import core_probes as probes
import reference_maximal as ref
from conftest import INPUTS
from pydriver.deckfile import deck_from_text, read_deck
from reference_from_deck import reference_model

FF = INPUTS / "uh60_part2_forward_flight.nml"
P1 = INPUTS / "uh60_part1_runup.nml"
P2 = INPUTS / "uh60_part2_runup.nml"
TOL = 1e-10
EPS = np.finfo(float).eps

# The forward-flight deck cut to 6 bodies (speed: the reference is pure Python); the clamp
# stays where it is, so the chain is shorter but still reaches it.
SIX = {"chain.n_bodies": 6, "shape.gamma_deg": [90.0, 90.0, 0.0, 0.0, 0.0, 0.0],
       "shape.beta_deg": [70.0, 12.0, 12.0, 12.0, 12.0, 12.0]}
RUNUP = {"case.analysis": "dynamic", "rotor.profile": "runup", "rotor.rpm_start": 60.0,
         "rotor.runup_start": 0.05, "rotor.runup_time": 0.5}

# id: (deck, changes, keys dropped from the deck text, times [s])
CASES = {
    "ff_n11": (FF, {}, (), (0.0, 0.0917)),
    "ff_n6": (FF, SIX, (), (0.0, 0.137, 0.61)),
    "ff_zy": (FF, {"chain.joint": "zy", "springs.c_gamma": 3.0, "springs.d_gamma": 0.01,
                   "springs.rest_gamma_deg": 5.0, "springs.rest_beta_deg": -3.0},
              ("c_twist", "d_twist"), (0.05, 0.29)),
    "ff_xy": (FF, {**SIX, "chain.joint": "xy"}, ("c_twist", "d_twist"), (0.05, 0.29)),
    "ff_no_body_couples": (FF, {**SIX, "rotor.body_couples": False}, (), (0.05, 0.29)),
    "ff_inertial": (FF, {**SIX, "rotor.frame": "inertial"}, (), (0.05, 0.29)),
    "ff_clamp_a_on_blade": (FF, {**SIX, "clamp_a.moves_with": "blade"}, (), (0.05,)),
    "ff_lag_extra": (FF, {**SIX, "case.analysis": "dynamic", "blade.lag_extra_deg": 2.0,
                          "blade.lag_extra_hz": 1.3, "blade.lag_extra_phase_deg": 30.0}, (), (0.05, 0.29)),
    # Run-up with clamp B on the flapping, lagging, pitching blade: before, during, after.
    "ff_runup_moving_clamp": (FF, {**SIX, **RUNUP}, (), (0.02, 0.2, 0.42, 0.7)),
    "ff_runup_inertial": (FF, {**SIX, **RUNUP, "rotor.frame": "inertial"}, (), (0.2,)),
    "ff_runup_no_body_couples": (FF, {**SIX, **RUNUP, "rotor.body_couples": False}, (), (0.42,)),
    "p1_runup": (P1, {}, (), (0.2, 1.3, 2.5, 6.0)),
    "p2_runup": (P2, {}, (), (2.5, 9.5)),
    "p2_runup_no_body_couples": (P2, {"rotor.body_couples": False}, (), (3.7,)),
}

WORST: dict[str, float] = {}


def deck_variant(path, changes: dict, drop=()):
    """The deck with keys removed from its text and others changed (schema-validated)."""
    text = path.read_text()
    for key in drop:
        text = re.sub(rf"^\s*{key}\s*=.*$", "", text, flags=re.M | re.I)
    deck = deck_from_text(text, path.name) if drop else read_deck(path)
    return deck.with_values(changes) if changes else deck


@pytest.fixture(scope="module")
def built():
    cache = {}

    def get(case):
        if case not in cache:
            path, changes, drop, _ = CASES[case]
            deck = deck_variant(path, changes, drop)
            cache[case] = (pydriver.Model(deck), reference_model(deck))
        return cache[case]
    return get


@pytest.fixture(scope="module", autouse=True)
def report_worst():
    yield
    print("\nworst errors (relative to each quantity's scale):")
    for k, x in sorted(WORST.items()):
        print(f"  {k:10s} {x:.2e}")


def cable_length(model) -> float:
    return float(np.sum(model.L))


def project(model, q, v, t):
    """Consistent state: Gauss-Newton (minimum-norm steps, halved until |g| decreases) onto
    g = 0, then v onto G v + g_t = 0, both with the reference's g, G and G v + g_t."""
    g = ref.constraint(model, q, t)
    for _ in range(100):
        if np.max(np.abs(g)) < 1e-14:
            break
        step = np.linalg.lstsq(ref.constraint_jacobian(model, q, t), g, rcond=None)[0]
        for _ in range(30):
            g_new = ref.constraint(model, q - step, t)
            if np.linalg.norm(g_new) < np.linalg.norm(g):
                break
            step = 0.5 * step
        q, g = q - step, g_new
    G = ref.constraint_jacobian(model, q, t)
    v = v - np.linalg.lstsq(G, ref.constraint_velocity(model, q, v, t), rcond=None)[0]
    assert np.max(np.abs(ref.constraint(model, q, t))) < 1e-13
    # the true root E = I, not a half turn: tr E = 3
    E = ref.kinematics(model, q, t=t)["R"][-1] @ ref._clamp_target(model, q, t)[1].T
    assert np.trace(E) > 3.0 - 1e-9
    assert np.max(np.abs(ref.constraint_velocity(model, q, v, t))) < 1e-12 * (1 + np.max(np.abs(v)))
    return q, v


def _pose_residual(model, q, t):
    """(P_tip - p_B, R_n - R_B): zero only at the true root E = I of the clamp (no spurious
    half-turn roots, unlike g_rot = 1/2 vee(E - E^T))."""
    pose = ref._poses(model, q, t)
    p_B, R_B = ref._clamp_target(model, np.real(q), t)
    return np.concatenate([pose["P"][-1] - p_B, np.ravel(pose["R"][-1] - R_B)])


def closed_start(model, q, t):
    """A closed shape near q (Levenberg-Marquardt on ``_pose_residual``, Jacobian by the complex
    step), the starting guess of ``project``.  Gauss-Newton on g itself from the deck's shape
    can land on a spurious root of g_rot, the last body turned by a half turn against clamp B
    (E a half turn, T = (tr E I - E)/2 and G singular there)."""
    q = np.asarray(q, float).copy()
    mu = 1e-3
    r = _pose_residual(model, q, t)
    for _ in range(200):
        if np.max(np.abs(r)) < 1e-10:
            break
        J = np.column_stack([np.imag(_pose_residual(model, q + 1e-30j * ek, t)) / 1e-30
                             for ek in np.eye(q.size)])
        step = np.linalg.solve(J.T @ J + mu * np.eye(q.size), J.T @ np.real(r))
        r_new = _pose_residual(model, q - step, t)
        if np.linalg.norm(r_new) < np.linalg.norm(r):
            q, r, mu = q - step, r_new, max(mu / 3.0, 1e-12)
        else:
            mu *= 4.0
    return q


def _blocks(d, ell):
    """max error of a 6-vector of clamp rows: position rows / ell, rotation rows / 1."""
    d = np.abs(d)
    return max(np.max(d[:3]) / ell, np.max(d[3:]))


def errors(m, model, q, v, vdot, lam, t) -> dict:
    """Core against reference at one state, every difference relative to its scale."""
    ell = cable_length(model)
    e = probes.evaluate_model(m, q, v, vdot, lam, t)
    out = {}
    g, G = ref.constraint(model, q, t), ref.constraint_jacobian(model, q, t)
    out["g"] = _blocks(e["g"] - g, ell)
    out["G"] = max(np.max(np.abs(e["G"][:3] - G[:3])) / ell, np.max(np.abs(e["G"][3:] - G[3:])))
    gv = ref.constraint_velocity(model, q, v, t)
    term = np.abs(G) @ np.abs(v) + np.abs(gv - G @ v)
    out["G_v"] = max(np.max(np.abs(e["G_v"] - gv)[:3]) / np.max(term[:3]),
                     np.max(np.abs(e["G_v"] - gv)[3:]) / np.max(term[3:]))
    bias = ref.constraint_bias(model, q, v, t)
    out["bias"] = np.max(np.abs(e["Gdot_v"] - bias)) / np.max(np.abs(bias))
    k = -ref.residual(model, q, v, np.zeros_like(v), np.zeros(6), t)
    out["k"] = np.max(np.abs(e["k"] - k)) / np.max(np.abs(k))
    res = ref.residual(model, q, v, vdot, lam, t)
    scale = max(np.max(np.abs(e["M"] @ vdot)), np.max(np.abs(k)), np.max(np.abs(G.T @ lam)))
    out["residual"] = np.max(np.abs(e["residual"] - res)) / scale
    s = ref.solve_accelerations(model, q, v, t)
    assert not s["singular"]
    out["vdot"] = np.max(np.abs(e["vdot"] - s["vdot"])) / np.max(np.abs(s["vdot"]))
    forces = np.concatenate([s["F_A"], s["F_B"], s["lam"][:3]])
    moments = np.concatenate([s["M_A"], s["M_B"], s["lam"][3:]])
    f_scale = np.max(np.abs(forces))
    m_scale = max(np.max(np.abs(moments)), f_scale * ell)
    out["lambda"] = max(np.max(np.abs(e["lambda"][:3] - s["lam"][:3])) / f_scale,
                        np.max(np.abs(e["lambda"][3:] - s["lam"][3:])) / m_scale)
    w = e["wrenches"]
    out["F_A,F_B"] = max(np.max(np.abs(w.force_a - s["F_A"])), np.max(np.abs(w.force_b - s["F_B"]))) / f_scale
    out["M_A,M_B"] = max(np.max(np.abs(w.moment_a - s["M_A"])), np.max(np.abs(w.moment_b - s["M_B"]))) / m_scale
    parts = ref.energy_parts(model, q, v, t)
    out["energy"] = (abs(e["energy"] - parts["kinetic"] - parts["potential"])
                     / (abs(parts["kinetic"]) + abs(parts["potential"])))
    for key, x in out.items():
        WORST[key] = max(WORST.get(key, 0.0), x)
    return out


@pytest.mark.parametrize("case", list(CASES))
def test_core_against_reference(case, built):
    m, model = built(case)
    assert m.nq == model.nq and m.nc == 6
    rng = np.random.default_rng(sum(map(ord, case)))       # seeded per case, stable
    for t in CASES[case][3]:
        q = m.q0 + rng.normal(0.0, 0.2, m.nq)
        v = rng.normal(0.0, 2.0, m.nq)
        vdot = rng.normal(0.0, 20.0, m.nq)
        lam = np.concatenate([rng.normal(0.0, 200.0, 3), rng.normal(0.0, 10.0, 3)])
        qc, vc = project(model, closed_start(model, m.q0, t) + rng.normal(0.0, 0.05, m.nq), v, t)
        for label, (qq, vv) in (("inconsistent", (q, v)), ("consistent", (qc, vc))):
            err = errors(m, model, qq, vv, vdot, lam, t)
            bad = {k: x for k, x in err.items() if not x < TOL}
            assert not bad, f"{case}, t = {t}, {label} state: {bad}"


@pytest.mark.parametrize("case", ["ff_n11", "ff_runup_moving_clamp", "ff_zy", "p1_runup"])
def test_mass_matrix_by_virtual_power(case, built):
    """M column by column from the reference's virtual-power residual at v = 0, lambda = 0
    (linear in vdot, so exact to round-off; no inversion)."""
    m, model = built(case)
    rng = np.random.default_rng(5)
    t = CASES[case][3][-1]
    q = m.q0 + rng.normal(0.0, 0.2, m.nq)
    zero = np.zeros(m.nq)
    r0 = ref.residual(model, q, zero, zero, np.zeros(6), t)
    M = np.column_stack([ref.residual(model, q, zero, ek, np.zeros(6), t) - r0 for ek in np.eye(m.nq)])
    Mc = probes.evaluate_model(m, q, zero, zero, np.zeros(6), t)["M"]
    err = np.max(np.abs(Mc - M)) / np.max(np.abs(M))
    WORST["M"] = max(WORST.get("M", 0.0), err)
    assert err < TOL


def test_mass_matrix_by_maximal_unit_responses(built):
    """The reference's maximal-coordinate M (inverse of the unit-torque responses M^-1):
    its own round-off is cond(M) eps, so the bound is 10 cond(M) eps."""
    m, model = built("ff_n6")
    q = m.q0 + np.random.default_rng(6).normal(0.0, 0.2, m.nq)
    Mc = probes.evaluate_model(m, q, np.zeros(m.nq), np.zeros(m.nq), np.zeros(6), 0.137)["M"]
    M = ref.mass_matrix(model, q, 0.137)
    err = np.max(np.abs(Mc - M)) / np.max(np.abs(M))
    WORST["M_maximal"] = max(WORST.get("M_maximal", 0.0), err)
    assert err < 10.0 * np.linalg.cond(Mc) * EPS


def test_cases_exercise_what_they_claim(built):
    """The run-up times see Omega' != 0 (and Omega = 0 before, constant after), and the
    blade-side clamp really moves: g_t = G v + g_t - G v is not zero."""
    m, model = built("ff_runup_moving_clamp")
    om = [ref.rotor_state(model.rotor, t) for t in CASES["ff_runup_moving_clamp"][3]]
    assert om[0][2] == 0.0 and om[1][2] > 10.0 and om[2][2] > 10.0 and om[3][2] == 0.0
    q = m.q0
    e = probes.evaluate_model(m, q, np.zeros(m.nq), None, None, 0.2)
    assert np.max(np.abs(e["G_v"])) > 0.1          # v = 0: G v + g_t = g_t, the clamp's velocity
    m, model = built("p1_runup")
    assert ref.rotor_state(model.rotor, 0.2)[1] == 0.0
    assert ref.rotor_state(model.rotor, 2.5)[2] > 5.0


def test_rheonomic_rows_against_finite_differences(built):
    """A third, independent check of the moving clamp during a run-up: g_t and the bias by
    central differences of the core's own g along the path s -> (q + s v, t + s).  Truncation
    h^2 |g'''| ~ 1e-10, round-off eps |g| / h ~ 1e-11 (h = 1e-5) for g_t; the second
    difference has round-off eps |g| / h^2 ~ 1e-6 (h = 1e-4)."""
    m, model = built("ff_runup_moving_clamp")
    rng = np.random.default_rng(8)
    q, v, t = m.q0 + rng.normal(0.0, 0.2, m.nq), rng.normal(0.0, 2.0, m.nq), 0.2

    def g(s):
        return probes.evaluate_model(m, q + s * v, v, None, None, t + s)["g"]

    e = probes.evaluate_model(m, q, v, None, None, t)
    h = 1e-5
    assert np.max(np.abs(e["G_v"] - (g(h) - g(-h)) / (2 * h))) < 1e-8 * np.max(np.abs(e["G_v"]))
    h = 1e-4
    fd2 = (g(h) - 2.0 * g(0.0) + g(-h)) / h**2
    assert np.max(np.abs(e["Gdot_v"] - fd2)) < 1e-5 * np.max(np.abs(e["Gdot_v"]))


def test_hub_and_inertial_frames_agree_at_one_state(built):
    """The same physical state in both frames: joint coordinates and rates are relative to the
    parent, so (q, v, t) describe the same motion relative to the hub in either model; the
    accelerations agree and the clamp and support loads are the hub's turned by Rz(psi)."""
    mh, modelh = built("ff_runup_moving_clamp")
    mi, _ = built("ff_runup_inertial")
    rng = np.random.default_rng(9)
    t = 0.2
    q0 = closed_start(modelh, mh.q0, t) + rng.normal(0.0, 0.05, mh.nq)
    q, v = project(modelh, q0, rng.normal(0.0, 2.0, mh.nq), t)
    eh = probes.evaluate_model(mh, q, v, None, None, t)
    ei = probes.evaluate_model(mi, q, v, None, None, t)
    psi = ref.rotor_state(modelh.rotor, t)[0]
    Rz = ref.Rz(psi)
    assert np.max(np.abs(ei["g"][:3] - Rz @ eh["g"][:3])) < 1e-13
    assert np.max(np.abs(ei["vdot"] - eh["vdot"])) < TOL * np.max(np.abs(eh["vdot"]))
    # Rows F_A, M_A, F_B, M_B: each a vector the frame turns alike.
    wh, wi = (np.array([w.force_a, w.moment_a, w.force_b, w.moment_b]) for w in (eh["wrenches"], ei["wrenches"]))
    scale = np.max(np.abs(wh))
    assert np.max(np.abs(wi - wh @ Rz.T)) < TOL * scale
