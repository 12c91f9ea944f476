"""Independent reference dynamics of a chain of rigid cylinders, in MAXIMAL coordinates.

Pure numpy.  Used by the tests to cross-check the Fortran implementation; it imports
nothing from ``pydriver``.  The formulation deliberately does NOT use a joint-space
recursion: every body carries its own 6 unknown accelerations (a_c, alpha), every joint
its own unknown reaction wrench, and the whole Newton-Euler + acceleration-constraint
system is solved at once.  Derivatives are exact: velocities, accelerations, joint axes,
the clamp Jacobian and its bias come from automatic differentiation (a truncated Taylor
``Jet`` class and the complex step) of one position-level kinematics routine, never from
finite differences and never from hand-derived joint-axis or bias formulas.

Conventions (SI units, angles in radians, all vectors in model-frame coordinates)
---------------------------------------------------------------------------------
* Body j (1..n): uniform solid cylinder, length L_j, radius R_j, mass m_j.  Body frame:
  origin at the joint point P_j, axis along local z, CM at (0,0,L/2), end at (0,0,L).
  Central inertia diag(Txx,Tyy,Tzz), Txx = Tyy = m(L^2+3R^2)/12, Tzz = m R^2/2.
* Active rotations Rz(a) = [[c,-s,0],[s,c,0],[0,0,1]], Ry(b) = [[c,0,s],[0,1,0],[-s,0,c]],
  Rx(a) = [[1,0,0],[0,c,-s],[0,s,c]].  R_j = R_{j-1} R_rel(q_j); R_0 = base rotation,
  P_1 = base point, P_{j+1} = P_j + R_j (0,0,L_j), tip = P_{n+1}.
* Joints (``ChainModel.joint``): 'zy' (thesis) R_rel = Rz(gamma) Ry(beta); 'xy' (Cardan)
  R_rel = Rx(phi) Ry(theta); 'xyz' R_rel = Rx(phi) Ry(theta) Rz(psi).  A locked joint keeps
  the thesis angles ``locked_angles`` (gamma, beta) through Rz Ry and has no coordinates.
  q lists the free joints' coordinates in body order.
* Supports: the base (support A: P_1, R_0) and the clamp (support B: p_B, R_B) each have a
  reference pose and an optional prescribed rigid motion T(t) = T_1 T_2 ... T_K, T_k(x) =
  Rot(u_k, theta_k(t)) (x - h_k) + h_k (hinge 1 carries hinges 2..K).
* Frames: ``hub=False`` the model frame is inertial.  ``hub=True`` it turns with the rotor
  (angle psi(t), speed Omega, acceleration Omega' about model z through ``rotor_centre``);
  positions and velocities are relative to it and the dynamics carry the frame terms.
* The legacy thesis field (``omega_rotor``, ``rotor_offset``) is kept exactly as before: a
  quasi-static centrifugal force m w^2 (c_x + o_x, c_y + o_y, 0) at every CM in an otherwise
  inertial model (no Coriolis, no couples); it is NOT mapped onto ``hub=True`` (that would add
  Coriolis forces and change k for the existing callers).
* Joint reaction (f_j, M_j): the wrench exerted by the PARENT (body j-1 or the base) on the
  CHILD (body j), force at P_j, M_j the whole moment about P_j transmitted by the joint,
  spring and damper torques included (so (F_A, M_A) = (f_1, M_1)).
* Clamp B: g = [P_{n+1} - p_B(t); 1/2 vee(E - E^T)], E = R_n R_B(t)^T, vee(M) = (M32, M13,
  M21).  Multipliers lambda act as the clamp wrench on body n: F_B = lambda[:3] at the tip,
  M_B = T^T lambda[3:], T = (tr(E) I - E)/2, so that G^T lambda is that wrench's
  generalized force.  Without ``clamp_position``/``clamp_rotation`` the clamp holds the pose
  the configuration q already has (legacy behaviour: the state is assumed consistent, and
  the acceleration rows reduce to "tip acceleration = 0, alpha_n = 0").

Maximal system (``_solve_maximal``)
-----------------------------------
Unknowns: (a_c, alpha) of every body, the joint accelerations qdd, the joint wrenches
(f_j, M_j) and the clamp multipliers.  Rows: Newton and Euler (about the CM) per body;
per joint the point coincidence a_P(child) = a_P(parent) (rigid-body acceleration formula)
and the relative rotation alpha_j - alpha_{j-1} = S_j qdd_j + (alpha_j - alpha_{j-1})|qdd=0,
with S_j the joint's world axes and the qdd = 0 part from the Taylor jet; per free
coordinate the joint power S_j^T M_j = Q_j (spring, damper, extra generalized torque); the
clamp rows G qdd = -bias written in body accelerations.  The system is square.

Solvability
-----------
The system is SINGULAR when the constraints are redundant, i.e. when the clamp's
constraint Jacobian loses rank: always when the clamp is active and the number of free
coordinates is < 6, and at kinematically singular configurations of the closed chain.  Then
the reactions are not unique (statically indeterminate); we fall back to lstsq
(minimum-norm solution) and set result['singular'] = True.  Without the clamp the system
is never singular (positive masses/inertias).
Example: 5 bodies, joints 1 AND 5 locked, gamma=(0,0,0,pi/2,pi/2),
beta=(pi/2,pi/2,pi/2,pi/2,-pi/2), clamp at the tip: the loop Jacobian has rank 5 < 6.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from math import factorial

import numpy as np

# Complex-step increment.  The complex step has no subtractive cancellation, so any h far
# below the scale of the arguments gives the derivative to round-off (Squire & Trapp 1998).
_CS_STEP = 1e-30


# ----------------------------------------------------------------------------------
# Automatic differentiation: truncated Taylor polynomials
# ----------------------------------------------------------------------------------
class Jet:
    """Truncated Taylor polynomial x(s) = sum_k c[k] s^k, k = 0..K, of an array quantity.

    Arithmetic on jets propagates the Taylor coefficients exactly (forward-mode automatic
    differentiation, Griewank & Walther 2008, ch. 13), so d^k x/ds^k = k! c[k] is exact to
    round-off.  Only what the kinematics need is implemented: +, -, * (elementwise), @, /
    by a constant, cross, sin, cos, indexing and transpose.

    Parameters
    ----------
    coeffs : array_like, shape (K+1, ...)
        Taylor coefficients, leading axis = power of s.
    """

    # numpy operators return NotImplemented for us, so ``ndarray @ Jet`` reaches
    # Jet.__rmatmul__; a numpy ufunc applied to a jet raises instead of silently building
    # an object array.
    __array_ufunc__ = None

    def __init__(self, coeffs):
        self.c = np.asarray(coeffs)

    @property
    def order(self) -> int:
        """Highest power K kept."""
        return self.c.shape[0] - 1

    @property
    def shape(self) -> tuple:
        """Shape of the quantity (without the Taylor axis)."""
        return self.c.shape[1:]

    def derivative(self, k: int) -> np.ndarray:
        """k-th derivative with respect to s at s = 0 (k! c[k])."""
        return factorial(k) * self.c[k]

    # Every operation works coefficient by coefficient, so numpy broadcasting acts on the
    # quantity's own axes and never on the Taylor axis.
    def __add__(self, o):
        if isinstance(o, Jet):
            return Jet(np.array([x + y for x, y in zip(self.c, o.c)]))
        z = np.zeros_like(np.asarray(o))
        return Jet(np.array([self.c[0] + o] + [x + z for x in self.c[1:]]))

    __radd__ = __add__

    def __neg__(self):
        return Jet(-self.c)

    def __sub__(self, o):
        return self + (-o)

    def __rsub__(self, o):
        return (-self) + o

    def __mul__(self, o):
        return _bilinear(np.multiply, self, o)

    def __rmul__(self, o):
        return _bilinear(np.multiply, o, self)

    def __matmul__(self, o):
        return _bilinear(np.matmul, self, o)

    def __rmatmul__(self, o):
        return _bilinear(np.matmul, o, self)

    def __truediv__(self, o):
        if isinstance(o, Jet):
            raise TypeError("division by a Jet is not needed and not implemented")
        return Jet(np.stack([x / o for x in self.c]))

    def __getitem__(self, idx):
        idx = idx if isinstance(idx, tuple) else (idx,)
        return Jet(self.c[(slice(None),) + idx])

    @property
    def T(self):
        """Transpose of a matrix-valued jet."""
        return Jet(np.swapaxes(self.c, -1, -2))

    def sincos(self):
        """(sin x, cos x) by the Taylor recurrences k s_k = sum_j j u_j c_{k-j},
        k c_k = -sum_j j u_j s_{k-j}."""
        u = self.c
        s = [np.sin(u[0])]
        c = [np.cos(u[0])]
        for k in range(1, u.shape[0]):
            s.append(sum(j * u[j] * c[k - j] for j in range(1, k + 1)) / k)
            c.append(-sum(j * u[j] * s[k - j] for j in range(1, k + 1)) / k)
        return Jet(np.stack(s)), Jet(np.stack(c))


def _bilinear(op, a, b):
    """Taylor coefficients of op(a, b) for a bilinear op (Cauchy product)."""
    if isinstance(a, Jet) and isinstance(b, Jet):
        if a.order != b.order:
            raise ValueError("jets of different order")
        return Jet(np.array([sum(op(a.c[i], b.c[k - i]) for i in range(k + 1))
                             for k in range(a.order + 1)]))
    if isinstance(a, Jet):
        return Jet(np.array([op(x, b) for x in a.c]))
    return Jet(np.array([op(a, x) for x in b.c]))


def _order(items) -> int | None:
    """Order of the first jet among items (None if there is none)."""
    for x in items:
        if isinstance(x, Jet):
            return x.order
    return None


def _lift(x, order: int) -> Jet:
    """A constant as a jet of the given order."""
    if isinstance(x, Jet):
        return x
    x = np.asarray(x)
    out = np.zeros((order + 1,) + x.shape, dtype=np.result_type(x, float))
    out[0] = x
    return Jet(out)


def _stack(items, axis: int = 0):
    """np.stack for a mix of arrays, scalars and jets."""
    k = _order(items)
    if k is None:
        return np.stack([np.asarray(x) for x in items], axis=axis)
    lifted = [_lift(x, k) for x in items]
    return Jet(np.stack([x.c for x in lifted], axis=axis + 1 if axis >= 0 else axis))


def _sin(x):
    return x.sincos()[0] if isinstance(x, Jet) else np.sin(x)


def _cos(x):
    return x.sincos()[1] if isinstance(x, Jet) else np.cos(x)


def _real(x):
    """Value used to pick a branch: real part of the s^0 coefficient."""
    return float(np.real(x.c[0] if isinstance(x, Jet) else x))


def _deriv(x, k: int):
    """k-th s-derivative of a jet; a constant has zero derivatives."""
    if isinstance(x, Jet):
        return x.derivative(k)
    return np.asarray(x) if k == 0 else np.zeros_like(np.asarray(x, float))


def _cross_array(a, b):
    """Cross product over the last axis; np.cross's axis handling costs more than the
    arithmetic for 3-vectors."""
    a, b = np.asarray(a), np.asarray(b)
    out = np.empty(np.broadcast_shapes(a.shape, b.shape), dtype=np.result_type(a, b))
    out[..., 0] = a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1]
    out[..., 1] = a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2]
    out[..., 2] = a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]
    return out


def cross(a, b):
    """Cross product of 3-vectors (arrays, complex arrays or jets)."""
    if isinstance(a, Jet) or isinstance(b, Jet):
        return _bilinear(_cross_array, a, b)
    return _cross_array(a, b)


def vee(M):
    """(M32, M13, M21) of a 3x3 matrix (array or jet)."""
    return _stack([M[2, 1], M[0, 2], M[1, 0]])


def vee_skew(M):
    """vee of the antisymmetric part of M: the exact angular-velocity extraction
    omega = vee(Rdot R^T) without relying on Rdot R^T being skew to round-off."""
    return vee(0.5 * (M - M.T))


# ----------------------------------------------------------------------------------
# Rotations (work on floats, complex numbers and jets)
# ----------------------------------------------------------------------------------
E_X = np.array([1.0, 0.0, 0.0])
E_Y = np.array([0.0, 1.0, 0.0])
E_Z = np.array([0.0, 0.0, 1.0])


def _elementary_array(c, s, i, k, axis):
    """Rotation about coordinate axis `axis`: [[c, -s], [s, c]] in rows/columns (i, k)."""
    R = np.zeros((3, 3), dtype=np.result_type(c, float))
    R[axis, axis] = 1.0
    R[i, i] = R[k, k] = c
    R[i, k], R[k, i] = -s, s
    return R


def _elementary_jet(c: Jet, s: Jet, i, k, axis):
    """Jet version of _elementary_array (coefficients filled directly, no lifting)."""
    R = np.zeros((c.order + 1, 3, 3), dtype=c.c.dtype)
    R[0, axis, axis] = 1.0
    R[:, i, i] = R[:, k, k] = c.c
    R[:, i, k], R[:, k, i] = -s.c, s.c
    return Jet(R)


def Rz(a):
    """Active rotation by a about z."""
    c, s = _cos(a), _sin(a)
    if not isinstance(a, Jet):
        return _elementary_array(c, s, 0, 1, 2)
    return _elementary_jet(c, s, 0, 1, 2)


def Ry(b):
    """Active rotation by b about y."""
    c, s = _cos(b), _sin(b)
    if not isinstance(b, Jet):
        return _elementary_array(c, s, 2, 0, 1)
    return _elementary_jet(c, s, 2, 0, 1)


def Rx(a):
    """Active rotation by a about x."""
    c, s = _cos(a), _sin(a)
    if not isinstance(a, Jet):
        return _elementary_array(c, s, 1, 2, 0)
    return _elementary_jet(c, s, 1, 2, 0)


def rot_axis(u, theta):
    """Rotation by theta about the unit axis u (Rodrigues: I + sin K + (1 - cos) K^2)."""
    K = skew(np.asarray(u, float))
    return np.eye(3) + _sin(theta) * K + (1.0 - _cos(theta)) * (K @ K)


def skew(v: np.ndarray) -> np.ndarray:
    """skew(v) @ x == cross(v, x)."""
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


JOINT_COORDS = {"zy": 2, "xy": 2, "xyz": 3}


def relative_rotation(joint: str, ang) -> np.ndarray:
    """R_rel of one free joint for its coordinates ang (floats, complex or jets)."""
    if joint == "zy":
        return Rz(ang[0]) @ Ry(ang[1])
    if joint == "xy":
        return Rx(ang[0]) @ Ry(ang[1])
    if joint == "xyz":
        return Rx(ang[0]) @ Ry(ang[1]) @ Rz(ang[2])
    raise ValueError(f"unknown joint {joint!r}")


def joint_axes_local(joint: str, ang) -> np.ndarray:
    """Columns vee(dR_rel/dq_k R_rel^T), k over the joint's coordinates, in the parent's
    frame: the relative angular velocity is (this) @ qdot.  Complex step of R_rel."""
    ang = np.asarray(ang, float)
    Rr = relative_rotation(joint, ang)
    cols = []
    for k in range(ang.size):
        a = ang.astype(complex)
        a[k] += 1j * _CS_STEP
        dR = relative_rotation(joint, a).imag / _CS_STEP
        cols.append(vee_skew(dR @ Rr.T))
    return np.column_stack(cols)


# ----------------------------------------------------------------------------------
# Model description
# ----------------------------------------------------------------------------------
@dataclass
class RotorSpeed:
    """Rotor speed profile; the rotor angle is psi(t) with psi(0) = 0.

    Parameters
    ----------
    omega : float
        Omega_0 [rad/s]: the constant speed, or the speed before the run-up.
    omega_end : float or None
        Omega_1 [rad/s] after the run-up; None (default) for a constant speed.
    t_start : float
        t0 [s], start of the run-up.
    duration : float
        T [s] (> 0), length of the run-up.  Omega = Omega_0 + (Omega_1 - Omega_0) s(tau),
        tau = clip((t - t0)/T, 0, 1), s(tau) = tau - sin(2 pi tau)/(2 pi).
    """

    omega: float = 0.0
    omega_end: float | None = None
    t_start: float = 0.0
    duration: float = 0.0

    def angle(self, t):
        """psi(t) [rad] for a float, complex or jet t (so its derivatives come by AD)."""
        if self.omega_end is None:
            return self.omega * t
        if self.duration <= 0.0:
            raise ValueError("RotorSpeed.duration must be > 0 for a run-up")
        d_om, t0, T = self.omega_end - self.omega, self.t_start, self.duration
        tr = _real(t)
        if tr < t0:
            return self.omega * t
        if tr <= t0 + T:
            tau = (t - t0) / T
            return (self.omega * t
                    + d_om * T * (0.5 * tau * tau + (_cos(2.0 * np.pi * tau) - 1.0) / (2.0 * np.pi) ** 2))
        return self.omega * t + d_om * T * 0.5 + d_om * (t - t0 - T)


def rotor_state(rotor: RotorSpeed | None, t: float) -> tuple[float, float, float]:
    """(psi, Omega, Omega') at time t, by a second-order jet of ``rotor.angle``."""
    if rotor is None:
        return 0.0, 0.0, 0.0
    p = rotor.angle(Jet(np.array([t, 1.0, 0.0])))
    p = _lift(p, 2)
    return float(p.derivative(0)), float(p.derivative(1)), float(p.derivative(2))


@dataclass
class AngleFunction:
    """Angle theta(t) [rad] of a prescribed hinge.

    Parameters
    ----------
    kind : {'constant', 'fourier', 'rotor'}
        'constant': theta = value.  'fourier': theta = a0 + sum_k c_k cos(k psi_b) +
        s_k sin(k psi_b) + amplitude sin(frequency t + phase), psi_b = psi(t) + azimuth0,
        with coefficients = (a0, c1, s1, c2, s2, ...).  'rotor': theta = psi(t) + offset.
    value : float
        Constant angle [rad].
    coefficients : tuple of float
        Fourier coefficients [rad] (a0, c1, s1, c2, s2, ...).
    azimuth0 : float
        Blade azimuth at psi = 0 [rad].
    amplitude, frequency, phase : float
        Extra term A [rad], w [rad/s], phi [rad].
    offset : float
        Offset of the 'rotor' angle [rad].
    """

    kind: str = "constant"
    value: float = 0.0
    coefficients: tuple = ()
    azimuth0: float = 0.0
    amplitude: float = 0.0
    frequency: float = 0.0
    phase: float = 0.0
    offset: float = 0.0

    def __call__(self, t, psi):
        """theta at time t (float, complex or jet), psi = rotor angle at t."""
        if self.kind == "constant":
            return self.value + 0.0 * t
        if self.kind == "rotor":
            return psi + self.offset
        if self.kind == "fourier":
            co = list(self.coefficients)
            if len(co) % 2 == 0:
                raise ValueError("fourier coefficients must be (a0, c1, s1, ..., ck, sk)")
            psi_b = psi + self.azimuth0
            th = co[0] + self.amplitude * _sin(self.frequency * t + self.phase)
            for k in range(1, len(co) // 2 + 1):
                th = th + co[2 * k - 1] * _cos(k * psi_b) + co[2 * k] * _sin(k * psi_b)
            return th
        raise ValueError(f"unknown angle function kind {self.kind!r}")


@dataclass
class Hinge:
    """One prescribed hinge: rotation by angle(t) about the unit axis through point, both
    given in the reference configuration (all angles 0).  Axis is normalised."""

    axis: np.ndarray
    point: np.ndarray
    angle: AngleFunction = field(default_factory=AngleFunction)

    def __post_init__(self):
        self.axis = np.asarray(self.axis, float).reshape(3)
        self.axis = self.axis / np.linalg.norm(self.axis)
        self.point = np.asarray(self.point, float).reshape(3)


@dataclass
class Drag:
    """Cross-flow drag: F_j = 1/2 rho cd_j (2 R_j) L_j |u_n| u_n at the CM.

    Parameters
    ----------
    rho : float
        Air density [kg/m^3].
    cd : array_like, shape (n,) or scalar
        Drag coefficient per body [-].
    V_inf : array_like, shape (3,)
        Inertial free stream [m/s] (in the hub frame the model sees Rz(psi)^T V_inf).
    """

    rho: float
    cd: np.ndarray
    V_inf: np.ndarray

    def __post_init__(self):
        self.cd = np.asarray(self.cd, float)
        self.V_inf = np.asarray(self.V_inf, float).reshape(3)


@dataclass
class Pulse:
    """Force [N] on the CM of body ``body`` (1-based, as in the decks) for
    t_start <= t < t_end [s]."""

    body: int
    force: np.ndarray
    t_start: float
    t_end: float

    def __post_init__(self):
        self.force = np.asarray(self.force, float).reshape(3)


@dataclass
class ChainModel:
    """A chain of n uniform cylinders; every field in SI units and radians.

    Parameters
    ----------
    L, R, m : array_like, shape (n,)
        Length [m], radius [m], mass [kg] per body.
    locked : array_like of bool, shape (n,)
        Locked (clamped) joints; they keep ``locked_angles`` and have no coordinates.
    locked_angles : array_like, shape (n, 2)
        Thesis angles (gamma, beta) [rad] of locked joints (Rz Ry whatever ``joint`` is).
    c, d, rest : array_like, shape (n, k)
        Spring stiffness [Nm/rad], damping [Nms/rad] and rest angle [rad] per joint
        coordinate, k = 2 ('zy', 'xy') or 3 ('xyz'); generalized force -c (q - rest) - d qd.
    g_vec : array_like, shape (3,)
        Gravity [m/s^2] in model coordinates.
    r_A : array_like, shape (3,)
        Reference base point P_1 [m].
    omega_rotor : float
        Legacy quasi-static thesis field [rad/s]: centrifugal m w^2 (c_xy + rotor_offset) at
        every CM, nothing else.  Must be 0 with ``hub=True``.
    rotor_offset : array_like, shape (2,)
        Legacy field: model origin relative to the rotor centre, x and y [m].
    clamp_B : bool
        Clamp B (6 constraint rows) at the tip.
    joint : {'zy', 'xy', 'xyz'}
        Parametrisation of the free joints.
    hub : bool
        Equations written in the frame turning with the rotor (frame terms included).
    rotor : RotorSpeed or None
        Rotor speed profile (None: rotor at rest, psi = 0).
    rotor_centre : array_like, shape (3,)
        Point c [m] on the rotor axis (model z direction).
    body_couples : bool
        With ``hub=True``: False leaves the bodies' rotational inertia out of the frame
        terms (Euler's equation in w_rel, d/dt|rel w_rel); Newton keeps the full acceleration.
    base_rotation : array_like, shape (3, 3)
        Reference base rotation R_0.
    base_hinges, clamp_hinges : list of Hinge
        Prescribed rigid motions of support A and support B (empty: fixed).
    clamp_position : array_like, shape (3,) or None
        Reference clamp point p_B0 [m].  None (with ``clamp_rotation`` None): the clamp
        holds the current tip pose (legacy).
    clamp_rotation : array_like, shape (3, 3) or None
        Reference clamp rotation R_B0.
    drag : Drag or None
        Cross-flow drag.
    pulse : Pulse or None
        Force pulse on one body's CM.
    tip_force : array_like, shape (3,)
        Constant force [N] at the tip P_{n+1}.
    """

    L: np.ndarray
    R: np.ndarray
    m: np.ndarray
    locked: np.ndarray                      # bool (n,)
    locked_angles: np.ndarray               # (n,2) gamma,beta used where locked
    c: np.ndarray                           # (n,k) spring stiffness per coordinate
    d: np.ndarray                           # (n,k) damping per coordinate
    rest: np.ndarray                        # (n,k) rest angles per coordinate
    g_vec: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, -9.81]))
    r_A: np.ndarray = field(default_factory=lambda: np.zeros(3))
    omega_rotor: float = 0.0
    rotor_offset: np.ndarray = field(default_factory=lambda: np.zeros(2))
    clamp_B: bool = False
    joint: str = "zy"
    hub: bool = False
    rotor: RotorSpeed | None = None
    rotor_centre: np.ndarray = field(default_factory=lambda: np.zeros(3))
    body_couples: bool = True
    base_rotation: np.ndarray = field(default_factory=lambda: np.eye(3))
    base_hinges: list = field(default_factory=list)
    clamp_position: np.ndarray | None = None
    clamp_rotation: np.ndarray | None = None
    clamp_hinges: list = field(default_factory=list)
    drag: Drag | None = None
    pulse: Pulse | None = None
    tip_force: np.ndarray = field(default_factory=lambda: np.zeros(3))

    def __post_init__(self):
        if self.joint not in JOINT_COORDS:
            raise ValueError(f"joint must be one of {sorted(JOINT_COORDS)}, not {self.joint!r}")
        self.L = np.asarray(self.L, float)
        self.R = np.asarray(self.R, float)
        self.m = np.asarray(self.m, float)
        n, k = self.L.size, JOINT_COORDS[self.joint]
        self.locked = np.asarray(self.locked, bool).reshape(n)
        self.locked_angles = np.asarray(self.locked_angles, float).reshape(n, 2)
        self.c = np.asarray(self.c, float).reshape(n, k)
        self.d = np.asarray(self.d, float).reshape(n, k)
        self.rest = np.asarray(self.rest, float).reshape(n, k)
        self.g_vec = np.asarray(self.g_vec, float).reshape(3)
        self.r_A = np.asarray(self.r_A, float).reshape(3)
        self.rotor_offset = np.asarray(self.rotor_offset, float).reshape(2)
        self.rotor_centre = np.asarray(self.rotor_centre, float).reshape(3)
        self.base_rotation = np.asarray(self.base_rotation, float).reshape(3, 3)
        self.tip_force = np.asarray(self.tip_force, float).reshape(3)
        if (self.clamp_position is None) != (self.clamp_rotation is None):
            raise ValueError("give both clamp_position and clamp_rotation, or neither")
        if self.clamp_position is not None:
            self.clamp_position = np.asarray(self.clamp_position, float).reshape(3)
            self.clamp_rotation = np.asarray(self.clamp_rotation, float).reshape(3, 3)
        elif self.clamp_hinges:
            raise ValueError("clamp_hinges need clamp_position and clamp_rotation")
        if self.hub and self.omega_rotor != 0.0:
            raise ValueError("the legacy omega_rotor field and hub=True exclude each other")
        if self.drag is not None:
            self.drag.cd = np.broadcast_to(self.drag.cd, (n,)).astype(float)
        if self.pulse is not None and not 1 <= self.pulse.body <= n:
            raise ValueError(f"pulse.body must be 1..{n}")

    @property
    def n(self) -> int:
        """Number of bodies."""
        return self.L.size

    @property
    def ncoord(self) -> int:
        """Coordinates per free joint."""
        return JOINT_COORDS[self.joint]

    @property
    def free_joints(self) -> list[int]:
        """0-based indices of free joints, in coordinate order."""
        return [j for j in range(self.n) if not self.locked[j]]

    @property
    def nq(self) -> int:
        """Number of coordinates."""
        return self.ncoord * len(self.free_joints)

    def coords(self, j: int) -> slice:
        """Slice of q belonging to (free) joint j (0-based)."""
        k = self.free_joints.index(j)
        return slice(self.ncoord * k, self.ncoord * (k + 1))


