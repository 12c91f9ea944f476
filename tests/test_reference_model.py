"""Self-checks of tests/reference_maximal.py, the independent maximal-coordinate model.

The reference is what the Fortran is judged by, so it is checked here on its own terms:
its derivatives are automatic differentiation (exact to round-off), its maximal linear
system must satisfy its own virtual-power residual, its dynamics must conserve the Jacobi
integral, give the same motion in the hub and in the inertial frame, and keep an exact
solution of a moving clamp on the constraint.  Nothing here imports pydriver.

Tolerances: quantities that are exact in exact arithmetic are compared at round-off
(1e-11 to 1e-12 relative: a few hundred flops through linear solves whose condition numbers
are 1e3-1e5 here); finite differences at their truncation/round-off level; the RK4 energy
drift at its observed discretisation error.  Each test states its own reason.
"""

import dataclasses

import numpy as np
import pytest
import reference_maximal as ref

RNG = np.random.default_rng(20240611)


def rel_err(a, b):
    """Max abs difference relative to the max abs of b."""
    return np.max(np.abs(np.asarray(a) - np.asarray(b))) / max(np.max(np.abs(b)), 1e-300)


# ----------------------------------------------------------------------------------
# Models
# ----------------------------------------------------------------------------------
RUN_UP = ref.RotorSpeed(omega=2.0, omega_end=5.0, t_start=0.1, duration=1.0)


def chain(joint="xy", n=4, locked_first=True, seed=0, **kw):
    """A chain of n unequal cylinders with springs, dampers and unequal rest angles."""
    rng = np.random.default_rng(seed)
    k = ref.JOINT_COORDS[joint]
    locked = np.zeros(n, bool)
    locked[0] = locked_first
    return ref.ChainModel(L=rng.uniform(0.2, 0.4, n), R=rng.uniform(0.01, 0.04, n),
                          m=rng.uniform(0.5, 1.5, n), locked=locked,
                          locked_angles=np.tile([0.3, 1.2], (n, 1)), c=rng.uniform(1, 5, (n, k)),
                          d=rng.uniform(0.05, 0.2, (n, k)), rest=rng.uniform(-0.3, 0.3, (n, k)),
                          joint=joint, **kw)


def everything(joint, hub=True, clamp=True):
    """Every feature at once: run-up, moving base and clamp, drag, pulse, tip force."""
    return chain(joint, hub=hub, clamp_B=clamp, rotor=RUN_UP, rotor_centre=[0.3, -0.2, 0.1],
                 base_rotation=ref.Rx(0.2), r_A=[0.7, 0.1, 0.0],
                 drag=ref.Drag(1.2, [1.1, 1.0, 1.2, 0.9], [10.0, 3.0, 1.0]),
                 pulse=ref.Pulse(2, [0.0, 1.0, 3.0], 0.0, 1.0), tip_force=[0.1, 0.2, 0.3],
                 clamp_position=[0.5, 0.2, -0.3], clamp_rotation=ref.Rz(0.3) @ ref.Ry(0.4),
                 base_hinges=[ref.Hinge([0, 1, 0], [0.1, 0, 0], ref.AngleFunction(
                     "fourier", coefficients=(0.1, 0.05, 0.02, -0.03, 0.01), azimuth0=0.4,
                     amplitude=0.03, frequency=7.0, phase=0.2))],
                 clamp_hinges=[ref.Hinge([1, 0, 1], [0.5, 0, 0], ref.AngleFunction("rotor", offset=0.2)),
                               ref.Hinge([0, 0, 1], [0.2, 0.3, 0], ref.AngleFunction("constant", value=0.3))])


JOINTS = ["zy", "xy", "xyz"]


