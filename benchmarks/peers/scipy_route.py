"""Peer benchmark: the rotorcable chain in plain numpy, integrated with scipy.integrate.solve_ivp.

This is "what a Python user would write" for the thesis's route (eq. 3.58): minimal joint
coordinates q, the index-1 ODE obtained by differentiating the closure constraint of clamp B
twice, stabilised after Baumgarte,

    [ M(q)  G^T ] [ qdd ]   [ k(q, qd, t)                           ]
    [ G(q)  0   ] [ -lam] = [ -Gdot qd - 2 alpha G qd - beta^2 g(q)  ]

with state y = (q, qd), integrated by ``solve_ivp`` (``DOP853`` or ``Radau``).  The model is an
independent numpy implementation (nothing of the Fortran core is called for the dynamics);
only the scene (geometry, masses, loads, the consistent start) is read with
``pydriver.scene``.  ``check_scipy_route.py`` compares every model quantity with the Fortran.

Model (docs/model.md, pydriver/scene.py): body j is a rigid cylinder with frame origin at
its joint point P_j, axis along local z; R_j = R_{j-1} Rz(gamma_j) Ry(beta_j), R_0 =
base_rotation, P_1 = base_position, CM_j = P_j + R_j (0,0,L_j/2), P_{j+1} = P_j + R_j (0,0,L_j).
The gamma axis of joint j is R_{j-1} e_z, the beta axis R_j e_y, both through P_j.
Loads: weight m_j g at each CM, the centrifugal force m w^2 (r_x, r_y, 0) (r = CM +
rotor_offset) when the rotor turns, the rectangular pulse at the CM of ``pulse_body``,
a constant tip force (open chains), joint torques -c (q - rest) - d qd.
Clamp B (6 rows): g_pos = P_{n+1} - p_B, g_rot = vee(E - E^T)/2 with E = R_n R_B^T; its rate is
T w_n, T = (tr E I - E)/2.

Implementation notes (the choices a careful user makes, documented):

* Kinematics by cumulative sums over the bodies (angular velocities, bias angular
  accelerations and bias point accelerations at qdd = 0); the orientation product
  R_j = R_{j-1} Rz Ry is a short Python loop (n matrix products).  M and k by the Jourdain
  projection with body Jacobians J_T (CM velocity) and J_R (angular velocity) as dense
  (n, nq, 3) arrays, contracted as (nq, 3n) matrix products; the saddle-point system with
  ``np.linalg.solve``.  O(n^2 nq) per call, which is nothing for n = 5 ... 11.
* Baumgarte constants: alpha = beta = 1/tau_B with tau_B = 5 ms (``BAUMGARTE_TAU``).  The
  constraint error then obeys g'' + 2/tau g' + g/tau^2 = 0, critically damped with a double
  root at -1/tau = -200 1/s: drift from integration errors is pulled back within ~ 5 tau = 25
  ms, faster than the motions of interest (first UH-60 part-2 mode 26 Hz, eigenvalue
  -6 +- 165i 1/s; the six-link swing 1.2 Hz, -1.9 +- 7.8i 1/s), and slower than the fast
  physical modes of the UH-60 cable (overdamped, real eigenvalues down to -2.3e4 1/s at the
  start state), so for that case the stabilisation adds no stiffness: DOP853 needs the same ~ 3550 (stability-limited) steps with tau = 2 ms, 5 ms,
  20 ms or no stabilisation.  On the six-link case (no springs, slow) the -200 1/s root is the
  fastest eigenvalue and bounds DOP853's step (h < ~ 6/200 = 30 ms): at rtol = 1e-3 it costs
  1010 evaluations against 2882 (tau = 2 ms), 398 (20 ms) and 194 (no stabilisation); at tight
  tolerance the choice does not change the solution (the terms vanish on the exact solution).
* Tolerances: ``atol = rtol * 1e-2`` for every component of y (q in rad, qd in rad/s), the
  coupling of the project's decks (rtol 1e-8, atol 1e-10).  The angles are O(0.1 ... 3) rad,
  the largest rates ~ 5 rad/s (six-link) and ~ 1 rad/s (UH-60 decay, a 0.2 mm response), so
  atol is a floor 100 times below rtol for unit-size components and keeps the test relative for
  all but the rates that have decayed to ~ 0.  The same coupling is used at every rtol.  Note
  that the UH-60 decay is a small motion about large angles: an angle error of rtol * 1 rad is
  ~ 500 rtol of the 2e-3 rad response.
* Radau: SciPy's default finite-difference Jacobian (``jac=None``, not vectorized), which is
  what most users run; ``njev`` counts those Jacobians, and ``nfev`` (SciPy's count) does not
  include the 2 nq columns of each finite difference, so ``nfev_total`` (extra key) counts
  every right-hand-side call.  Caveat, measured: SciPy's ``num_jac`` perturbs component i by
  factor_i * max(|y_i|, atol) (factor from sqrt(eps)), so with atol = 1e-2 rtol the rates that
  have decayed to ~ 0 get increments near round-off; on the UH-60 decay at rtol <= 1e-6 Radau
  then fails Newton iterations step after step (a new Jacobian every ~ 1.4 steps, h ~ 3e-6 s
  late in the run) and reaches only t = 0.92 s (rtol 1e-6) and 0.59 s (1e-8) in 5 min of CPU.
  A plain forward difference with increments 1e-7 max(|y_i|, 1) finishes the same runs in 7 s
  and 20 s with 3 and 46 Jacobians; atol = rtol also cures it (rtol 1e-6: 4.4 s, 5 Jacobians).
  We keep the default, as the benchmark asks for what a user gets out of the box.
* The pulse is a discontinuity in t: the integration is split at the pulse edges
  (``solve_ivp`` on [0, t_start], [t_start, t_end_pulse], [t_end_pulse, t_end], empty pieces
  skipped), and in each piece the force is on or off for the whole piece (decided at the piece's
  midpoint), so the solver never sees the jump.
* Reactions at t_end from eq. 3.55 (the plain acceleration-level system, without the
  Baumgarte terms, as the project reports them) at the integrated (q, qd):
  F_B = lam_pos, M_B = T^T lam_rot (about B); F_A, M_A (about P_1) from the balance of the
  whole chain:  F_A = sum m_j a_j - sum F_ext,j - F_B - F_tip and
  M_A = sum [(CM_j - P_1) x (m_j a_j - F_ext,j) + Theta_j alpha_j + w_j x Theta_j w_j]
        - M_B - (P_{n+1} - P_1) x (F_B + F_tip).
* ``max_constraint_violation_m``: max |g_pos| (Euclidean norm of the tip error) over the
  solver's accepted step points (``solve_ivp`` without ``t_eval``), which include t_end.
"""