# ----------------------------------------------------------------------------------
# Small helpers
# ----------------------------------------------------------------------------------
def body_inertia(model: ChainModel) -> np.ndarray:
    """(n,3,3) central inertia tensors in body frames (solid uniform cylinder)."""
    T = np.zeros((model.n, 3, 3))
    for j in range(model.n):
        m, L, R = model.m[j], model.L[j], model.R[j]
        txx = m * (L**2 + 3.0 * R**2) / 12.0
        T[j] = np.diag([txx, txx, 0.5 * m * R**2])
    return T


def joint_angles(model: ChainModel, q: np.ndarray) -> np.ndarray:
    """(n,k) array of joint coordinates: q for free joints; locked rows hold
    ``locked_angles`` (thesis gamma, beta) for 'zy' and NaN otherwise."""
    q = np.asarray(q, float).reshape(-1)
    if q.size != model.nq:
        raise ValueError(f"q has size {q.size}, expected {model.nq}")
    if model.joint == "zy":
        ang = model.locked_angles.copy()
    else:
        ang = np.full((model.n, model.ncoord), np.nan)
    for j in model.free_joints:
        ang[j] = q[model.coords(j)]
    return ang


def joint_rates(model: ChainModel, qd: np.ndarray) -> np.ndarray:
    """(n,k) array of joint rates; zero for locked joints."""
    qd = np.asarray(qd, float).reshape(-1)
    if qd.size != model.nq:
        raise ValueError(f"qd has size {qd.size}, expected {model.nq}")
    rates = np.zeros((model.n, model.ncoord))
    for j in model.free_joints:
        rates[j] = qd[model.coords(j)]
    return rates