LEGACY_NUMBERS = {
    "open": {
        "qdd": [
            -77.99012053809552, 46.753413582001905, 55.878376005564995,
            -9.595839319999659, 201.18374875110396, -110.75092475478054],
        "F_A": [
            -0.03980807524137971, 0.0466620746578767, 1.3868906777026326],
        "M_A": [
            -0.01200688908823457, 0.08149882020896501, 0.01170796326794897],
        "k": [
            -0.04139723407894315, 0.08391877280189337, 0.08450958747270657,
            0.02091139263998751, 0.03714079756033643, -0.02515745032058687],
        "energy": [
            0.30485071347315496],
        "M": [
            0.0007498345957668738, -0.00036226830879482804, 0.00014590635927217734,
            -0.00036846923870914963, 5.844928078949216e-05, -9.545662111290685e-05,
            -0.0003622683087948279, 0.0011658547481873172, -0.00013265725763681078,
            0.0005666576103064816, 9.824459918382509e-05, 5.198380742856834e-05,
            0.00014590635927217642, -0.0001326572576368102, 0.0007576752848442423,
            -0.00011011913670625533, 0.00021545719131722027, -0.00013860097549010352,
            -0.0003684692387091502, 0.0005666576103064819, -0.0001101191367062559,
            0.0014445618373346402, 0.00013796511009997074, 0.00037977128994921144,
            5.844928078949174e-05, 9.824459918382567e-05, 0.00021545719131722067,
            0.00013796511009997098, 0.0001311760362316463, -1.831871063884713e-20,
            -9.545662111290682e-05, 5.198380742856818e-05, -0.0001386009754901037,
            0.00037977128994921155, 9.55403050820796e-20, 0.00021348374749999985],
    },
    "closed": {
        "qdd": [
            -21.932654335563562, -142.3902452566674, -283.0356340534329,
            3.5686935334208063, 293.6665330296493, -14.036932340048683,
            -298.8297316766854, -159.70824430962563],
        "F_A": [
            7.386702342558528, 61.70071207882625, 86.88780821756077],
        "M_A": [
            -0.14000000000000118, -18.1579516588014, 19.239039325926317],
        "F_B": [
            -14.168131276701331, -74.21259274921725, 55.52264954328408],
        "M_B": [
            -6.464905144556436, -12.12862241415766, -16.412646568908475],
        "k": [
            -14.45292948216169, 2.372586401261316, -15.04019603571277, -17.52385260691604,
            -8.880578147646881, -7.470268957343226, -4.634677804697626, 1.0855113751033416],
        "energy": [
            16.170268116977695],
        "M": [
            0.36925989889175315, -0.031400950330982905, 0.19774125025518746,
            0.1641415935741485, 0.19172488261051904, -0.029362431808366007,
            -0.0036634146437638233, 0.05900992260192213, -0.03140095033101175,
            0.24526590537400858, -0.07951135241163239, 0.03418785273796735,
            0.06564139282132574, -0.004630032836891175, -0.0010098673674475607,
            0.04127044068530745, 0.19774125025521708, -0.07951135241160946,
            0.2985451333893308, -0.07407600247990101, 0.21457274211155755,
            -0.07438580443323531, -0.022784289551434155, 0.03865970658449503,
            0.16414159357412167, 0.03418785273798364, -0.07407600247993945,
            0.5396023794876535, 0.05057767091904293, 0.2617828739409557,
            0.06217006648391592, 0.04285968685323032, 0.19172488261053902,
            0.06564139282135348, 0.21457274211154553, 0.05057767091907983,
            0.2907609873661743, -0.0018951505602500956, 0.0014864950990322616,
            0.0841581431492146, -0.029362431808362975, -0.004630032836885992,
            -0.07438580443323901, 0.2617828739409654, -0.00189515056025049,
            0.2703948010978491, 0.0639055591644838, -0.002526007175126447,
            -0.0036634146437622803, -0.0010098673674457366, -0.022784289551434727,
            0.06217006648391967, 0.0014864950990330715, 0.06390555916448445,
            0.021544611150003688, 1.5432692012866857e-15, 0.05900992260192136,
            0.04127044068531493, 0.03865970658448722, 0.04285968685323565,
            0.08415814314920869, -0.0025260071751281575, 7.56052560976499e-16,
            0.04132460384947827],
    },
}


def legacy_open():
    """The old callers' open chain: pivot, springs, dampers, legacy rotor field with offset."""
    n = 3
    return ref.ChainModel(L=np.full(n, 0.112), R=np.full(n, 0.0043), m=np.full(n, 0.051),
                          locked=np.zeros(n, bool), locked_angles=np.zeros((n, 2)),
                          c=np.tile([0.01, 0.02], (n, 1)), d=np.tile([0.001, 0.002], (n, 1)),
                          rest=np.radians([[90.0, 153.0], [0, 0], [0, 0]]),
                          omega_rotor=2 * np.pi, rotor_offset=np.array([0.1, 0.2]))


def legacy_closed():
    """The old callers' six-link closed chain (first body clamped, clamp B, no target)."""
    n = 5
    angles = np.radians([[0, 90], [0, 45], [90, 90], [0, 90], [90, -45]])
    locked = np.zeros(n, bool)
    locked[0] = True
    return ref.ChainModel(L=np.full(n, 0.2), R=np.full(n, 0.025),
                          m=np.full(n, 7801 * np.pi * 0.025**2 * 0.2), locked=locked,
                          locked_angles=angles, c=np.tile([3.0, 5.0], (n, 1)),
                          d=np.tile([0.1, 0.25], (n, 1)), rest=np.zeros((n, 2)), clamp_B=True)


LEGACY_STATES = {
    "open": (np.array([0.3, -1.2, 0.7, 2.1, -0.4, 0.9]), np.array([1.0, -2.0, 0.5, 3.0, -1.5, 0.25])),
    "closed": (np.radians([0, 45, 90, 90, 0, 90, 90, -45])
               + np.array([0.03, -0.02, 0.05, 0.01, -0.04, 0.02, 0.03, -0.01]),
               np.array([0.5, -1.0, 0.8, 0.2, -0.3, 1.1, -0.7, 0.4])),
}


