"""Independent reference dynamics of a chain of rigid cylinders, in MAXIMAL coordinates.

Pure numpy. Used by tests to cross-check the Fortran implementation. The formulation
deliberately does NOT use generalized-coordinate Jacobians: every body carries its own
6 unknown accelerations (a_c, alpha) in the world frame, every joint its own unknown
reaction, and the whole Newton-Euler + acceleration-constraint system is solved at once.

Conventions (all angles in radians)
-----------------------------------
* Body j (1..n): uniform solid cylinder, length L_j, radius R_j, mass m_j.
  Body frame: origin at the joint point P_j, axis along local z, CM at (0,0,L/2),
  end point at (0,0,L). Central inertia diag(Txx,Tyy,Tzz), Txx = Tyy = m(L^2+3R^2)/12,
  Tzz = m R^2/2.
* Active rotations Rz(a) = [[c,-s,0],[s,c,0],[0,0,1]], Ry(b) = [[c,0,s],[0,1,0],[-s,0,c]].
  R_0 = I (base), R_j = R_{j-1} Rz(gamma_j) Ry(beta_j), P_1 = r_A,
  P_{j+1} = P_j + R_j (0,0,L_j). Tip = P_{n+1}.
* Joint axes in world: a_gamma = R_{j-1} e_z, a_beta = R_j e_y, n_j = a_gamma x a_beta
  (a_gamma and a_beta are always orthogonal, so n_j is a unit vector: no gimbal
  singularity inside one joint).
* q = (gamma_j, beta_j) for each FREE joint j in increasing order; locked joints use
  model.locked_angles and contribute no coordinates.
* Joint reaction (f_j, moment) is the wrench exerted by the PARENT (body j-1 or the
  base) on the CHILD (body j), force applied at P_j. Spring/damper torques are applied
  separately (they are not part of the constraint reaction unknown), but they ARE
  included in the reported base wrench (F_A, M_A) since that is the total wrench the
  base exerts on body 1.
* Clamp B: the support exerts (F_B, M_B) on body n, F_B applied at the tip point,
  M_B a pure moment (i.e. moment about the tip point).

Solvability
-----------
The system is square: 6n body equations + (4 per free joint, 6 per locked joint, 6 for
the clamp) constraint equations, for the same number of unknowns. It is SINGULAR when
the constraints are redundant, i.e. when the constraint Jacobian of the clamp loses
rank: always when the clamp is active and the number of free coordinates is < 6, and
also at kinematically singular configurations of the closed chain (e.g. when the free
joint axes of the chain cannot generate all 6 tip motions). Then the reactions are not
unique (statically indeterminate); we fall back to lstsq (minimum-norm reactions) and
set result['singular'] = True. Without the clamp the system is never singular
(positive masses/inertias).
Example: 5 bodies, joints 1 AND 5 locked, gamma=(0,0,0,pi/2,pi/2),
beta=(pi/2,pi/2,pi/2,pi/2,-pi/2), clamp at the tip: the loop Jacobian has rank 5 < 6,
one self-stress (mixing F_Bz, M_Bx, M_By) exists and the returned reactions are the
minimum-norm ones. With only joint 1 locked the same shape is a regular 2-DOF
closed-loop mechanism that is NOT in static equilibrium (qdd != 0).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


# ----------------------------------------------------------------------------------
# Model description
# ----------------------------------------------------------------------------------
@dataclass
class ChainModel:
    L: np.ndarray
    R: np.ndarray
    m: np.ndarray
    locked: np.ndarray                      # bool (n,)
    locked_angles: np.ndarray               # (n,2) gamma,beta used where locked
    c: np.ndarray                           # (n,2) spring stiffness (gamma, beta)
    d: np.ndarray                           # (n,2) damping (gamma, beta)
    rest: np.ndarray                        # (n,2) rest angles (gamma, beta)
    g_vec: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, -9.81]))
    r_A: np.ndarray = field(default_factory=lambda: np.zeros(3))
    omega_rotor: float = 0.0
    rotor_offset: np.ndarray = field(default_factory=lambda: np.zeros(2))
    clamp_B: bool = False
    # Note: the clamp targets p_B, R_B are not stored: at acceleration level only
    # "tip acceleration = 0, alpha_n = 0" enters; (q, qd) must be consistent with the
    # clamp (tip at p_B, R_n = R_B, zero tip velocity) for the result to be meaningful.

    def __post_init__(self):
        self.L = np.asarray(self.L, float)
        self.R = np.asarray(self.R, float)
        self.m = np.asarray(self.m, float)
        n = self.L.size
        self.locked = np.asarray(self.locked, bool).reshape(n)
        self.locked_angles = np.asarray(self.locked_angles, float).reshape(n, 2)
        self.c = np.asarray(self.c, float).reshape(n, 2)
        self.d = np.asarray(self.d, float).reshape(n, 2)
        self.rest = np.asarray(self.rest, float).reshape(n, 2)
        self.g_vec = np.asarray(self.g_vec, float).reshape(3)
        self.r_A = np.asarray(self.r_A, float).reshape(3)
        self.rotor_offset = np.asarray(self.rotor_offset, float).reshape(2)

    @property
    def n(self) -> int:
        return self.L.size

    @property
    def free_joints(self) -> list[int]:
        """0-based indices of free joints, in coordinate order."""
        return [j for j in range(self.n) if not self.locked[j]]

    @property
    def nq(self) -> int:
        return 2 * len(self.free_joints)


# ----------------------------------------------------------------------------------
# Small helpers
# ----------------------------------------------------------------------------------
E_Y = np.array([0.0, 1.0, 0.0])
E_Z = np.array([0.0, 0.0, 1.0])


def Rz(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def Ry(b: float) -> np.ndarray:
    c, s = np.cos(b), np.sin(b)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def skew(v: np.ndarray) -> np.ndarray:
    """skew(v) @ x == cross(v, x)."""
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def body_inertia(model: ChainModel) -> np.ndarray:
    """(n,3,3) central inertia tensors in body frames (solid uniform cylinder)."""
    T = np.zeros((model.n, 3, 3))
    for j in range(model.n):
        m, L, R = model.m[j], model.L[j], model.R[j]
        txx = m * (L**2 + 3.0 * R**2) / 12.0
        T[j] = np.diag([txx, txx, 0.5 * m * R**2])
    return T


def joint_angles(model: ChainModel, q: np.ndarray) -> np.ndarray:
    """(n,2) array of (gamma, beta) for every joint: q for free, constants for locked."""
    q = np.asarray(q, float).reshape(-1)
    if q.size != model.nq:
        raise ValueError(f"q has size {q.size}, expected {model.nq}")
    ang = model.locked_angles.copy()
    for k, j in enumerate(model.free_joints):
        ang[j] = q[2 * k: 2 * k + 2]
    return ang


def joint_rates(model: ChainModel, qd: np.ndarray) -> np.ndarray:
    """(n,2) array of (gammadot, betadot); zero for locked joints."""
    qd = np.asarray(qd, float).reshape(-1)
    if qd.size != model.nq:
        raise ValueError(f"qd has size {qd.size}, expected {model.nq}")
    rates = np.zeros((model.n, 2))
    for k, j in enumerate(model.free_joints):
        rates[j] = qd[2 * k: 2 * k + 2]
    return rates


# ----------------------------------------------------------------------------------
# 1. Forward kinematics (positions, orientations, velocities)
# ----------------------------------------------------------------------------------
def kinematics(model: ChainModel, q: np.ndarray, qd: np.ndarray | None = None) -> dict:
    """Positions/orientations (and velocities if qd is given) of every body.

    Returns dict with
      'R'  (n,3,3) world-from-body rotations
      'P'  (n+1,3) joint points, P[n] = tip
      'c'  (n,3)   centres of mass
      'a_gamma', 'a_beta', 'n_axis'  (n,3) joint axes in world
      if qd given: 'w' (n,3) angular velocities, 'v' (n,3) CM velocities,
                   'vP' (n+1,3) joint-point velocities
    """
    n = model.n
    ang = joint_angles(model, q)
    Rs = np.zeros((n, 3, 3))
    P = np.zeros((n + 1, 3))
    cm = np.zeros((n, 3))
    ag = np.zeros((n, 3))
    ab = np.zeros((n, 3))
    P[0] = model.r_A
    R_parent = np.eye(3)                        # base orientation = identity
    for j in range(n):
        gam, bet = ang[j]
        ag[j] = R_parent @ E_Z                  # gamma axis: parent's z axis
        Rs[j] = R_parent @ Rz(gam) @ Ry(bet)    # world-from-body j
        ab[j] = Rs[j] @ E_Y                     # beta axis: new y axis
        cm[j] = P[j] + Rs[j] @ np.array([0.0, 0.0, 0.5 * model.L[j]])
        P[j + 1] = P[j] + Rs[j] @ np.array([0.0, 0.0, model.L[j]])
        R_parent = Rs[j]
    out = {"R": Rs, "P": P, "c": cm, "a_gamma": ag, "a_beta": ab,
           "n_axis": np.cross(ag, ab)}
    if qd is None:
        return out

    # Velocities: relative-rate definition w_j = w_{j-1} + a_gamma*gd + a_beta*bd
    # (locked joint: rates are zero, so w_j = w_{j-1}); base is fixed (w_0 = 0, v_P1 = 0).
    rates = joint_rates(model, qd)
    w = np.zeros((n, 3))
    v = np.zeros((n, 3))
    vP = np.zeros((n + 1, 3))
    w_parent = np.zeros(3)
    for j in range(n):
        w[j] = w_parent + ag[j] * rates[j, 0] + ab[j] * rates[j, 1]
        # rigid-body transport of velocity from P_j (shared with the parent)
        v[j] = vP[j] + np.cross(w[j], cm[j] - P[j])
        vP[j + 1] = vP[j] + np.cross(w[j], P[j + 1] - P[j])
        w_parent = w[j]
    out.update(w=w, v=v, vP=vP, rates=rates)
    return out


# ----------------------------------------------------------------------------------
# 2./3. Newton-Euler in maximal coordinates, solved as one linear system
# ----------------------------------------------------------------------------------
def _solve_maximal(model: ChainModel, q, qd, clamp: bool, extra_gen_torque=None) -> dict:
    """Assemble and solve the maximal-coordinate system.

    extra_gen_torque: optional (nq,) vector of additional generalized torques, applied
    as torque pairs along the joint axes (+axis on child, -axis on parent).
    """
    n = model.n
    kin = kinematics(model, q, qd)
    Rs, P, cm = kin["R"], kin["P"], kin["c"]
    ag, ab, nax = kin["a_gamma"], kin["a_beta"], kin["n_axis"]
    w, rates = kin["w"], kin["rates"]
    ang = joint_angles(model, q)
    T = body_inertia(model)

    # ---------------- unknown layout ----------------
    # body j: a_c (3), alpha (3)           -> columns 6j .. 6j+5
    # joint j free:   f_j (3), mu_j (1)    (moment mu_j * n_j)
    # joint j locked: f_j (3), M_j (3)
    # clamp: F_B (3), M_B (3)
    col_a = lambda j: slice(6 * j, 6 * j + 3)
    col_al = lambda j: slice(6 * j + 3, 6 * j + 6)
    col = 6 * n
    jf, jm = [], []                           # column slices of joint force / moment
    for j in range(n):
        jf.append(slice(col, col + 3))
        col += 3
        k = 3 if model.locked[j] else 1
        jm.append(slice(col, col + k))
        col += k
    if clamp:
        cFB = slice(col, col + 3)
        cMB = slice(col + 3, col + 6)
        col += 6
    nunk = col
    A = np.zeros((nunk, nunk))
    b = np.zeros(nunk)

    # ---------------- applied loads (known) ----------------
    F_app = np.zeros((n, 3))      # forces at the CMs
    M_app = np.zeros((n, 3))      # pure moments on each body
    Om2 = model.omega_rotor ** 2
    for j in range(n):
        F_app[j] += model.m[j] * model.g_vec                       # gravity
        F_app[j] += model.m[j] * Om2 * np.array([cm[j, 0] + model.rotor_offset[0],
                                                 cm[j, 1] + model.rotor_offset[1],
                                                 0.0])             # centrifugal
    # joint springs/dampers (and extra generalized torques): torque tau on child,
    # -tau on parent (nothing on the base, which is not a body here)
    tau_joint = np.zeros((n, 3))
    k_free = {j: k for k, j in enumerate(model.free_joints)}
    for j in range(n):
        if model.locked[j]:
            continue
        tg = -(model.c[j, 0] * (ang[j, 0] - model.rest[j, 0]) + model.d[j, 0] * rates[j, 0])
        tb = -(model.c[j, 1] * (ang[j, 1] - model.rest[j, 1]) + model.d[j, 1] * rates[j, 1])
        if extra_gen_torque is not None:
            k = k_free[j]
            tg += extra_gen_torque[2 * k]
            tb += extra_gen_torque[2 * k + 1]
        tau_joint[j] = tg * ag[j] + tb * ab[j]
    for j in range(n):
        M_app[j] += tau_joint[j]
        if j > 0:
            M_app[j - 1] -= tau_joint[j]

    # ---------------- body equations (rows 0 .. 6n-1) ----------------
    for j in range(n):
        rN = slice(6 * j, 6 * j + 3)       # Newton rows
        rE = slice(6 * j + 3, 6 * j + 6)   # Euler rows (about CM)
        Iw = Rs[j] @ T[j] @ Rs[j].T        # world-frame inertia
        # Newton: m a_c - f_j + f_{j+1} - [F_B] = F_app
        A[rN, col_a(j)] = model.m[j] * np.eye(3)
        A[rN, jf[j]] -= np.eye(3)
        if j + 1 < n:
            A[rN, jf[j + 1]] += np.eye(3)
        # Euler about CM: Iw alpha + w x Iw w = (P_j - c) x f_j - (P_{j+1} - c) x f_{j+1}
        #                 + joint moments (in from j, out to j+1) + M_app [+ clamp]
        A[rE, col_al(j)] = Iw
        A[rE, jf[j]] -= skew(P[j] - cm[j])
        if model.locked[j]:
            A[rE, jm[j]] -= np.eye(3)
        else:
            A[rE, jm[j]] -= nax[j][:, None]
        if j + 1 < n:
            A[rE, jf[j + 1]] += skew(P[j + 1] - cm[j])
            if model.locked[j + 1]:
                A[rE, jm[j + 1]] += np.eye(3)
            else:
                A[rE, jm[j + 1]] += nax[j + 1][:, None]
        b[rN] = F_app[j]
        b[rE] = M_app[j] - np.cross(w[j], Iw @ w[j])
        if clamp and j == n - 1:
            A[rN, cFB] -= np.eye(3)
            A[rE, cFB] -= skew(P[n] - cm[j])
            A[rE, cMB] -= np.eye(3)

    # ---------------- acceleration-level constraints ----------------
    row = 6 * n

    def point_acc(jb, point):
        """Coefficient block and known part of the acceleration of `point` on body jb:
        a = a_c + alpha x r + w x (w x r), r = point - c."""
        r = point - cm[jb]
        return -skew(r), np.cross(w[jb], np.cross(w[jb], r))

    for j in range(n):
        # (a) equal acceleration of P_j computed from child and parent (base: zero)
        rr = slice(row, row + 3)
        Kc, kc = point_acc(j, P[j])
        A[rr, col_a(j)] += np.eye(3)
        A[rr, col_al(j)] += Kc
        rhs = -kc
        if j > 0:
            Kp, kp = point_acc(j - 1, P[j])
            A[rr, col_a(j - 1)] -= np.eye(3)
            A[rr, col_al(j - 1)] -= Kp
            rhs = rhs + kp
        b[rr] = rhs
        row += 3
        # (b) rotational constraint
        if model.locked[j]:
            # rigid joint: alpha_j = alpha_{j-1} (base: 0)
            rr = slice(row, row + 3)
            A[rr, col_al(j)] += np.eye(3)
            if j > 0:
                A[rr, col_al(j - 1)] -= np.eye(3)
            row += 3
        else:
            # no relative rotation about n_j:
            # n.(alpha_j - alpha_{j-1}) + ndot.(w_j - w_{j-1}) = 0
            w_par = w[j - 1] if j > 0 else np.zeros(3)
            ag_dot = np.cross(w_par, ag[j])
            ab_dot = np.cross(w[j], ab[j])
            n_dot = np.cross(ag_dot, ab[j]) + np.cross(ag[j], ab_dot)
            A[row, col_al(j)] += nax[j]
            if j > 0:
                A[row, col_al(j - 1)] -= nax[j]
            b[row] = -n_dot @ (w[j] - w_par)
            row += 1
    if clamp:
        # tip point fixed: acceleration zero; last body orientation fixed: alpha_n = 0
        rr = slice(row, row + 3)
        K, kk = point_acc(n - 1, P[n])
        A[rr, col_a(n - 1)] += np.eye(3)
        A[rr, col_al(n - 1)] += K
        b[rr] = -kk
        row += 3
        A[row:row + 3, col_al(n - 1)] = np.eye(3)
        row += 3
    assert row == nunk

    # ---------------- solve ----------------
    singular = False
    try:
        x = np.linalg.solve(A, b)
        if not np.all(np.isfinite(x)) or np.linalg.cond(A) > 1e13:
            raise np.linalg.LinAlgError
    except np.linalg.LinAlgError:
        singular = True
        x = np.linalg.lstsq(A, b, rcond=None)[0]

    a_c = np.array([x[col_a(j)] for j in range(n)])
    alpha = np.array([x[col_al(j)] for j in range(n)])

    # ---------------- recover qdd ----------------
    # alpha_j - alpha_{j-1} - (ag_dot*gd + ab_dot*bd) = ag*gdd + ab*bdd  (least squares)
    qdd = np.zeros(model.nq)
    for k, j in enumerate(model.free_joints):
        w_par = w[j - 1] if j > 0 else np.zeros(3)
        al_par = alpha[j - 1] if j > 0 else np.zeros(3)
        ag_dot = np.cross(w_par, ag[j])
        ab_dot = np.cross(w[j], ab[j])
        rhs = alpha[j] - al_par - ag_dot * rates[j, 0] - ab_dot * rates[j, 1]
        Bm = np.column_stack([ag[j], ab[j]])
        qdd[2 * k: 2 * k + 2] = np.linalg.lstsq(Bm, rhs, rcond=None)[0]

    # ---------------- base wrench on body 1 (about P_1) ----------------
    F_A = x[jf[0]].copy()
    if model.locked[0]:
        M_A = x[jm[0]].copy()
    else:
        M_A = x[jm[0]][0] * nax[0]
    M_A = M_A + tau_joint[0]          # include spring/damper torque of joint 1

    out = {"qdd": qdd, "F_A": F_A, "M_A": M_A, "F_B": None, "M_B": None,
           "a_c": a_c, "alpha": alpha, "singular": singular,
           "joint_force": np.array([x[s] for s in jf])}
    if clamp:
        out["F_B"] = x[cFB].copy()
        out["M_B"] = x[cMB].copy()
    return out


def forward_dynamics(model: ChainModel, q, qd) -> dict:
    """Accelerations and reactions.

    Returns dict: 'qdd' (nq,), 'F_A','M_A' (wrench of base on body 1, moment about P_1,
    spring torque of joint 1 included), 'F_B','M_B' (wrench of support B on body n,
    moment about the tip; None without clamp), plus diagnostics 'a_c','alpha',
    'singular'.
    """
    return _solve_maximal(model, q, qd, clamp=model.clamp_B)


# ----------------------------------------------------------------------------------
# 4. Generalized mass matrix and forces (chain WITHOUT the clamp)
# ----------------------------------------------------------------------------------
def mass_matrix(model: ChainModel, q) -> np.ndarray:
    """M(q): columns of M^{-1} = response of qdd to unit generalized torque pairs."""
    nq = model.nq
    qd0 = np.zeros(nq)
    base = _solve_maximal(model, q, qd0, clamp=False)["qdd"]
    Minv = np.zeros((nq, nq))
    for e in range(nq):
        tau = np.zeros(nq)
        tau[e] = 1.0
        Minv[:, e] = _solve_maximal(model, q, qd0, clamp=False, extra_gen_torque=tau)["qdd"] - base
    M = np.linalg.inv(Minv)
    return M   # not symmetrized on purpose: symmetry is a check of the formulation


def generalized_forces(model: ChainModel, q, qd) -> np.ndarray:
    """k(q,qd) such that M qdd = k (+ G^T lambda for the clamp): k = M @ qdd_free."""
    qdd0 = _solve_maximal(model, q, qd, clamp=False)["qdd"]
    return mass_matrix(model, q) @ qdd0


# ----------------------------------------------------------------------------------
# 5. Energy
# ----------------------------------------------------------------------------------
def energy(model: ChainModel, q, qd) -> float:
    """Kinetic + gravitational potential + joint spring energy (no centrifugal potential)."""
    kin = kinematics(model, q, qd)
    T = body_inertia(model)
    E = 0.0
    for j in range(model.n):
        Iw = kin["R"][j] @ T[j] @ kin["R"][j].T
        E += 0.5 * model.m[j] * kin["v"][j] @ kin["v"][j]          # translational
        E += 0.5 * kin["w"][j] @ Iw @ kin["w"][j]                  # rotational
        E += -model.m[j] * model.g_vec @ kin["c"][j]               # gravity
    ang = joint_angles(model, q)
    for j in model.free_joints:
        E += 0.5 * model.c[j] @ (ang[j] - model.rest[j]) ** 2      # springs
    return float(E)