# ----------------------------------------------------------------------------------
# 1. Position kinematics, written once for floats, complex numbers and jets
# ----------------------------------------------------------------------------------
def _value(x):
    """Real value of a float, complex number or jet (arrays elementwise)."""
    return np.real(x.c[0] if isinstance(x, Jet) else x)


def _support_pose(model: ChainModel, hinges, p_ref, R_ref, t):
    """Pose (p, R) of a support moved by T(t) = T_1 T_2 ... T_K from its reference pose.

    T_K acts first, so hinge 1 carries hinges 2..K with it; each T_k rotates about its
    axis through its point as given in the reference configuration.
    """
    p, R = p_ref, R_ref
    if hinges:
        psi = model.rotor.angle(t) if model.rotor is not None else 0.0 * t
        for h in reversed(hinges):
            rot = rot_axis(h.axis, h.angle(t, psi))
            p = rot @ (p - h.point) + h.point
            R = rot @ R
    return p, R


def _poses(model: ChainModel, q, t) -> dict:
    """Base pose, body rotations, joint points and CMs at (q, t).

    q (nq,) and t may be floats, complex numbers (complex step) or jets (Taylor AD); the
    results are of the same kind.  Lists: 'R' (n), 'P' (n+1, P[n] = tip), 'C' (n).
    """
    P1, R0 = _support_pose(model, model.base_hinges, model.r_A, model.base_rotation, t)
    Rs, P, C = [], [P1], []
    R_par = R0
    for j in range(model.n):
        if model.locked[j]:
            Rrel = Rz(model.locked_angles[j, 0]) @ Ry(model.locked_angles[j, 1])
        else:
            sl = model.coords(j)
            Rrel = relative_rotation(model.joint, [q[i] for i in range(sl.start, sl.stop)])
        Rj = R_par @ Rrel
        Rs.append(Rj)
        C.append(P[j] + Rj @ np.array([0.0, 0.0, 0.5 * model.L[j]]))
        P.append(P[j] + Rj @ np.array([0.0, 0.0, model.L[j]]))
        R_par = Rj
    return {"R0": R0, "R": Rs, "P": P, "C": C}