# ----------------------------------------------------------------------------------
# 1. Existing behaviour unchanged
# ----------------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["open", "closed"])
def test_legacy_numbers_unchanged(name):
    # LEGACY_NUMBERS were printed by the file as it was at commit 28d9a34 (before the
    # extension).  The new system has other unknowns (full joint wrenches, qdd) and other
    # rows, so the numbers agree to round-off, not bit for bit: measured <= 3e-15 for the
    # dynamics; the old mass matrix (and k = M qdd) carries round-off of its inversion
    # (asymmetry 3e-14 relative in the stored numbers), measured 1e-13 and 2e-13.  Hence
    # 1e-12.
    model = legacy_open() if name == "open" else legacy_closed()
    want = LEGACY_NUMBERS[name]
    q, v = LEGACY_STATES[name]
    r = ref.forward_dynamics(model, q, v)
    assert not r["singular"]
    keys = ("qdd", "F_A", "M_A") + (("F_B", "M_B") if model.clamp_B else ())
    for key in keys:
        assert rel_err(r[key], want[key]) < 1e-12, key
    if not model.clamp_B:
        assert r["F_B"] is None and r["M_B"] is None
    assert rel_err(ref.mass_matrix(model, q), np.reshape(want["M"], (model.nq, model.nq))) < 1e-12
    assert rel_err(ref.generalized_forces(model, q, v), want["k"]) < 1e-12
    assert ref.energy(model, q, v) == pytest.approx(want["energy"][0], rel=1e-13)


@pytest.mark.parametrize("name", ["open", "closed"])
def test_new_system_agrees_with_kept_legacy_system(name):
    # The old formulation (hand-written axes and bias, reaction moments only along
    # n = a_gamma x a_beta, qdd by least squares) is kept; at random states of the legacy
    # models both systems give the same dynamics.  Both exact: 1e-11 (measured <= 6e-15).
    model = legacy_open() if name == "open" else legacy_closed()
    for _ in range(4):
        q = LEGACY_STATES[name][0] + RNG.normal(0, 0.3, model.nq)
        v = RNG.normal(0, 2, model.nq)
        new, old = ref.forward_dynamics(model, q, v), ref._legacy_forward_dynamics(model, q, v)
        if old["singular"] or new["singular"]:
            continue
        for key in ("qdd", "F_A", "M_A") + (("F_B", "M_B") if model.clamp_B else ()):
            assert rel_err(new[key], old[key]) < 1e-11, key


# ----------------------------------------------------------------------------------
# 2. Automatic differentiation
# ----------------------------------------------------------------------------------
def test_rotor_rates_by_ad_match_closed_form():
    # Omega and Omega' come from the Taylor jet of psi(t); closed forms
    # psi = Omega_0 t + dOmega T (tau^2/2 + (cos 2 pi tau - 1)/(2 pi)^2) + dOmega max(t - t0 - T, 0),
    # Omega = Omega_0 + dOmega s(tau), Omega' = dOmega (1 - cos 2 pi tau)/T.  Exact: 1e-13.
    r = RUN_UP
    d, T = r.omega_end - r.omega, r.duration
    for t in (0.0, 0.05, 0.1, 0.35, 0.6, 1.1, 1.5):
        tau = np.clip((t - r.t_start) / T, 0, 1)
        psi, om, omd = ref.rotor_state(r, t)
        want = (r.omega * t + d * T * (tau**2 / 2 + (np.cos(2 * np.pi * tau) - 1) / (2 * np.pi) ** 2)
                + d * max(t - r.t_start - T, 0.0))
        assert psi == pytest.approx(want, rel=1e-13, abs=1e-15)
        assert om == pytest.approx(r.omega + d * (tau - np.sin(2 * np.pi * tau) / (2 * np.pi)), rel=1e-13)
        assert omd == pytest.approx(d * (1 - np.cos(2 * np.pi * tau)) / T, rel=1e-13, abs=1e-13)


@pytest.mark.parametrize("joint", JOINTS)
def test_jet_and_complex_step_agree(joint):
    # Two independent AD methods on the same kinematics: a first-order Taylor jet in
    # direction e_k against the complex step (G), and the jet's d/ds along (q + s v, t + s)
    # against G v + g_t with g_t by the complex step in t.  Both exact: 1e-13 relative
    # (measured <= 6e-16).
    model = everything(joint)
    q, v, t = RNG.uniform(-1, 1, model.nq), RNG.normal(0, 1, model.nq), 0.4
    G = ref.constraint_jacobian(model, q, t)
    for k in range(model.nq):
        qj = ref.Jet(np.stack([q, np.eye(model.nq)[k]]))
        tj = ref.Jet(np.array([t, 0.0]))
        col = ref._clamp_g(ref._poses(model, qj, tj), ref._clamp_target(model, qj, tj)).derivative(1)
        assert np.max(np.abs(col - G[:, k])) < 1e-13 * max(1.0, np.max(np.abs(G)))
    tc = t + 1j * ref._CS_STEP
    g_t = np.imag(ref._clamp_g(ref._poses(model, q, tc), ref._clamp_target(model, q, tc))) / ref._CS_STEP
    gv = ref.constraint_velocity(model, q, v, t)
    assert rel_err(gv, G @ v + g_t) < 1e-13