from __future__ import annotations

import json
import sys
import time

import numpy as np
from scipy.integrate import solve_ivp

METHODS = ("scipy-DOP853", "scipy-Radau")

#: Baumgarte time constant [s]; alpha = beta = 1/BAUMGARTE_TAU (see the module docstring).
BAUMGARTE_TAU = 5.0e-3
#: absolute tolerance = ATOL_PER_RTOL * rtol on every state component (q [rad], qd [rad/s]).
ATOL_PER_RTOL = 1.0e-2


def _rz(a):
    c, s = np.cos(a), np.sin(a)
    r = np.zeros(a.shape + (3, 3))
    r[..., 0, 0], r[..., 0, 1], r[..., 1, 0], r[..., 1, 1], r[..., 2, 2] = c, -s, s, c, 1.0
    return r


def _ry(a):
    c, s = np.cos(a), np.sin(a)
    r = np.zeros(a.shape + (3, 3))
    r[..., 0, 0], r[..., 0, 2], r[..., 2, 0], r[..., 2, 2], r[..., 1, 1] = c, s, -s, c, 1.0
    return r


def _cross(a, b):
    """a x b over the last axis (broadcasting); np.cross does the same but spends most of its
    time on axis bookkeeping for these small arrays (half the cost of a right-hand side)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


def _skew(w):
    return np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])


def _vee(s):
    return np.array([s[2, 1], s[0, 2], s[1, 0]])


class ChainModel:
    """Equations of motion of a scene's chain in minimal coordinates (numpy only)."""

    def __init__(self, sc, alpha=None, beta=None):
        self.sc = sc
        self.n = n = sc.n_bodies
        self.nq = nq = sc.n_coords
        self.nc = 6 if sc.clamp_active else 0
        self.L = np.asarray(sc.lengths, float)
        self.m = np.asarray(sc.masses, float)
        self.inertia = np.asarray(sc.inertia, float)
        self.free = ~np.asarray(sc.locked, bool)
        fc = np.asarray(sc.first_coord, int)
        self.ig = fc[self.free] - 1            # q index of gamma of each free joint
        self.ib = fc[self.free]                # q index of beta
        # per coordinate: its body (0-based) and whether it is the beta (1) or gamma (0) axis
        self.body_of = np.empty(nq, int)
        self.kind = np.empty(nq, int)
        free_bodies = np.nonzero(self.free)[0]
        self.body_of[self.ig], self.kind[self.ig] = free_bodies, 0
        self.body_of[self.ib], self.kind[self.ib] = free_bodies, 1
        # mask[j, k]: coordinate k moves body j
        self.mask = (self.body_of[None, :] <= np.arange(n)[:, None]).astype(float)
        self.c = np.asarray(sc.stiffness, float)
        self.d = np.asarray(sc.damping, float)
        self.rest = np.asarray(sc.rest, float)
        self.g_acc = np.asarray(sc.gravity, float)
        self.R0 = np.asarray(sc.base_rotation, float)
        self.P1 = np.asarray(sc.base_position, float)
        self.pB = np.asarray(sc.clamp_position, float)
        self.RB = np.asarray(sc.clamp_rotation, float)
        tau = BAUMGARTE_TAU
        self.alpha = 1.0 / tau if alpha is None else alpha
        self.beta = 1.0 / tau if beta is None else beta

    # ------------------------------------------------------------------ kinematics
    def kinematics(self, q, v):
        """Positions, orientations, joint axes, angular velocities and bias accelerations."""
        n = self.n
        ang = np.array(self.sc.locked_angles, float)        # (n, 2) gamma, beta
        ang[self.free, 0] = q[self.ig]
        ang[self.free, 1] = q[self.ib]
        rate = np.zeros((n, 2))
        rate[self.free, 0] = v[self.ig]
        rate[self.free, 1] = v[self.ib]
        Rj = _rz(ang[:, 0]) @ _ry(ang[:, 1])                 # joint rotations (n, 3, 3)
        R = np.empty((n, 3, 3))
        prev = self.R0
        for j in range(n):
            prev = R[j] = prev @ Rj[j]
        Rprev = np.concatenate([self.R0[None], R[:-1]])
        a_g = Rprev[:, :, 2]                                  # gamma axes (world)
        a_b = R[:, :, 1]                                      # beta axes (world)
        dvec = R[:, :, 2] * self.L[:, None]                   # P_j -> P_{j+1}
        P = np.concatenate([self.P1[None], self.P1 + np.cumsum(dvec, axis=0)])
        cm = P[:-1] + 0.5 * dvec
        w_rel = a_g * rate[:, :1] + a_b * rate[:, 1:]
        w = np.cumsum(w_rel, axis=0)
        w_prev = np.concatenate([np.zeros((1, 3)), w[:-1]])
        # bias angular acceleration (qdd = 0): w_{j-1} x w_rel + gd bd a_g x a_b
        alpha_b = np.cumsum(_cross(w_prev, w_rel)
                            + (rate[:, 0] * rate[:, 1])[:, None] * _cross(a_g, a_b), axis=0)

        def centripetal(r):
            return _cross(alpha_b, r) + _cross(w, _cross(w, r))

        accP = np.concatenate([np.zeros((1, 3)), np.cumsum(centripetal(dvec), axis=0)])
        acc_cm = accP[:-1] + centripetal(0.5 * dvec)
        axes = np.where(self.kind[:, None] == 0, a_g[self.body_of], a_b[self.body_of])  # (nq, 3)
        return dict(R=R, P=P, cm=cm, w=w, alpha_b=alpha_b, accP_b=accP, acc_cm_b=acc_cm, axes=axes)

    def jacobians(self, kin):
        """J_T (n, nq, 3) of the CM velocities, J_R (n, nq, 3) of the angular velocities,
        J_tip (nq, 3) of the tip velocity."""
        axes, P = kin["axes"], kin["P"]
        pk = P[self.body_of]                                   # joint point of each coordinate
        JR = self.mask[:, :, None] * axes[None]
        JT = self.mask[:, :, None] * _cross(axes[None], kin["cm"][:, None, :] - pk[None])
        Jtip = _cross(axes, P[-1] - pk)
        return JT, JR, Jtip

    def external_forces(self, cm, pulse_on):
        sc = self.sc
        F = self.m[:, None] * self.g_acc[None]
        if sc.rotor_omega != 0.0:
            F[:, :2] += self.m[:, None] * sc.rotor_omega**2 * (cm[:, :2] + sc.rotor_offset[:2])
        if pulse_on and sc.pulse_body > 0:
            F[sc.pulse_body - 1] += sc.pulse_force
        return F

    # ------------------------------------------------------------------ dynamics
    def terms(self, q, v, pulse_on):
        """M, k, G, Gdot v, g at (q, v) plus the intermediate kinematics."""
        kin = self.kinematics(q, v)
        JT, JR, Jtip = self.jacobians(kin)
        R, w, alpha_b = kin["R"], kin["w"], kin["alpha_b"]
        theta = (R * self.inertia[:, None, :]) @ R.transpose(0, 2, 1)   # world inertia about CM
        # Jacobians as (nq, 3n) matrices: M = J_T^T m J_T + J_R^T Theta J_R as two matmuls
        JTf = JT.transpose(1, 0, 2).reshape(self.nq, -1)
        JRf = JR.transpose(1, 0, 2).reshape(self.nq, -1)
        JRth = (JR @ theta).transpose(1, 0, 2).reshape(self.nq, -1)
        M = (JTf * np.repeat(self.m, 3)) @ JTf.T + JRth @ JRf.T
        F = self.external_forces(kin["cm"], pulse_on)
        th_w = (theta @ w[:, :, None])[:, :, 0]
        force = F - self.m[:, None] * kin["acc_cm_b"]
        moment = -(theta @ alpha_b[:, :, None])[:, :, 0] - _cross(w, th_w)
        k = (JTf @ force.ravel() + JRf @ moment.ravel()
             - self.c * (q - self.rest) - self.d * v)
        if not self.sc.clamp_active:
            k += Jtip @ self.sc.tip_force
        out = dict(kin=kin, JT=JT, JR=JR, theta=theta, F=F, M=M, k=k)
        if self.nc:
            E = R[-1] @ self.RB.T
            T = 0.5 * (np.trace(E) * np.eye(3) - E)
            Edot = _skew(w[-1]) @ E
            Tdot = 0.5 * (np.trace(Edot) * np.eye(3) - Edot)
            out["T"] = T
            out["g"] = np.concatenate([kin["P"][-1] - self.pB, 0.5 * _vee(E - E.T)])
            out["G"] = np.vstack([Jtip.T, T @ JR[-1].T])
            out["Gdot_v"] = np.concatenate([kin["accP_b"][-1], Tdot @ w[-1] + T @ alpha_b[-1]])
        return out

    def accelerations(self, tm, v, baumgarte=True):
        """Solve the saddle-point system for qdd and lambda (eq. 3.55, + Baumgarte terms)."""
        M, k = tm["M"], tm["k"]
        if not self.nc:
            return np.linalg.solve(M, k), np.zeros(0)
        G = tm["G"]
        rhs_c = -tm["Gdot_v"]
        if baumgarte:
            rhs_c = rhs_c - 2.0 * self.alpha * (G @ v) - self.beta**2 * tm["g"]
        A = np.block([[M, G.T], [G, np.zeros((self.nc, self.nc))]])
        x = np.linalg.solve(A, np.concatenate([k, rhs_c]))
        return x[:self.nq], -x[self.nq:]

    def rhs(self, t, y, pulse_on):
        q, v = y[:self.nq], y[self.nq:]
        tm = self.terms(q, v, pulse_on)
        qdd, _ = self.accelerations(tm, v)
        return np.concatenate([v, qdd])

    def wrenches(self, tm, qdd, lam):
        """(12,) F_A, M_A (about P_1), F_B, M_B (about B): supports on the chain, world frame."""
        kin = tm["kin"]
        P, cm, w, theta = kin["P"], kin["cm"], kin["w"], tm["theta"]
        a_cm = kin["acc_cm_b"] + np.einsum("jkc,k->jc", tm["JT"], qdd)
        alpha = kin["alpha_b"] + np.einsum("jkc,k->jc", tm["JR"], qdd)
        if self.nc:
            FB, MB = lam[:3], tm["T"].T @ lam[3:]
            F_tip = FB
        else:
            FB, MB = np.zeros(3), np.zeros(3)
            F_tip = np.asarray(self.sc.tip_force, float)
        net = self.m[:, None] * a_cm - tm["F"]          # what the supports must supply per body
        FA = net.sum(axis=0) - F_tip
        r = cm - P[0]
        dH = (_cross(r, net) + np.einsum("jab,jb->ja", theta, alpha)
              + _cross(w, np.einsum("jab,jb->ja", theta, w))).sum(axis=0)
        MA = dH - MB - _cross(P[-1] - P[0], F_tip)
        return np.concatenate([FA, MA, FB, MB])