def _clamp_target(model: ChainModel, q, t):
    """(p_B, R_B) at t.  Legacy model (no clamp_position): the pose of the real
    configuration, frozen (no derivatives)."""
    if model.clamp_position is None:
        pose = _poses(model, _value(q), float(_value(t)))
        return pose["P"][-1], pose["R"][-1]
    return _support_pose(model, model.clamp_hinges, model.clamp_position,
                         model.clamp_rotation, t)


def _clamp_g(pose: dict, target) -> np.ndarray:
    """g = [P_tip - p_B; 1/2 vee(E - E^T)], E = R_n R_B^T (arrays, complex or jets)."""
    p_B, R_B = target
    gp = pose["P"][-1] - p_B
    E = pose["R"][-1] @ R_B.T
    gr = 0.5 * vee(E - E.T)
    return _stack([gp[0], gp[1], gp[2], gr[0], gr[1], gr[2]])


def _t_matrix(R_n: np.ndarray, R_B: np.ndarray) -> np.ndarray:
    """T = (tr(E) I - E)/2, E = R_n R_B^T: d/dt g_rot = T w_n - T^T w_B."""
    E = R_n @ R_B.T
    return 0.5 * (np.trace(E) * np.eye(3) - E)


def _motion(model: ChainModel, q, v, qdd, t: float, clamp: bool = False) -> dict:
    """Positions, velocities and accelerations (relative to the model frame) at
    (q, v, qdd, t), from ONE second-order jet of the position kinematics along the path
    s -> (q + s v + s^2 qdd/2, t + s).  Exact to round-off: d/ds and d^2/ds^2 at s = 0 are
    the velocity and the acceleration.

    Angular velocity w = vee(Rdot R^T) and acceleration alpha = vee(Rddot R^T) (the
    symmetric part Rdot Rdot^T of d/dt(Rdot R^T) drops out of vee's antisymmetric part).
    """
    q = np.asarray(q, float)
    qj = Jet(np.stack([q, np.asarray(v, float), 0.5 * np.asarray(qdd, float)]))
    tj = Jet(np.array([float(t), 1.0, 0.0]))
    pose = _poses(model, qj, tj)

    def derivs(x):
        return _deriv(x, 0), _deriv(x, 1), _deriv(x, 2)

    def angular(Rx_):
        R, Rd, Rdd = derivs(Rx_)
        return R, vee_skew(Rd @ R.T), vee_skew(Rdd @ R.T)

    n = model.n
    out = {k: np.zeros((n, 3)) for k in ("C", "vC", "aC", "w", "alpha")}
    out["R"] = np.zeros((n, 3, 3))
    out.update(P=np.zeros((n + 1, 3)), vP=np.zeros((n + 1, 3)), aP=np.zeros((n + 1, 3)))
    for j in range(n):
        out["R"][j], out["w"][j], out["alpha"][j] = angular(pose["R"][j])
        out["C"][j], out["vC"][j], out["aC"][j] = derivs(pose["C"][j])
    for j in range(n + 1):
        out["P"][j], out["vP"][j], out["aP"][j] = derivs(pose["P"][j])
    out["R0"], out["w0"], out["alpha0"] = angular(pose["R0"])
    if clamp:
        target = _clamp_target(model, qj, tj)
        g = _clamp_g(pose, target)
        out["g"], out["g_dot"], out["g_ddot"] = derivs(g)
        out["R_B"] = _deriv(target[1], 0)
        out["T"] = _t_matrix(out["R"][-1], out["R_B"])
    return out