@pytest.mark.parametrize("joint", JOINTS)
def test_ad_against_finite_differences(joint):
    # Shows the AD is right (finite differences are the check, never the method).
    # Central differences with h = 1e-6: truncation h^2 |g'''|/6 ~ 1e-13, round-off
    # eps |g|/h ~ 1e-10 -> 1e-8 (measured <= 4e-10).  Second difference with h = 1e-4:
    # truncation h^2 |g''''|/12 ~ 1e-9, round-off 4 eps |g|/h^2 ~ 1e-8 -> 1e-6 relative to
    # max(1, |bias|) (measured <= 5e-8).
    model = everything(joint)
    for t in (0.05, 0.4, 1.3):
        q, v = RNG.uniform(-1, 1, model.nq), RNG.normal(0, 1, model.nq)

        def g(qq, tt):
            return ref.constraint(model, qq, tt)

        h = 1e-6
        fd = np.column_stack([(g(q + h * e, t) - g(q - h * e, t)) / (2 * h) for e in np.eye(model.nq)])
        assert np.max(np.abs(ref.constraint_jacobian(model, q, t) - fd)) < 1e-8
        fd_v = (g(q + h * v, t + h) - g(q - h * v, t - h)) / (2 * h)
        assert np.max(np.abs(ref.constraint_velocity(model, q, v, t) - fd_v)) < 1e-8
        h = 1e-4
        fd_b = (g(q + h * v, t + h) - 2 * g(q, t) + g(q - h * v, t - h)) / h**2
        bias = ref.constraint_bias(model, q, v, t)
        assert np.max(np.abs(bias - fd_b)) < 1e-6 * max(1.0, np.max(np.abs(bias)))


def test_prescribed_motion_composition():
    # T(t) = T_1(theta_1) T_2(theta_2): hinge 1 carries hinge 2.  Rebuilt here with rotations
    # made by a change of basis (Q Rz(theta) Q^T, Q = a frame with u as third axis), not by
    # Rodrigues.  Positions are exact: 1e-14 (measured 4e-16); the jet's velocity of P_1
    # against central
    # differences (h = 1e-6: truncation h^2 |p'''|/6 ~ 1e-12 * 300/6, round-off eps |p|/h
    # ~ 2e-10): 1e-8 (measured 1e-10).
    h1 = ref.Hinge([0, 0, 1], [0.3, -0.2, 0], ref.AngleFunction("rotor", offset=0.1))
    h2 = ref.Hinge([1, 1, 0], [0.5, 0.1, 0.2], ref.AngleFunction("fourier", coefficients=(0.2, 0.1, -0.05),
                                                                  amplitude=0.02, frequency=5.0))
    model = chain("xy", n=2, locked_first=False, base_hinges=[h1, h2], rotor=RUN_UP,
                  r_A=[1.0, 0.5, -0.2], base_rotation=ref.Ry(0.3))

    def rot(u, th):
        u = np.asarray(u, float) / np.linalg.norm(u)
        a = np.cross(u, [0.3, 0.5, 0.7])
        a /= np.linalg.norm(a)
        Q = np.column_stack([a, np.cross(u, a), u])
        return Q @ ref.Rz(th) @ Q.T

    def base_pose(t):
        psi = RUN_UP.angle(t)
        R1, R2 = rot(h1.axis, h1.angle(t, psi)), rot(h2.axis, h2.angle(t, psi))
        p = R1 @ (R2 @ (model.r_A - h2.point) + h2.point - h1.point) + h1.point
        return p, R1 @ R2 @ model.base_rotation

    q = RNG.uniform(-1, 1, model.nq)
    for t in (0.0, 0.3, 0.8):
        psi = RUN_UP.angle(t)
        assert h2.angle(t, psi) == pytest.approx(0.2 + 0.1 * np.cos(psi) - 0.05 * np.sin(psi)
                                                 + 0.02 * np.sin(5.0 * t), rel=1e-15)
        assert h1.angle(t, psi) == psi + 0.1
        kin = ref.kinematics(model, q, np.zeros(model.nq), t)
        p, R0 = base_pose(t)
        assert np.max(np.abs(kin["P"][0] - p)) < 1e-14
        assert np.max(np.abs(kin["R0"] - R0)) < 1e-14
        h = 1e-6
        fd = (base_pose(t + h)[0] - base_pose(t - h)[0]) / (2 * h)
        assert np.max(np.abs(kin["vP"][0] - fd)) < 1e-8