def _pieces(sc):
    """Integration intervals [a, b] with the pulse on or off throughout each."""
    edges = [0.0, sc.t_end]
    if sc.pulse_body > 0:
        edges += [min(max(x, 0.0), sc.t_end) for x in sc.pulse_window]
    edges = sorted(set(edges))
    out = []
    for a, b in zip(edges[:-1], edges[1:]):
        if b > a:
            mid = 0.5 * (a + b)
            on = sc.pulse_body > 0 and sc.pulse_window[0] <= mid < sc.pulse_window[1]
            out.append((a, b, bool(on)))
    return out


def integrate(model, solver, rtol, t_eval=None):
    """solve_ivp piece by piece from the scene's consistent start to t_end.

    Returns the list of solve_ivp results, the status ("ok" or the failing piece's message)
    and the number of right-hand-side calls.  ``t_eval`` (optional, sorted) is split over the
    pieces, a time on a pulse edge going to the piece that starts there (with t_eval the next
    piece starts from the dense output at the edge, equal to the step end up to round-off).
    """
    sc = model.sc
    y = np.concatenate([sc.q0, sc.v0]).astype(float)
    calls = [0]

    def make_fun(on):
        def fun(t, yy):
            calls[0] += 1
            return model.rhs(t, yy, on)
        return fun

    sols, status = [], "ok"
    pieces = _pieces(sc)
    for i, (a, b, on) in enumerate(pieces):
        te = None
        if t_eval is not None:
            last = i == len(pieces) - 1
            te = t_eval[(t_eval >= a) & ((t_eval < b) | (last & (t_eval <= b)))]
        sol = solve_ivp(make_fun(on), (a, b), y, method=solver, rtol=rtol,
                        atol=ATOL_PER_RTOL * rtol, t_eval=te, dense_output=te is not None)
        sols.append(sol)
        if not sol.success:
            status = sol.message
            break
        y = sol.y[:, -1].copy() if te is None else sol.sol(b)
    return sols, status, calls[0]