def _joint_axes_world(model: ChainModel, q, R: np.ndarray, R0: np.ndarray) -> list:
    """World joint axes S_j (3, k) per joint (None for locked joints): relative angular
    velocity w_j - w_{j-1} = S_j qd_j.  From the complex step of R_rel."""
    q = np.asarray(q, float)
    axes = []
    for j in range(model.n):
        if model.locked[j]:
            axes.append(None)
            continue
        R_par = R0 if j == 0 else R[j - 1]
        axes.append(R_par @ joint_axes_local(model.joint, q[model.coords(j)]))
    return axes


def _partial_velocities(model: ChainModel, q, t: float):
    """Partial velocities by complex step of the positions in q at fixed t:
    JC (n,3,nq) of the CMs, Jw (n,3,nq) angular, Jtip (3,nq) of the tip."""
    q = np.asarray(q, float)
    n, nq = model.n, model.nq
    base = _poses(model, q, t)
    JC, Jw, Jtip = np.zeros((n, 3, nq)), np.zeros((n, 3, nq)), np.zeros((3, nq))
    for k in range(nq):
        qc = q.astype(complex)
        qc[k] += 1j * _CS_STEP
        pc = _poses(model, qc, t)
        for j in range(n):
            JC[j, :, k] = pc["C"][j].imag / _CS_STEP
            Jw[j, :, k] = vee_skew(pc["R"][j].imag / _CS_STEP @ base["R"][j].T)
        Jtip[:, k] = pc["P"][-1].imag / _CS_STEP
    return JC, Jw, Jtip


def kinematics(model: ChainModel, q, qd=None, t: float = 0.0, qdd=None) -> dict:
    """Positions, orientations and (with qd) velocities and accelerations of every body.

    Parameters
    ----------
    model : ChainModel
    q : array_like, shape (nq,)
        Coordinates [rad].
    qd : array_like, shape (nq,), optional
        Rates [rad/s].
    t : float
        Time [s] (moving supports).
    qdd : array_like, shape (nq,), optional
        Accelerations [rad/s^2] (default 0: the velocity-product accelerations).

    Returns
    -------
    dict
        'R' (n,3,3) model-from-body rotations, 'P' (n+1,3) joint points (P[n] = tip),
        'c' (n,3) centres of mass, 'R0' base rotation, 'axes' (n,3,k) world joint axes
        (zero for locked joints); for 'zy' also the legacy 'a_gamma' = R_{j-1} e_z,
        'a_beta' = R_j e_y, 'n_axis' = a_gamma x a_beta.  With qd: 'w' (n,3) angular
        velocities, 'v' (n,3) CM velocities, 'vP' (n+1,3), 'rates' (n,k), 'a' (n,3) CM
        accelerations, 'alpha' (n,3), 'aP' (n+1,3); all relative to the model frame.
    """
    q = np.asarray(q, float).reshape(-1)
    if q.size != model.nq:
        raise ValueError(f"q has size {q.size}, expected {model.nq}")
    pose = _poses(model, q, t)
    Rs = np.array(pose["R"])
    R0 = np.asarray(pose["R0"], float)
    axes_list = _joint_axes_world(model, q, Rs, R0)
    axes = np.zeros((model.n, 3, model.ncoord))
    for j, a in enumerate(axes_list):
        if a is not None:
            axes[j] = a
    out = {"R": Rs, "P": np.array(pose["P"]), "c": np.array(pose["C"]), "R0": R0, "axes": axes}
    if model.joint == "zy":
        R_par = np.concatenate([R0[None], Rs[:-1]])
        ag, ab = R_par @ E_Z, Rs @ E_Y
        out.update(a_gamma=ag, a_beta=ab, n_axis=cross(ag, ab))
    if qd is None:
        return out
    qdd = np.zeros(model.nq) if qdd is None else qdd
    st = _motion(model, q, qd, qdd, t)
    out.update(w=st["w"], v=st["vC"], vP=st["vP"], rates=joint_rates(model, qd),
               a=st["aC"], alpha=st["alpha"], aP=st["aP"])
    return out


# ----------------------------------------------------------------------------------
# 2. Clamp constraint and its exact derivatives
# ----------------------------------------------------------------------------------
def constraint(model: ChainModel, q, t: float = 0.0) -> np.ndarray:
    """Clamp residual g(q, t) = [P_{n+1} - p_B(t); 1/2 vee(E - E^T)], E = R_n R_B(t)^T.

    Parameters
    ----------
    model : ChainModel
    q : array_like, shape (nq,)
        Coordinates [rad].
    t : float
        Time [s] (moving clamp).

    Returns
    -------
    ndarray, shape (6,)
        Position rows [m], rotation rows [-]; shape (0,) without the clamp.  A legacy
        model (no clamp_position) gives zeros: its clamp holds the current pose.
    """
    if not model.clamp_B:
        return np.zeros(0)
    q = np.asarray(q, float)
    return np.asarray(_clamp_g(_poses(model, q, t), _clamp_target(model, q, t)), float)