# ----------------------------------------------------------------------------------
# 3. The maximal system against the virtual-power residual
# ----------------------------------------------------------------------------------
@pytest.mark.parametrize("joint", JOINTS)
@pytest.mark.parametrize("hub", [True, False])
def test_solution_satisfies_residual_and_clamp(joint, hub):
    # solve_accelerations (one maximal linear system) and residual (body wrenches mapped by
    # partial velocities) share only kinematics and loads.  At the solution: residual = 0
    # and G vdot + bias = 0; M from residual columns equals the unit-torque mass matrix; k
    # equals -residual(vdot = 0, lambda = 0).  All exact: 1e-11 relative to the size of the
    # terms (measured <= 3e-13).
    model = everything(joint, hub=hub)
    nq = model.nq
    for t in (0.3, 1.5):
        q, v = RNG.uniform(-1, 1, nq), RNG.normal(0, 1, nq)
        r = ref.solve_accelerations(model, q, v, t)
        assert not r["singular"]
        M = ref.mass_matrix(model, q, t)
        k = ref.generalized_forces(model, q, v, t)
        G = ref.constraint_jacobian(model, q, t)
        scale = max(np.max(np.abs(M @ r["vdot"])), np.max(np.abs(k)))
        assert np.max(np.abs(ref.residual(model, q, v, r["vdot"], r["lam"], t))) < 1e-11 * scale
        assert np.max(np.abs(M @ r["vdot"] - k - G.T @ r["lam"])) < 1e-11 * scale
        bias = ref.constraint_bias(model, q, v, t)
        assert np.max(np.abs(G @ r["vdot"] + bias)) < 1e-11 * max(np.max(np.abs(bias)), 1.0)
        zero, lam0 = np.zeros(nq), np.zeros(6)
        r0 = ref.residual(model, q, zero, zero, lam0, t)
        M_res = np.column_stack([ref.residual(model, q, zero, e, lam0, t) - r0 for e in np.eye(nq)])
        assert rel_err(M_res, M) < 1e-11
        assert rel_err(M, M.T) < 1e-11
        assert rel_err(-ref.residual(model, q, v, zero, lam0, t), k) < 1e-11
        # The reported clamp moment is T^T lambda_rot, F_B = lambda_pos.
        assert np.allclose(r["F_B"], r["lam"][:3], rtol=0, atol=0)


# ----------------------------------------------------------------------------------
# 4. Jacobi integral
# ----------------------------------------------------------------------------------
def rk4(model, q, v, h, steps):
    """Fixed-step classical Runge-Kutta on (q, v)' = (v, vdot)."""
    def f(q, v, t):
        return v, ref.solve_accelerations(model, q, v, t)["vdot"]
    t = 0.0
    for _ in range(steps):
        k1 = f(q, v, t)
        k2 = f(q + h / 2 * k1[0], v + h / 2 * k1[1], t + h / 2)
        k3 = f(q + h / 2 * k2[0], v + h / 2 * k2[1], t + h / 2)
        k4 = f(q + h * k3[0], v + h * k3[1], t + h)
        q = q + h / 6 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0])
        v = v + h / 6 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1])
        t += h
    return q, v


@pytest.mark.parametrize("joint,couples", [("xy", True), ("xyz", True), ("xy", False)])
def test_jacobi_integral_conserved(joint, couples):
    # A hanging three-body pivot chain in the hub frame at constant Omega (offset rotor
    # centre, gravity, springs with rest angles, a tip force, no dampers): kinetic (relative)
    # + potential (with the centrifugal potential) is the Jacobi integral.  RK4 with h and
    # h/2 over 0.4 s: the drift must fall at least like h^4 (observed order >= 3.8; a
    # linear oscillator's RK4 energy error falls like h^5; measured 4.4-4.6 here) and be
    # below 1e-9 of |kinetic| + |potential| at h = 0.002 s (measured 1.7e-10 to 3.2e-10;
    # the Jacobi integral is a sum of terms of both signs, so it is judged against their
    # size).
    n, k = 3, ref.JOINT_COORDS[joint]
    model = ref.ChainModel(L=[0.3, 0.25, 0.2], R=[0.06, 0.08, 0.05], m=[0.8, 0.6, 0.5],
                           locked=np.zeros(n, bool), locked_angles=np.zeros((n, 2)),
                           c=np.full((n, k), 0.4), d=np.zeros((n, k)), rest=np.full((n, k), 0.05),
                           joint=joint, hub=True, rotor=ref.RotorSpeed(omega=1.5),
                           rotor_centre=[-0.4, 0.1, 0.0], body_couples=couples,
                           tip_force=[0.3, -0.2, 0.5])
    q0 = np.concatenate([[2.6, 0.3, 0.2][:k]] + [np.full(k, 0.3)] * (n - 1))
    v0 = 0.5 * np.linspace(-1, 1, model.nq)

    def jacobi(q, v):
        e = ref.energy_parts(model, q, v)
        return e["kinetic"] + e["potential"], abs(e["kinetic"]) + abs(e["potential"])

    H0, scale = jacobi(q0, v0)
    drift = []
    for h in (0.004, 0.002):
        q, v = rk4(model, q0, v0, h, round(0.4 / h))
        drift.append(abs(jacobi(q, v)[0] - H0) / scale)
    order = np.log2(drift[0] / drift[1])
    assert order > 3.8, (drift, order)
    assert drift[1] < 1e-9, drift