def simulate(deck_path: str, method: str, rtol: float, *, n_samples: int = 0) -> dict:
    """Integrate the deck's scene from its consistent start to t_end.

    Returns {"method", "rtol", "cpu_s" (time.process_time() of the integration only, not
    scene set-up), "cm_end": (n,3) CM positions at t_end [m], "tip_end": (3,) P_{n+1} [m],
    "reactions_end": (12,) F_A, M_A, F_B, M_B at t_end (support on chain, inertial, moments
    about A and B), "nfev": int, "njev": int, "status": str ("ok" or the solver message),
    "max_constraint_violation_m": max |g_pos| at the output points}.
    Extra keys: "nfev_total" (every right-hand-side call, including Radau's finite-difference
    Jacobian columns), "nsteps" (accepted steps), "t_last" (t_end unless the solver failed:
    the *_end values are then at t_last), "atol", "baumgarte_tau_s".  ``n_samples`` > 1 adds
    "cm_samples": (n_samples, n, 3) CMs at n_samples equally spaced times 0 ... t_end, from
    solve_ivp's dense output (t_eval).
    """
    import pydriver

    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}")
    solver = method.split("-", 1)[1]
    sc = pydriver.scene(deck_path)
    model = ChainModel(sc)
    atol = ATOL_PER_RTOL * rtol
    t0 = time.process_time()
    times = np.linspace(0.0, sc.t_end, n_samples) if n_samples > 1 else None
    sols, status, calls = integrate(model, solver, rtol, t_eval=times)
    cpu = time.process_time() - t0
    nfev = sum(sol.nfev for sol in sols)
    njev = sum(sol.njev for sol in sols)
    nsteps = sum((len(sol.sol.ts) if sol.sol is not None else sol.t.size) - 1 for sol in sols)
    ys = [sol.y for sol in sols]
    y = ys[-1][:, -1]             # the state at t_end (at the failure time if status != "ok")
    samples = None
    if times is not None:
        yt = np.concatenate(ys, axis=1).T
        samples = np.array([model.kinematics(yy[:model.nq], yy[model.nq:])["cm"] for yy in yt])

    # post-processing (not timed)
    gmax = 0.0
    if model.nc:
        for yy in np.concatenate(ys, axis=1).T:
            tip = model.kinematics(yy[:model.nq], yy[model.nq:])["P"][-1]
            gmax = max(gmax, float(np.linalg.norm(tip - model.pB)))
    q, v = y[:model.nq], y[model.nq:]
    on_end = _pieces(sc)[-1][2]
    tm = model.terms(q, v, on_end)
    qdd, lam = model.accelerations(tm, v, baumgarte=False)
    wr = model.wrenches(tm, qdd, lam)
    if not model.nc:
        wr[6:] = 0.0
    return {"method": method, "rtol": float(rtol), "cpu_s": cpu,
            "cm_end": tm["kin"]["cm"].copy(), "tip_end": tm["kin"]["P"][-1].copy(),
            "reactions_end": wr, "nfev": int(nfev), "njev": int(njev), "status": status,
            "max_constraint_violation_m": gmax,
            "nfev_total": int(calls), "nsteps": int(nsteps), "t_last": float(sols[-1].t[-1]),
            "atol": atol,
            "baumgarte_tau_s": BAUMGARTE_TAU, **({"cm_samples": samples} if samples is not None else {})}


if __name__ == "__main__":
    import argparse

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("deck", nargs="?", default="inputs/six_link_dynamic.nml")
    ap.add_argument("--method", default="scipy-DOP853", choices=METHODS)
    ap.add_argument("--rtol", type=float, default=1e-6)
    args = ap.parse_args()
    res = simulate(args.deck, args.method, args.rtol)
    json.dump({k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in res.items()},
              sys.stdout, indent=1)
    print()