def constraint_jacobian(model: ChainModel, q, t: float = 0.0) -> np.ndarray:
    """Constraint Jacobian G = dg/dq by the complex step (exact to round-off).

    Parameters
    ----------
    model : ChainModel
    q : array_like, shape (nq,)
        Coordinates [rad].
    t : float
        Time [s].

    Returns
    -------
    ndarray, shape (6, nq)
        G ([m/rad], [1/rad]); shape (0, nq) without the clamp.
    """
    if not model.clamp_B:
        return np.zeros((0, model.nq))
    q = np.asarray(q, float)
    target = _clamp_target(model, q, t)          # real: a legacy target must stay frozen
    G = np.zeros((6, model.nq))
    for k in range(model.nq):
        qc = q.astype(complex)
        qc[k] += 1j * _CS_STEP
        G[:, k] = np.imag(_clamp_g(_poses(model, qc, t), target)) / _CS_STEP
    return G


def constraint_velocity(model: ChainModel, q, v, t: float = 0.0) -> np.ndarray:
    """Constraint velocity G v + g_t = d/ds g(q + s v, t + s) at s = 0, by the Taylor jet.

    Parameters
    ----------
    model : ChainModel
    q, v : array_like, shape (nq,)
        Coordinates [rad] and rates [rad/s].
    t : float
        Time [s].

    Returns
    -------
    ndarray, shape (6,)
        [m/s], [1/s]; shape (0,) without the clamp.
    """
    if not model.clamp_B:
        return np.zeros(0)
    return _motion(model, q, v, np.zeros(model.nq), t, clamp=True)["g_dot"]


def constraint_bias(model: ChainModel, q, v, t: float = 0.0) -> np.ndarray:
    """Acceleration bias d^2/ds^2 g(q + s v, t + s) at s = 0, by the Taylor jet.

    It is d^2 g/dt^2 at qdd = 0, so that d^2 g/dt^2 = G qdd + bias.

    Parameters
    ----------
    model : ChainModel
    q, v : array_like, shape (nq,)
        Coordinates [rad] and rates [rad/s].
    t : float
        Time [s].

    Returns
    -------
    ndarray, shape (6,)
        [m/s^2], [1/s^2]; shape (0,) without the clamp.
    """
    if not model.clamp_B:
        return np.zeros(0)
    return _motion(model, q, v, np.zeros(model.nq), t, clamp=True)["g_ddot"]


# ----------------------------------------------------------------------------------
# 3. Loads and frame terms
# ----------------------------------------------------------------------------------
def _per_coordinate(model: ChainModel, arr: np.ndarray) -> np.ndarray:
    """(n,k) per-joint parameters -> (nq,) over the free joints' coordinates."""
    if not model.free_joints:
        return np.zeros(0)
    return np.concatenate([arr[j] for j in model.free_joints])


def _spring_damper(model: ChainModel, q, qd) -> np.ndarray:
    """Generalized joint forces -c (q - rest) - d qd, shape (nq,)."""
    c, d, rest = (_per_coordinate(model, a) for a in (model.c, model.d, model.rest))
    return -c * (np.asarray(q, float) - rest) - d * np.asarray(qd, float)


def _body_forces(model: ChainModel, st: dict, t: float) -> np.ndarray:
    """Applied forces at the CMs, shape (n,3): gravity, legacy field, drag, pulse."""
    F = model.m[:, None] * model.g_vec[None, :]
    if model.omega_rotor != 0.0:
        # Legacy quasi-static thesis field (section 5.5): centrifugal force only.
        w2 = model.omega_rotor**2
        F[:, :2] += model.m[:, None] * w2 * (st["C"][:, :2] + model.rotor_offset[None, :])
    if model.drag is not None:
        psi, Om, _ = rotor_state(model.rotor, t)
        if model.hub:
            V = Rz(psi).T @ model.drag.V_inf
            v_abs = st["vC"] + cross(Om * E_Z, st["C"] - model.rotor_centre)
        else:
            V = model.drag.V_inf
            v_abs = st["vC"]
        for j in range(model.n):
            e = st["R"][j] @ E_Z
            u = V - v_abs[j]
            un = u - (u @ e) * e
            F[j] += (0.5 * model.drag.rho * model.drag.cd[j] * 2.0 * model.R[j] * model.L[j]
                     * np.linalg.norm(un) * un)
    p = model.pulse
    if p is not None and p.t_start <= t < p.t_end:
        F[p.body - 1] += p.force
    return F


def _world_inertia(model: ChainModel, R: np.ndarray) -> np.ndarray:
    """(n,3,3) central inertia tensors in model coordinates."""
    return R @ body_inertia(model) @ np.swapaxes(R, 1, 2)


def _frame_terms(model: ChainModel, st: dict, Iw: np.ndarray, t: float):
    """Velocity and frame terms of Newton and Euler.

    Returns (a_fr, e_fr), both (n,3), such that the equations read
    m (a_rel + a_fr) = F and Iw alpha_rel + e_fr = M (M about the CM).
    Hub frame: a_abs = a_rel + 2 W x v + W' x r + W x (W x r), r = C - c, and
    alpha_abs = alpha_rel + W' + W x w (W = Omega e_z), w_abs = w + W; with
    body_couples=False Euler keeps w, alpha_rel only.
    """
    w = st["w"]
    Iww = np.einsum("jab,jb->ja", Iw, w)
    if not model.hub:
        return np.zeros_like(w), cross(w, Iww)
    _, Om, Omd = rotor_state(model.rotor, t)
    W, Wd = Om * E_Z, Omd * E_Z
    r = st["C"] - model.rotor_centre
    a_fr = 2.0 * cross(W, st["vC"]) + cross(Wd, r) + cross(W, cross(W, r))
    if not model.body_couples:
        return a_fr, cross(w, Iww)
    wa = w + W
    e_fr = (np.einsum("jab,jb->ja", Iw, Wd + cross(W, w))
            + cross(wa, np.einsum("jab,jb->ja", Iw, wa)))
    return a_fr, e_fr