# ----------------------------------------------------------------------------------
# 5. Frame independence
# ----------------------------------------------------------------------------------
@pytest.mark.parametrize("joint", JOINTS)
@pytest.mark.parametrize("clamp", [False, True])
def test_hub_frame_equals_inertial_frame(joint, clamp):
    # The same chain (springs, dampers, drag, a pulse and a tip force along z, gravity
    # along z, during the run-up so Omega' != 0) written in the hub frame with fixed
    # supports and in the inertial frame with both supports carried by a 'rotor' hinge
    # about the axis through c.  The joint coordinates are the same; the reactions differ
    # by Rz(psi).  The clamp case uses a consistent state (g = 0, G v = 0): the
    # acceleration-level constraint is frame-independent only there.  Exact: 1e-11
    # (measured <= 5e-14).
    c = np.array([0.3, -0.2, 0.1])
    # Five bodies, the first clamped: 8 or 12 coordinates, so the closed chain can move.
    model = chain(joint, n=5, seed=3, hub=True, rotor=RUN_UP, rotor_centre=c, r_A=[0.7, 0.1, 0.0],
                  base_rotation=ref.Rx(0.2), drag=ref.Drag(1.2, 1.1, [10.0, 3.0, 1.0]),
                  pulse=ref.Pulse(2, [0.0, 0.0, 3.0], 0.0, 1.0), tip_force=[0.0, 0.0, 0.3])
    q, v, t = RNG.uniform(-1, 1, model.nq), RNG.normal(0, 1, model.nq), 0.6
    if clamp:
        kin = ref.kinematics(model, q)
        model = dataclasses.replace(model, clamp_B=True, tip_force=np.zeros(3),
                                    clamp_position=kin["P"][-1], clamp_rotation=kin["R"][-1])
        G = ref.constraint_jacobian(model, q, t)
        v = v - np.linalg.pinv(G) @ (G @ v)
        assert np.max(np.abs(ref.constraint_velocity(model, q, v, t))) < 1e-13
    hinge = [ref.Hinge([0, 0, 1], c, ref.AngleFunction("rotor"))]
    inertial = dataclasses.replace(model, hub=False, base_hinges=hinge,
                                   clamp_hinges=hinge if clamp else [])
    rh, ri = ref.solve_accelerations(model, q, v, t), ref.solve_accelerations(inertial, q, v, t)
    Rpsi = ref.Rz(RUN_UP.angle(t))
    assert rel_err(ri["vdot"], rh["vdot"]) < 1e-11
    scale = max(np.max(np.abs(rh[k])) for k in ("F_A", "M_A", "F_B", "M_B"))
    for key in ("F_A", "M_A", "F_B", "M_B"):
        assert np.max(np.abs(ri[key] - Rpsi @ rh[key])) < 1e-11 * scale, key


# ----------------------------------------------------------------------------------
# 6. body_couples
# ----------------------------------------------------------------------------------
@pytest.mark.parametrize("joint", JOINTS)
def test_body_couples_change_only_the_rotational_frame_terms(joint):
    # residual(body_couples=True) - residual(body_couples=False) must be the generalized
    # force of the couple Theta W' + Theta (W x w) + w x Theta W + W x Theta w + W x Theta W
    # (W = Omega e_z, w relative, Theta the world inertia, here from the cylinder formula),
    # mapped with the partial angular velocities dw/dqd_k = kinematics(q, e_k)['w'].  The
    # mass matrix is the same.  Exact: 1e-12 relative (measured <= 5e-14).
    model = everything(joint, clamp=True)
    model = dataclasses.replace(model, base_hinges=[], clamp_hinges=[])   # fixed supports
    nq = model.nq
    q, v, vdot, lam = (RNG.uniform(-1, 1, nq), RNG.normal(0, 1, nq), RNG.normal(0, 5, nq),
                       RNG.normal(0, 3, 6))
    t = 0.5
    plain = dataclasses.replace(model, body_couples=False)
    diff = ref.residual(model, q, v, vdot, lam, t) - ref.residual(plain, q, v, vdot, lam, t)
    _, om, omd = ref.rotor_state(RUN_UP, t)
    W, Wd = om * np.array([0, 0, 1.0]), omd * np.array([0, 0, 1.0])
    kin = ref.kinematics(model, q, v, t)
    Jw = np.stack([ref.kinematics(model, q, e, t)["w"] for e in np.eye(nq)], axis=-1)
    want = np.zeros(nq)
    for j in range(model.n):
        m, L, R = model.m[j], model.L[j], model.R[j]
        Tb = np.diag([m * (L**2 + 3 * R**2) / 12, m * (L**2 + 3 * R**2) / 12, m * R**2 / 2])
        Th = kin["R"][j] @ Tb @ kin["R"][j].T
        w = kin["w"][j]
        couple = (Th @ Wd + Th @ np.cross(W, w) + np.cross(w, Th @ W) + np.cross(W, Th @ w)
                  + np.cross(W, Th @ W))
        want += Jw[j].T @ couple
    assert rel_err(diff, want) < 1e-12
    assert rel_err(ref.mass_matrix(plain, q, t), ref.mass_matrix(model, q, t)) < 1e-12