# ----------------------------------------------------------------------------------
# 4. Newton-Euler in maximal coordinates, solved as one linear system
# ----------------------------------------------------------------------------------
def _solve_maximal(model: ChainModel, q, qd, t: float = 0.0, clamp: bool | None = None,
                   extra_gen_torque=None) -> dict:
    """Assemble and solve the maximal-coordinate system (see the module docstring).

    extra_gen_torque: optional (nq,) generalized torques added to the springs'.
    """
    n, nq = model.n, model.nq
    clamp = model.clamp_B if clamp is None else clamp
    q = np.asarray(q, float).reshape(-1)
    qd = np.asarray(qd, float).reshape(-1)
    if q.size != nq or qd.size != nq:
        raise ValueError(f"q and qd must have size {nq}")
    st = _motion(model, q, qd, np.zeros(nq), t, clamp=clamp)
    Rs, P, C, w = st["R"], st["P"], st["C"], st["w"]
    Iw = _world_inertia(model, Rs)
    a_fr, e_fr = _frame_terms(model, st, Iw, t)
    F = _body_forces(model, st, t)
    Q = _spring_damper(model, q, qd)
    if extra_gen_torque is not None:
        Q = Q + np.asarray(extra_gen_torque, float)
    S = _joint_axes_world(model, q, Rs, st["R0"])

    # ---------------- unknown layout ----------------
    # body j: a_c (3), alpha (3); then qdd (nq); joint j: f (3), M (3); clamp lambda (6)
    def ca(j):
        return slice(6 * j, 6 * j + 3)

    def cal(j):
        return slice(6 * j + 3, 6 * j + 6)

    def cq(j):
        s = model.coords(j)
        return slice(6 * n + s.start, 6 * n + s.stop)

    def cf(j):
        return slice(6 * n + nq + 6 * j, 6 * n + nq + 6 * j + 3)

    def cm(j):
        return slice(6 * n + nq + 6 * j + 3, 6 * n + nq + 6 * j + 6)

    cl = slice(12 * n + nq, 12 * n + nq + 6)
    cl_p, cl_r = slice(cl.start, cl.start + 3), slice(cl.start + 3, cl.stop)
    nunk = 12 * n + nq + (6 if clamp else 0)
    A = np.zeros((nunk, nunk))
    b = np.zeros(nunk)
    I3 = np.eye(3)
    T = st["T"] if clamp else None

    # ---------------- body equations (rows 0 .. 6n-1) ----------------
    for j in range(n):
        rN, rE = slice(6 * j, 6 * j + 3), slice(6 * j + 3, 6 * j + 6)
        # Newton: m a_c - f_j + f_{j+1} [- F_B] = F - m a_fr
        A[rN, ca(j)] = model.m[j] * I3
        A[rN, cf(j)] = -I3
        b[rN] = F[j] - model.m[j] * a_fr[j]
        # Euler about the CM: Iw alpha - (P_j - C) x f_j - M_j + (P_{j+1} - C) x f_{j+1}
        #                     + M_{j+1} [- (P_tip - C) x F_B - T^T lambda_rot] = -e_fr
        A[rE, cal(j)] = Iw[j]
        A[rE, cf(j)] = -skew(P[j] - C[j])
        A[rE, cm(j)] = -I3
        b[rE] = -e_fr[j]
        if j + 1 < n:
            A[rN, cf(j + 1)] = I3
            A[rE, cf(j + 1)] = skew(P[j + 1] - C[j])
            A[rE, cm(j + 1)] = I3
        else:
            b[rN] += model.tip_force
            b[rE] += cross(P[n] - C[j], model.tip_force)
            if clamp:
                A[rN, cl_p] = -I3
                A[rE, cl_p] = -skew(P[n] - C[j])
                A[rE, cl_r] = -T.T

    # ---------------- joint rows (rows 6n .. 12n-1) ----------------
    def centripetal(jb, point):
        r = point - C[jb]
        return cross(w[jb], cross(w[jb], r))

    for j in range(n):
        rP, rR = slice(6 * n + 6 * j, 6 * n + 6 * j + 3), slice(6 * n + 6 * j + 3, 6 * n + 6 * j + 6)
        # point P_j: a_c + alpha x r + w x (w x r) equal on child and parent (base: the
        # prescribed acceleration of P_1 from the jet of the support motion)
        A[rP, ca(j)] = I3
        A[rP, cal(j)] = -skew(P[j] - C[j])
        b[rP] = -centripetal(j, P[j])
        # rotation: alpha_j - alpha_{j-1} - S_j qdd_j = (alpha_j - alpha_{j-1}) at qdd = 0
        A[rR, cal(j)] = I3
        if j > 0:
            A[rP, ca(j - 1)] = -I3
            A[rP, cal(j - 1)] = skew(P[j] - C[j - 1])
            b[rP] += centripetal(j - 1, P[j])
            A[rR, cal(j - 1)] = -I3
            b[rR] = st["alpha"][j] - st["alpha"][j - 1]
        else:
            b[rP] += st["aP"][0]
            b[rR] = st["alpha"][0]
        if S[j] is not None:
            A[rR, cq(j)] = -S[j]
            # joint power: the joint moment does power Q on the joint's own rates
            sj = model.coords(j)
            rows = slice(12 * n + sj.start, 12 * n + sj.stop)
            A[rows, cm(j)] = S[j].T
            b[rows] = Q[model.coords(j)]

    # ---------------- clamp rows: G qdd + bias = 0 in body accelerations ----------------
    if clamp:
        r0 = 12 * n + nq
        rp, rr = slice(r0, r0 + 3), slice(r0 + 3, r0 + 6)
        # tip: G_pos qdd = a_tip - a_tip(qdd=0), a_tip = a_c + alpha x r + w x (w x r)
        A[rp, ca(n - 1)] = I3
        A[rp, cal(n - 1)] = -skew(P[n] - C[n - 1])
        b[rp] = st["aP"][n] - centripetal(n - 1, P[n]) - st["g_ddot"][:3]
        # rotation: G_rot qdd = T (alpha_n - alpha_n(qdd=0))
        A[rr, cal(n - 1)] = T
        b[rr] = T @ st["alpha"][n - 1] - st["g_ddot"][3:]

    # ---------------- solve ----------------
    singular = False
    try:
        x = np.linalg.solve(A, b)
        # cond > 1e13: the reactions are undetermined to more than 1e-3 relative in
        # double precision, i.e. the constraints are redundant (see Solvability).
        if not np.all(np.isfinite(x)) or np.linalg.cond(A) > 1e13:
            raise np.linalg.LinAlgError
    except np.linalg.LinAlgError:
        singular = True
        x = np.linalg.lstsq(A, b, rcond=None)[0]

    out = {"vdot": x[6 * n: 6 * n + nq].copy(),
           "a_c": np.array([x[ca(j)] for j in range(n)]),
           "alpha": np.array([x[cal(j)] for j in range(n)]),
           "joint_force": np.array([x[cf(j)] for j in range(n)]),
           "joint_moment": np.array([x[cm(j)] for j in range(n)]),
           "F_A": x[cf(0)].copy(), "M_A": x[cm(0)].copy(), "singular": singular}
    if clamp:
        lam = x[cl].copy()
        out.update(lam=lam, F_B=lam[:3].copy(), M_B=T.T @ lam[3:])
    else:
        out.update(lam=np.zeros(0), F_B=model.tip_force.copy(), M_B=np.zeros(3))
    return out


def solve_accelerations(model: ChainModel, q, v, t: float = 0.0) -> dict:
    """Accelerations, multipliers and reactions from the maximal-coordinate system.

    The clamp enters at acceleration level, G vdot + bias = 0, exact at any state
    (consistent with g = 0, G v + g_t = 0 or not).

    Parameters
    ----------
    model : ChainModel
    q, v : array_like, shape (nq,)
        Coordinates [rad] and rates [rad/s].
    t : float
        Time [s].

    Returns
    -------
    dict
        'vdot' (nq,) [rad/s^2]; 'lam' (6,) clamp multipliers [N, Nm] ((0,) without clamp);
        'F_A', 'M_A' (3,) wrench of the base on body 1 [N, Nm], moment about P_1, joint-1
        springs included; 'F_B', 'M_B' (3,) wrench of support B on body n, moment about the
        tip (open chain: the applied tip force and zero); diagnostics 'a_c', 'alpha',
        'joint_force', 'joint_moment', 'singular'.
    """
    return _solve_maximal(model, q, v, t)


def forward_dynamics(model: ChainModel, q, qd, t: float = 0.0) -> dict:
    """Accelerations and reactions (legacy interface of ``solve_accelerations``).

    Returns dict: 'qdd' (nq,), 'F_A','M_A' (wrench of base on body 1, moment about P_1,
    spring torque of joint 1 included), 'F_B','M_B' (wrench of support B on body n,
    moment about the tip; None without clamp), plus 'lam' and diagnostics 'a_c', 'alpha',
    'singular'.
    """
    r = _solve_maximal(model, q, qd, t)
    r["qdd"] = r.pop("vdot")
    if not model.clamp_B:
        r["F_B"] = r["M_B"] = None
    return r


# ----------------------------------------------------------------------------------
# 5. Generalized mass matrix, forces and the virtual-power residual
# ----------------------------------------------------------------------------------
def mass_matrix(model: ChainModel, q, t: float = 0.0) -> np.ndarray:
    """Generalized mass matrix from the maximal system.

    Columns of M^{-1} are the responses of qdd to unit generalized torques (chain without
    the clamp).  Not symmetrised: symmetry is a check of the formulation.

    Parameters
    ----------
    model : ChainModel
    q : array_like, shape (nq,)
        Coordinates [rad].
    t : float
        Time [s] (moving supports change nothing in M but enter the solves).

    Returns
    -------
    ndarray, shape (nq, nq)
        M [kg m^2].
    """
    nq = model.nq
    qd0 = np.zeros(nq)
    base = _solve_maximal(model, q, qd0, t, clamp=False)["vdot"]
    Minv = np.zeros((nq, nq))
    for e in range(nq):
        tau = np.zeros(nq)
        tau[e] = 1.0
        Minv[:, e] = _solve_maximal(model, q, qd0, t, clamp=False, extra_gen_torque=tau)["vdot"] - base
    return np.linalg.inv(Minv)