# ----------------------------------------------------------------------------------
# 7. Moving clamp along exact solutions
# ----------------------------------------------------------------------------------
@pytest.mark.parametrize("hub", [False, True])
def test_clamp_and_base_on_one_rigid_motion(hub):
    # Base and clamp carried by the same rigid motion (a flapping hinge in the blade azimuth
    # on a rotating hinge), the clamp's hinges described through other points of the same
    # axes.  The chain keeps its start shape: q(t) = q0, v = 0 (the joint coordinates are
    # relative to the base, so the rigid-motion rates are zero) and qdd = 0.  Then g = 0,
    # G v + g_t = g_t = 0 and bias = g_tt = 0 at all t.  Exact: 1e-10 against the support's
    # own acceleration (~|Omega|^2 |r| ~ 30 m/s^2; measured <= 5e-16 of it).
    flap = ref.AngleFunction("fourier", coefficients=(0.1, 0.05, -0.02, 0.01, 0.03), azimuth0=0.7,
                             amplitude=0.04, frequency=9.0, phase=0.3)
    spin = ref.AngleFunction("rotor", offset=-0.4)
    u1, p1, u2, p2 = np.array([0, 0, 1.0]), np.array([0.1, -0.3, 0]), np.array([1.0, 0.2, 0]), np.array([0.4, 0, 0.1])
    base = [ref.Hinge(u1, p1, spin), ref.Hinge(u2, p2, flap)]
    moved = [ref.Hinge(u1, p1 + 0.8 * u1, spin), ref.Hinge(u2, p2 - 0.37 * u2 / np.linalg.norm(u2), flap)]
    model = chain("xyz", n=4, locked_first=False, seed=5, hub=hub, rotor=RUN_UP)
    q0 = RNG.uniform(-1, 1, model.nq)
    kin = ref.kinematics(model, q0)          # reference configuration: no hinges yet
    model = dataclasses.replace(model, clamp_B=True, base_hinges=base, clamp_hinges=moved,
                                clamp_position=kin["P"][-1], clamp_rotation=kin["R"][-1])
    zero = np.zeros(model.nq)
    for t in (0.0, 0.25, 0.7, 1.4):
        scale = max(1.0, np.max(np.abs(ref.kinematics(model, q0, zero, t)["aP"])))
        assert np.max(np.abs(ref.constraint(model, q0, t))) < 1e-13
        assert np.max(np.abs(ref.constraint_velocity(model, q0, zero, t))) < 1e-10 * scale
        assert np.max(np.abs(ref.constraint_bias(model, q0, zero, t))) < 1e-10 * scale


def xyz_angles(M):
    """(phi, theta, psi) with Rx(phi) Ry(theta) Rz(psi) = M (|theta| < pi/2)."""
    return np.array([np.arctan2(-M[1, 2], M[2, 2]), np.arcsin(M[0, 2]), np.arctan2(-M[0, 1], M[0, 0])])


def test_clamp_turning_about_the_pivot():
    # A pivot chain with a three-angle first joint and a fixed base; the clamp turns by
    # theta(t) = psi(t) (run-up) about an axis u through P_1.  Exact solution: the whole
    # chain turns rigidly, joint 1 follows R_rel,1(q1(t)) = R_0^T Rot(u, theta) R_0
    # R_rel,1(q1_0), q1dot from S_1 q1dot = Omega u, the other joints keep their angles.
    # Checked: g = 0 (1e-13), G v + g_t = 0 (1e-12 relative to |g_t|); the six rows
    # G_1 qdd_1 = -bias for the three unknowns qdd_1 are consistent (least-squares residual
    # 1e-10 relative to |bias|; with the clamp's motion left out of the bias it is 0.45),
    # and that qdd_1 gives every body the rigid rotation's closed-form accelerations,
    # alpha = Omega' u and a_P = alpha x r + W x (W x r), W = Omega u, r = P - P_1 (1e-10
    # relative).  All exact; measured <= 1e-15.
    u, R0 = np.array([0.3, -0.4, 0.85]), ref.Ry(0.4)
    u = u / np.linalg.norm(u)
    model = chain("xyz", n=4, locked_first=False, seed=7, rotor=RUN_UP, base_rotation=R0,
                  r_A=[0.2, 0.1, -0.3])
    q0 = RNG.uniform(-0.8, 0.8, model.nq)
    kin = ref.kinematics(model, q0)
    model = dataclasses.replace(model, clamp_B=True, clamp_position=kin["P"][-1], clamp_rotation=kin["R"][-1],
                                clamp_hinges=[ref.Hinge(u, kin["P"][0], ref.AngleFunction("rotor"))])
    R1 = ref.relative_rotation("xyz", q0[:3])
    for t in (0.2, 0.6, 1.3):
        psi, om, omd = ref.rotor_state(RUN_UP, t)
        q = q0.copy()
        q[:3] = xyz_angles(R0.T @ ref.rot_axis(u, psi) @ R0 @ R1)
        S1 = ref.kinematics(model, q)["axes"][0]
        v = np.zeros(model.nq)
        v[:3] = np.linalg.solve(S1, om * u)
        assert np.max(np.abs(ref.constraint(model, q, t))) < 1e-13
        G = ref.constraint_jacobian(model, q, t)
        g_t = ref.constraint_velocity(model, q, np.zeros(model.nq), t)
        assert np.max(np.abs(ref.constraint_velocity(model, q, v, t))) < 1e-12 * np.max(np.abs(g_t))
        bias = ref.constraint_bias(model, q, v, t)
        qdd1, *_ = np.linalg.lstsq(G[:, :3], -bias, rcond=None)
        assert np.max(np.abs(G[:, :3] @ qdd1 + bias)) < 1e-10 * np.max(np.abs(bias))
        qdd = np.zeros(model.nq)
        qdd[:3] = qdd1
        moving = ref.kinematics(model, q, v, t, qdd)
        W, alpha = om * u, omd * u
        r = moving["P"] - moving["P"][0]
        a_rigid = np.cross(alpha, r) + np.cross(W, np.cross(W, r))
        # (relative to Omega^2 + |Omega'|: after the run-up alpha is zero)
        assert np.max(np.abs(moving["alpha"] - alpha)) < 1e-10 * (om**2 + abs(omd))
        assert rel_err(moving["aP"], a_rigid) < 1e-10