def generalized_forces(model: ChainModel, q, qd, t: float = 0.0) -> np.ndarray:
    """Generalized forces k(q, qd, t) with M qdd = k (+ G^T lambda for the clamp).

    k = M qdd_free, qdd_free from the maximal system without the clamp.

    Parameters
    ----------
    model : ChainModel
    q, qd : array_like, shape (nq,)
        Coordinates [rad] and rates [rad/s].
    t : float
        Time [s].

    Returns
    -------
    ndarray, shape (nq,)
        k [Nm].
    """
    qdd0 = _solve_maximal(model, q, qd, t, clamp=False)["vdot"]
    return mass_matrix(model, q, t) @ qdd0


def residual(model: ChainModel, q, v, vdot, lam, t: float = 0.0) -> np.ndarray:
    """M vdot - k - G^T lambda from the bodies' Newton-Euler residual wrenches.

    Every body's residual force m a_abs - F (at the CM) and moment Iw alpha_abs +
    w_abs x Iw w_abs (about the CM) are mapped to the coordinates by virtual power with the
    partial velocities dC/dq_k, dw/dq_k (complex step); the tip force, the clamp wrench
    (F_B = lambda[:3] at the tip, M_B = T^T lambda[3:]) and the joint springs enter as
    applied loads.  No joint-space recursion.

    Parameters
    ----------
    model : ChainModel
    q, v, vdot : array_like, shape (nq,)
        Coordinates, rates, accelerations.
    lam : array_like, shape (6,) or (0,)
        Clamp multipliers [N, Nm] (ignored without the clamp).
    t : float
        Time [s].

    Returns
    -------
    ndarray, shape (nq,)
        Residual [Nm].
    """
    q = np.asarray(q, float).reshape(-1)
    n = model.n
    st = _motion(model, q, v, vdot, t, clamp=model.clamp_B)
    JC, Jw, Jtip = _partial_velocities(model, q, t)
    Iw = _world_inertia(model, st["R"])
    a_fr, e_fr = _frame_terms(model, st, Iw, t)
    F = _body_forces(model, st, t)
    res_F = model.m[:, None] * (st["aC"] + a_fr) - F
    res_M = np.einsum("jab,jb->ja", Iw, st["alpha"]) + e_fr
    res = np.einsum("jak,ja->k", JC, res_F) + np.einsum("jak,ja->k", Jw, res_M)
    res -= Jtip.T @ model.tip_force
    res -= _spring_damper(model, q, v)
    if model.clamp_B:
        lam = np.asarray(lam, float).reshape(6)
        res -= Jtip.T @ lam[:3] + Jw[n - 1].T @ (st["T"].T @ lam[3:])
    return res


# ----------------------------------------------------------------------------------
# 6. Energy
# ----------------------------------------------------------------------------------
def energy_parts(model: ChainModel, q, v, t: float = 0.0) -> dict:
    """Kinetic energy relative to the model frame and potential energy.

    kinetic = sum 1/2 m v_rel^2 + 1/2 w_rel . Iw w_rel; potential = springs
    1/2 c (q - rest)^2 - m g . C - F_tip . P_{n+1} + (hub frame) the centrifugal potential
    -1/2 sum [m |W x (C - c)|^2 + W . Iw W] (rotational part only with body_couples) at the
    current Omega + (legacy field) -1/2 m w^2 |C_xy + rotor_offset|^2.  With constant
    Omega, fixed supports and no dampers, drag or pulse, kinetic + potential (the Jacobi
    integral) is conserved.

    Parameters
    ----------
    model : ChainModel
    q, v : array_like, shape (nq,)
        Coordinates [rad] and rates [rad/s].
    t : float
        Time [s] (Omega(t) of the centrifugal potential, moving supports).

    Returns
    -------
    dict
        'kinetic', 'potential' [J].
    """
    q = np.asarray(q, float).reshape(-1)
    st = _motion(model, q, v, np.zeros(model.nq), t)
    Iw = _world_inertia(model, st["R"])
    kin = 0.5 * np.sum(model.m * np.sum(st["vC"] ** 2, axis=1))
    kin += 0.5 * np.einsum("ja,jab,jb->", st["w"], Iw, st["w"])
    pot = 0.5 * np.sum(_per_coordinate(model, model.c) * (q - _per_coordinate(model, model.rest)) ** 2)
    pot -= np.sum(model.m * (st["C"] @ model.g_vec))
    pot -= model.tip_force @ st["P"][-1]
    if model.hub:
        _, Om, _ = rotor_state(model.rotor, t)
        W = Om * E_Z
        r = st["C"] - model.rotor_centre
        pot -= 0.5 * np.sum(model.m * np.sum(cross(W, r) ** 2, axis=1))
        if model.body_couples:
            pot -= 0.5 * np.einsum("a,jab,b->", W, Iw, W)
    pot += _legacy_field_potential(model, st["C"])
    return {"kinetic": float(kin), "potential": float(pot)}


def _legacy_field_potential(model: ChainModel, C: np.ndarray) -> float:
    """Potential -1/2 m w^2 |C_xy + rotor_offset|^2 of the legacy quasi-static field."""
    return float(-0.5 * model.omega_rotor**2
                 * np.sum(model.m * np.sum((C[:, :2] + model.rotor_offset) ** 2, axis=1)))


def energy(model: ChainModel, q, qd, t: float = 0.0) -> float:
    """Total energy: kinetic + potential of ``energy_parts`` without the legacy field.

    The legacy quasi-static field's potential is left out, as it always was (the existing
    callers add -1/2 m w^2 r^2 themselves).

    Parameters
    ----------
    model : ChainModel
    q, qd : array_like, shape (nq,)
        Coordinates [rad] and rates [rad/s].
    t : float
        Time [s].

    Returns
    -------
    float
        Energy [J].
    """
    e = energy_parts(model, q, qd, t)
    C = kinematics(model, q, t=t)["c"]
    return e["kinetic"] + e["potential"] - _legacy_field_potential(model, C)


# ----------------------------------------------------------------------------------
# 7. The previous formulation, kept verbatim as a check of the new one
# ----------------------------------------------------------------------------------
# Hand-written joint axes (a_gamma, a_beta, n = a_gamma x a_beta), hand-written bias terms
# and reaction moments only along n: a different maximal-coordinate system for the same
# physics.  Valid only for legacy models ('zy', fixed supports, inertial frame, no drag,
# pulse or tip force); tests/test_reference_model.py checks that the new system agrees.
def _check_legacy(model: ChainModel) -> None:
    if (model.joint != "zy" or model.hub or model.base_hinges or model.clamp_position is not None
            or model.drag is not None or model.pulse is not None or np.any(model.tip_force != 0)
            or np.any(model.base_rotation != np.eye(3))):
        raise ValueError("the legacy formulation covers only the legacy model fields")


def _legacy_kinematics(model: ChainModel, q: np.ndarray, qd: np.ndarray | None = None) -> dict:
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


def _solve_maximal_legacy(model: ChainModel, q, qd, clamp: bool, extra_gen_torque=None) -> dict:
    """Assemble and solve the maximal-coordinate system.

    extra_gen_torque: optional (nq,) vector of additional generalized torques, applied
    as torque pairs along the joint axes (+axis on child, -axis on parent).
    """
    n = model.n
    kin = _legacy_kinematics(model, q, qd)
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


def _legacy_forward_dynamics(model: ChainModel, q, qd) -> dict:
    """Accelerations and reactions.

    Returns dict: 'qdd' (nq,), 'F_A','M_A' (wrench of base on body 1, moment about P_1,
    spring torque of joint 1 included), 'F_B','M_B' (wrench of support B on body n,
    moment about the tip; None without clamp), plus diagnostics 'a_c','alpha',
    'singular'.
    """
    _check_legacy(model)
    return _solve_maximal_legacy(model, q, qd, clamp=model.clamp_B)