# ----------------------------------------------------------------------------------
# 8. Loads in closed form
# ----------------------------------------------------------------------------------
def test_drag_pulse_and_tip_force_closed_form():
    # Generalized forces of each load against its closed-form force mapped with the partial
    # velocities from kinematics (dC/dqd_k, dP_tip/dqd_k): drag in the hub frame
    # F = 1/2 rho cd 2R L |u_n| u_n, u = Rz(psi)^T V_inf - (v + W x (C - c)); the pulse only
    # inside [t0, t1); the tip force.  Exact up to round-off, and the load's part is the
    # difference of two whole generalized forces, so its round-off scales with |k0| (the
    # gravity, inertia and frame terms), not with the load: 1e-12 of the larger of the two
    # (measured 6e-15, 5e-15, 4e-15; relative to the load alone it had reached 2.5e-12 with
    # the shared generator's inputs when the file ran in part).  Its own generator: the inputs
    # do not depend on which tests ran before.
    rng = np.random.default_rng(558)
    V, rho, cd = np.array([12.0, -3.0, 2.0]), 1.2, np.array([1.1, 0.9, 1.3])
    base = chain("xy", n=3, locked_first=False, seed=9, hub=True, rotor=RUN_UP,
                 rotor_centre=[0.2, 0.1, 0.0])
    drag = dataclasses.replace(base, drag=ref.Drag(rho, cd, V))
    q, v, t = rng.uniform(-1, 1, base.nq), rng.normal(0, 1, base.nq), 0.7
    kin = ref.kinematics(base, q, v, t)
    JC = np.stack([ref.kinematics(base, q, e, t)["v"] for e in np.eye(base.nq)], axis=-1)
    Jtip = np.stack([ref.kinematics(base, q, e, t)["vP"][-1] for e in np.eye(base.nq)], axis=-1)
    psi, om, _ = ref.rotor_state(RUN_UP, t)
    want = np.zeros(base.nq)
    for j in range(3):
        e = kin["R"][j][:, 2]
        u = ref.Rz(psi).T @ V - kin["v"][j] - np.cross([0, 0, om], kin["c"][j] - base.rotor_centre)
        un = u - (u @ e) * e
        want += JC[j].T @ (0.5 * rho * cd[j] * 2 * base.R[j] * base.L[j] * np.linalg.norm(un) * un)
    k0 = ref.generalized_forces(base, q, v, t)

    def load_error(got, expected):
        return np.max(np.abs(got - expected)) / max(np.max(np.abs(expected)), np.max(np.abs(k0)))

    assert load_error(ref.generalized_forces(drag, q, v, t) - k0, want) < 1e-12
    F = np.array([0.4, -1.0, 2.0])
    pulse = dataclasses.replace(base, pulse=ref.Pulse(2, F, 0.5, 0.9))
    assert load_error(ref.generalized_forces(pulse, q, v, 0.5) - ref.generalized_forces(base, q, v, 0.5),
                      JC[1].T @ F) < 1e-12
    assert np.max(np.abs(ref.generalized_forces(pulse, q, v, 0.9) - ref.generalized_forces(base, q, v, 0.9))) \
        < 1e-12 * np.max(np.abs(k0))
    tip = dataclasses.replace(base, tip_force=F)
    assert load_error(ref.generalized_forces(tip, q, v, t) - k0, Jtip.T @ F) < 1e-12
    r = ref.solve_accelerations(tip, q, v, t)
    assert np.array_equal(r["F_B"], F) and np.array_equal(r["M_B"], np.zeros(3))
