"""The one Python module of the driver that calls the compiled core's run API
(``pydriver._rotorcable``, f2py: ``src_fortran/api.f90``) and unpacks its positional results.
Everything else works with :class:`CoreModel` and :class:`CoreSession` and gets named numpy
arrays, records built here (:class:`Sample`, :class:`Wrenches`; the statistics by the names of
:data:`STATIC_STATS` ...) and exceptions back, and hands design parameters in as
:class:`SensitivityParameter` records.  The test and benchmark probes (``src_fortran/probes.f90``) are
:mod:`pydriver.core_probes`, which only the tests and benchmarks import; it unpacks their
results with the helpers here.

Every core routine that can fail returns a status: 0 ok; 1 bad input (with the input at fault
as ``group.key``), raised as :class:`~pydriver.errors.DeckError`; 2 a failed computation,
raised as :class:`~pydriver.errors.RunError`.  Freeing a model or a session cannot fail and
returns nothing.
"""

from __future__ import annotations

import contextlib
import ctypes
import ctypes.util
import enum
import os
from dataclasses import dataclass

import numpy as np

from pydriver import _rotorcable
from pydriver.errors import DeckError, RunError


class _FpeTrapped:
    """The core's routines with floating-point exceptions trapped while they run (SIGFPE on an
    invalid operation, a division by zero or an overflow), for the debug build's test suite
    (ROTORCABLE_FPE_TRAP=1, .ci/tests).  gfortran's -ffpe-trap only acts through a Fortran
    main program, which a Python extension has not; the traps are switched on for the call
    only, since numpy and matplotlib produce inf and NaN on purpose between calls."""

    _FLAGS = 0x01 | 0x04 | 0x08          # FE_INVALID | FE_DIVBYZERO | FE_OVERFLOW (x86-64 fenv.h)

    def __init__(self, module):
        self._module = module
        self._libm = ctypes.CDLL(ctypes.util.find_library("m"))

    def __getattr__(self, name):
        fn = getattr(self._module, name)

        def trapped(*args):
            self._libm.feclearexcept(self._FLAGS)
            self._libm.feenableexcept(self._FLAGS)
            try:
                return fn(*args)
            finally:
                self._libm.fedisableexcept(self._FLAGS)
        return trapped


def _trapped_if_asked(module):
    """``module``, or its routines with floating-point exceptions trapped when the environment
    asks for it (ROTORCABLE_FPE_TRAP=1: the debug build's test suite)."""
    return _FpeTrapped(module) if os.environ.get("ROTORCABLE_FPE_TRAP") == "1" else module


_api = _trapped_if_asked(_rotorcable.rotorcable_api)


class JointKind(enum.IntEnum):
    """The chain's joint kind (``&chain joint``: its name in lower case) as the core's integer
    code (src_fortran/api.f90, rc_model_new's ``joint_kind``: 1 thesis zy, 2 Cardan xy, 3
    Cardan xyz)."""

    ZY = 1
    XY = 2
    XYZ = 3


def _text(x) -> str:
    if isinstance(x, np.ndarray):
        x = x.tobytes()
    if isinstance(x, bytes):
        x = x.decode(errors="replace")
    return str(x).strip().strip("\x00").strip()


def _raise(deck: str, stat: int, key, msg, context: str = ""):
    if stat == 0:
        return
    msg = _text(msg)
    if context:
        msg = f"{context}: {msg}"
    key = _text(key)
    if stat == 1:
        group, _, name = key.partition(".")
        raise DeckError(deck, group, name, msg)
    raise RunError(f"deck '{deck}': {msg}")


#: The names of the statistics the core returns as an integer array, in its order
#: (src_fortran/api.f90): a static solve's, a time integration's, and an integration with
#: forward sensitivities (rotorcable_monodromy, rotorcable_parameter_sensitivity).
STATIC_STATS = ("newton_iterations", "residual_evals", "jacobian_evals", "line_search_cuts")
INTEGRATION_STATS = ("steps", "residual_evals", "jacobian_evals", "error_test_failures", "convergence_failures")
SENSITIVITY_STATS = INTEGRATION_STATS + ("sensitivity_residual_evals",)


def solver_stats(names: tuple, counts) -> dict:
    """The core's statistics array ``counts`` by name (``names``: one of :data:`STATIC_STATS`,
    :data:`INTEGRATION_STATS`, :data:`SENSITIVITY_STATS`), as the summaries report them."""
    return dict(zip(names, (int(x) for x in counts)))


class PartialKind(enum.IntEnum):
    """How the core forms a design parameter's explicit partial dF/dp from the rebuilt models at
    the fixed state.  The values are the core's ``loads_only`` codes (src_fortran/api.f90,
    rc_parameter_sensitivity and rc_probe_parameter_partial: 1 sets ``points%loads_only``, 2
    ``points%bodies_and_loads``, anything else neither)."""

    #: The rebuilt models' whole residuals.
    WHOLE_RESIDUALS = 0
    #: Their loads' generalized forces on this model's kinematics (they differ in loads only).
    LOADS_ONLY = 1
    #: Their Newton-Euler passes on this model's motion (they differ in bodies and loads).
    BODIES_AND_LOADS = 2


@dataclass(frozen=True)
class DifferencePoint:
    """One term of a parameter's difference: ``weight`` F(model at p + ``offset`` h) / h."""

    offset: float
    weight: float
    core: CoreModel | None      #: the rebuilt model's core; None: this model


@dataclass(frozen=True)
class SensitivityParameter:
    """A design parameter as the core's sensitivity integration takes it
    (:meth:`CoreModel.parameter_sensitivity`)."""

    step: float                 #: h of the differences
    scale: float                #: pbar > 0: the sensitivity's absolute tolerance is atol / pbar
    points: list                #: the :class:`DifferencePoint` terms of dF/dp
    partial: PartialKind = PartialKind.WHOLE_RESIDUALS
    changed_loads: list | None = None   #: per load slot, whether the parameter changes it (None: all)


@dataclass(frozen=True)
class Wrenches:
    """The supports' wrenches on the chain in the model frame: force [N] and moment [Nm] at
    clamp A and at support B (zero for an open chain), each (..., 3) with one row per sample."""

    force_a: np.ndarray
    moment_a: np.ndarray
    force_b: np.ndarray
    moment_b: np.ndarray

    @classmethod
    def from_flat(cls, w) -> Wrenches:
        """From the 12 values FA, MA, FB, MB on the last axis (the order of the core's and of
        :data:`pydriver.analyses.common.REACTION_NAMES`)."""
        w = np.asarray(w, float)
        return cls(w[..., 0:3], w[..., 3:6], w[..., 6:9], w[..., 9:12])

    def as_flat(self) -> np.ndarray:
        """The 12 values FA, MA, FB, MB on the last axis (:meth:`from_flat`'s order)."""
        return np.concatenate([self.force_a, self.moment_a, self.force_b, self.moment_b], axis=-1)

    def at(self, k) -> Wrenches:
        """The wrenches of sample(s) ``k``."""
        return Wrenches(self.force_a[k], self.moment_a[k], self.force_b[k], self.moment_b[k])


@dataclass(frozen=True)
class Sample:
    """The output quantities of nt states (:meth:`CoreModel.sample`, rc_sample), n bodies and
    nc constraints."""

    wrenches: Wrenches            #: the supports' wrenches on the chain, (nt, 3) each
    kinetic: np.ndarray           #: kinetic energy (nt) [J]
    potential: np.ndarray         #: potential energy (nt) [J]
    g_max: np.ndarray             #: largest constraint violation (nt) [m]
    angles: np.ndarray            #: thesis angles gamma, beta (2, n, nt) [rad]
    cm: np.ndarray                #: centres of mass (3, n, nt) [m]
    joints: np.ndarray            #: joint points (3, n + 1, nt) [m]
    axial: np.ndarray             #: axial force per joint (nt, n) [N]
    shear: np.ndarray             #: shear force per joint (nt, n) [N]
    bending: np.ndarray           #: bending moment per joint (nt, n) [Nm]
    torsion: np.ndarray           #: torsional moment per joint (nt, n) [Nm]
    bend_angle: np.ndarray        #: bend angle per joint (nt, n) [rad]
    moment_xy: np.ndarray         #: signed bending moment in the child's body axes (nt, 2, n) [Nm]
    bend_xy: np.ndarray           #: signed bend angle in the child's body axes (nt, 2, n) [rad]
    psi: np.ndarray               #: rotor azimuth (nt) [rad]
    lam: np.ndarray               #: constraint multipliers (nt, nc)
    support_velocities: np.ndarray  #: the supports' velocities A, B, 6 each (nt, 12)


def _ints(a) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.int32).reshape(-1)


def load_mask(changed: list) -> np.ndarray:
    """(load slots, parameters) int32 mask of the load slots each parameter changes, from a list
    with one entry per parameter: a sequence of flags, or None (all; a slot beyond the mask counts
    as changed in the core)."""
    nl = max([1] + [len(c) for c in changed if c is not None])
    mask = np.ones((nl, len(changed)), dtype=np.int32, order="F")
    for k, c in enumerate(changed):
        if c is not None:
            mask[:len(c), k] = np.asarray(c, bool)
    return mask


def _reals(a) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=float).reshape(-1)


def _parameter_arrays(params: dict) -> tuple:
    """A component's parameters ``{name: value}`` as the flat layout of its parameter block
    (src_fortran/parameter_block.f90), the one place it is built: the real arrays' names
    (blank-separated), sizes and values, then the same for the integer arrays.  A value is an
    integer array when its numpy kind is integer or bool (a body index, a hinge count), real
    otherwise.  A word (a ``str`` value: a choice such as the linear solver ``'chain'``) is the
    integer array of its ASCII codes, read back by ``get_word``.  Names are single words: the
    block splits them at blanks."""
    real_names, real_sizes, reals, int_names, int_sizes, ints = [], [], [], [], [], []
    for name, value in params.items():
        if not name or " " in name or len(name) > 32:
            raise ValueError(f"parameter name {name!r}: one word of at most 32 characters")
        if isinstance(value, str):
            if not value.isascii() or not value.isprintable():
                raise ValueError(f"parameter {name}: {value!r} is not a printable ASCII word")
            value = np.frombuffer(value.encode("ascii"), np.uint8)
        a = np.asarray(value)
        if a.dtype.kind in "iub":
            int_names.append(name), int_sizes.append(a.size), ints.append(_ints(a))
        else:
            real_names.append(name), real_sizes.append(a.size), reals.append(_reals(a))
    # f2py passes an empty Python string as a zero-length argument; one blank names nothing too.
    return (" ".join(real_names) or " ", _ints(real_sizes), _reals(np.concatenate(reals) if reals else []),
            " ".join(int_names) or " ", _ints(int_sizes), _ints(np.concatenate(ints) if ints else []))


class CoreModel:
    """A model built in the core from its flat description; freed with the object.

    Parameters
    ----------
    deck : str
        The deck's name, for messages.
    """

    def __init__(self, deck: str, lengths, radii, masses, joint: str, locked, locked_angles):
        self.deck = deck
        self.handle = None
        handle, stat, key, msg = _api.rc_model_new(
            _reals(lengths), _reals(radii), _reals(masses), JointKind[joint.upper()], _ints(locked),
            np.asfortranarray(np.asarray(locked_angles, float).reshape(2, -1)))
        self.handle = int(handle)
        _raise(deck, stat, key, msg)
        self.n_bodies = len(lengths)
        self.nq = self.nc = 0

    def __del__(self):
        if getattr(self, "handle", None):
            _api.rc_model_free(self.handle)
            self.handle = None

    # -- building -------------------------------------------------------------------------
    def add_load(self, kind: str, params: dict, context: str = "", deck_keys: dict | None = None):
        """Add a load of a kind the core's load factory knows, with its parameters by name
        (``{name: value}``, as pydriver.components declares them).  A constructor that refuses
        a value names its parameter; ``deck_keys`` ({parameter: 'group.key'}) turns that name
        into the deck key that fed it, so the error is a DeckError naming the key."""
        stat, key, msg = _api.rc_model_add_load(self.handle, kind, *_parameter_arrays(params))
        _raise(self.deck, stat, (deck_keys or {}).get(_text(key), key), msg, context)

    def set_base(self, position, rotation, motion: dict | None = None):
        """Support A: P_1 [m], R_0 (3, 3) and its prescribed motion (the block entries of
        :func:`pydriver.motions.motion_parameters`; None: fixed)."""
        params = {"position": position, "rotation": np.asarray(rotation, float).ravel(order="F"),
                  **(motion or {"motion.hinges": np.int32(0)})}
        stat, key, msg = _api.rc_model_set_base(self.handle, *_parameter_arrays(params))
        _raise(self.deck, stat, key, msg, "clamp A")

    def add_support(self, kind: str, params: dict, context: str = "", deck_keys: dict | None = None):
        """Add support B, of a kind the core's support factory knows, with its parameters by name
        (as :meth:`add_load`)."""
        stat, key, msg = _api.rc_model_add_support(self.handle, kind, *_parameter_arrays(params))
        _raise(self.deck, stat, (deck_keys or {}).get(_text(key), key), msg, context)

    def set_rotor(self, params: dict):
        """The rotor and the frame, its parameter block by name (:func:`pydriver.motions.rotor_parameters`)."""
        stat, key, msg = _api.rc_model_set_rotor(self.handle, *_parameter_arrays(params))
        _raise(self.deck, stat, key, msg, "rotor")

    def finish(self):
        nq, nc, stat, key, msg = _api.rc_model_finish(self.handle)
        _raise(self.deck, stat, key, msg)
        self.nq, self.nc = int(nq), int(nc)

    # -- updating (issue 23: a parameter change is a call, not a rebuild) --------------------
    def update(self, name: str, value):
        """Change the parameter ``name`` of the built model in place.

        Parameters
        ----------
        name : str
            ``'rotor.omega'`` (constant rotor speed [rad/s]), ``'loads.pulse'`` (1 on, 0 off),
            ``'springs.stiffness'`` [Nm/rad] or ``'springs.damping'`` [Nms/rad] (one value per
            coordinate, the layout of ``Model.description["stiffness"]``).
        value : float or array_like

        Raises
        ------
        RunError
            Naming the parameter: a name no component of this model has, a value that does not
            fit, or an integration of this model still open.
        """
        stat, key, msg = _api.rc_model_update(self.handle, name, _reals(value))
        _raise(self.deck, stat, key, msg)

    def parameter(self, name: str) -> np.ndarray:
        """The current value(s) of the parameter ``name`` (see :meth:`update`)."""
        values, count, stat, key, msg = _api.rc_model_parameter(self.handle, name, max(self.nq, 1))
        _raise(self.deck, stat, key, msg)
        return values[:int(count)].copy()

    @contextlib.contextmanager
    def updated(self, changes: dict):
        """The model with ``changes`` ({name: value}, see :meth:`update`) for the duration of a
        ``with`` block; every parameter gets its previous value back on leaving, also on an
        exception.  Scopes nest (each restores what it found)."""
        previous = {name: self.parameter(name) for name in changes}
        try:
            for name, value in changes.items():
                self.update(name, value)
            yield self
        finally:
            for name, value in previous.items():
                self.update(name, value)

    # -- kinematics -----------------------------------------------------------------------
    def thesis_coordinates(self, gamma, beta, gamma_rate, beta_rate):
        """Coordinates and rates of a shape in the thesis's angles [rad, rad/s]."""
        q, v, stat, key, msg = _api.rc_thesis_coordinates(self.handle, _reals(gamma), _reals(beta),
                                                          _reals(gamma_rate), _reals(beta_rate), self.nq)
        _raise(self.deck, stat, key, msg)
        return q, v

    def shape(self, q, t: float = 0.0) -> dict:
        """Thesis angles (n, 2) [rad], CMs (n, 3), joint points (n+1, 3) [m], every body's rotation
        R_j (n, 3, 3; model frame <- body j, its columns the body's axes e1, e2, e3, e3 along the
        body) and R_n (``last_rotation``) at (q, t)."""
        angles, cm, joints, rot, stat, key, msg = _api.rc_shape(self.handle, float(t), _reals(q), self.n_bodies)
        _raise(self.deck, stat, key, msg)
        rotations = np.moveaxis(rot, 2, 0).copy()
        return {"angles": angles.T.copy(), "cm": cm.T.copy(), "joints": joints.T.copy(), "rotations": rotations,
                "last_rotation": rotations[-1]}

    # -- analyses -------------------------------------------------------------------------
    def static(self, q_start, t: float, tol: float, max_iter: int):
        """Static equilibrium: (q, lambda, stats dict)."""
        q, lam, st, stat, key, msg = _api.rc_static(self.handle, float(t), _reals(q_start), max(self.nc, 1),
                                                    float(tol), int(max_iter))
        _raise(self.deck, stat, key, msg)
        stats = solver_stats(STATIC_STATS, st)
        return q, lam[:self.nc].copy(), stats

    def static_system(self, q, lam, t: float = 0.0, jacobian: bool = False) -> dict:
        """The static equilibrium equations at the state (q, lambda), nothing solved:
        ``residual`` -k(q, 0) - G^T lambda (nq) [Nm] and ``g`` (nc); with ``jacobian`` also the
        tangent stiffness ``K`` = d residual/dq at fixed lambda (nq, nq) and ``G`` (nc, nq)."""
        lam_in = np.zeros(max(self.nc, 1))
        lam_in[:self.nc] = lam
        res, g, k_tan, g_jac, stat, key, msg = _api.rc_static_system(
            self.handle, float(t), _reals(q), lam_in, int(jacobian))
        _raise(self.deck, stat, key, msg)
        out = {"residual": res, "g": g[:self.nc].copy()}
        if jacobian:
            out.update(K=k_tan, G=g_jac[:self.nc].copy())
        return out

    def modal_matrices(self, q, lam, t: float = 0.0) -> dict:
        """The linearised equations about (q, lambda) on the constraint manifold: basis N,
        full M, and reduced M_r, K_r, D_r (D_r with the gyroscopic part of a turning frame).
        Their modes are solved in :mod:`pydriver.analyses.linear_modes`."""
        lam_in = np.zeros(max(self.nc, 1))
        lam_in[:self.nc] = lam
        basis, m_full, m_r, k_r, d_r, stat, key, msg = _api.rc_modal_matrices(
            self.handle, float(t), _reals(q), lam_in, self.nq - self.nc)
        _raise(self.deck, stat, key, msg)
        return {"basis": basis, "M": m_full, "M_r": m_r, "K_r": k_r, "D_r": d_r}

    def start(self, settings: dict, t0: float, q0, v0) -> "CoreSession":
        """Start a time integration; the session's q0, v0 are the consistent start.  ``settings``
        is ``{name: value}`` of pydriver.components.SOLVER (:meth:`pydriver.model.Model.solver_settings`),
        sent as the core's 'solver' parameter block; so for the other integrations here."""
        session, q, v, stat, key, msg = _api.rc_dynamic_start(self.handle, *_parameter_arrays(settings), float(t0),
                                                              _reals(q0), _reals(v0))
        s = CoreSession(self, int(session), q, v)
        if stat:
            s.close()
            _raise(self.deck, stat, key, msg)
        return s

    def monodromy(self, settings: dict, t0: float, q0, v0, t) -> dict:
        """One period from (q0, v0) at t0 with its forward sensitivities (rotorcable_monodromy: tangent
        integration with IDA).

        Returns the consistent start ``q0``, ``v0``, the states ``q``, ``v`` (nq, len(t)) at the
        increasing output times ``t`` (the last one ends the period), the null-space basis
        ``basis`` N (nq, nf) of G at the start, the monodromy matrix ``phi`` (2 nf, 2 nf) in the
        independent coordinates x = (a, b), q = q0 + N a, v = v0 + N b + correction, and the
        solver statistics.
        """
        t = _reals(t)
        nf = self.nq - self.nc
        q, v, qs, vs, basis, phi, st, stat, key, msg = _api.rc_monodromy(
            self.handle, *_parameter_arrays(settings), float(t0), _reals(q0), _reals(v0), t, nf)
        _raise(self.deck, stat, key, msg)
        stats = solver_stats(SENSITIVITY_STATS, st)
        return {"q0": qs, "v0": vs, "q": q, "v": v, "basis": basis, "phi": phi, "stats": stats}

    def monodromy_columns(self, settings: dict, t0: float, q0, v0, t, dq, dv, column_atol: float) -> dict:
        """The monodromy applied to k start perturbations, without the whole matrix
        (rotorcable_monodromy's monodromy_columns_run: the same tangent integration as
        :meth:`monodromy`, with k columns instead of 2 nf).

        ``dq``, ``dv`` (nq, k) perturb q and v at the start; their directions in the independent
        coordinates are x_j = (N^T dq_j, N^T dv_j) (the part off the constraint manifold is
        dropped), so a direction x given in the basis N of an earlier call from the same start is
        passed as ``dq = N x[:nf]``, ``dv = N x[nf:]``.  ``column_atol`` (> 0) is the absolute
        tolerance of the columns' q and v rows (per unit of the perturbation); the state keeps
        the settings' own.  Returns what :meth:`monodromy` returns, with ``images`` (2 nf, k)
        = Phi [x_1 ... x_k] in place of ``phi``.
        """
        t = _reals(t)
        nf = self.nq - self.nc
        q, v, qs, vs, basis, images, st, stat, key, msg = _api.rc_monodromy_columns(
            self.handle, *_parameter_arrays(settings), float(column_atol), float(t0), _reals(q0), _reals(v0), t, nf,
            np.asfortranarray(dq, float), np.asfortranarray(dv, float))
        _raise(self.deck, stat, key, msg)
        stats = dict(zip(("steps", "residual_evals", "jacobian_evals", "error_test_failures",
                          "convergence_failures", "sensitivity_residual_evals"), (int(x) for x in st)))
        return {"q0": qs, "v0": vs, "q": q, "v": v, "basis": basis, "images": images, "stats": stats}

    def parameter_sensitivity(self, settings: dict, t0: float, q0, v0, points, sq0, sv0, t,
                              tolerance_scale: float = 1.0) -> dict:
        """An integration from (q0, v0) at t0 with the forward sensitivities of design parameters
        (rotorcable_parameter_sensitivity).

        ``points`` holds a :class:`SensitivityParameter` per parameter: the explicit partial
        dF/dp = sum weight F(model at p + offset h) / h over its :class:`DifferencePoint` terms
        (core None: this model), and the parameter's scale pbar > 0 (the sensitivity's absolute
        tolerance is atol / pbar).  Its ``partial`` (:class:`PartialKind`: the rebuilt models
        differ from this one in their loads only, or in bodies and loads) lets the core
        difference the loads' generalized forces instead of whole residuals, of the changed
        slots only.
        ``tolerance_scale`` (>= 1) loosens the sensitivities' rtol and atol by that factor (the
        state keeps the settings' own).
        ``sq0``, ``sv0`` (nq, np) are the start sensitivities of q and v (made consistent in the
        core).  Returns the consistent start ``q0``, ``v0`` and start sensitivities ``sq0``,
        ``sv0``, the states ``q``, ``v`` (nq, nt) and the sensitivities ``sq``, ``sv``
        (nq, nt, np) at the increasing output times ``t`` > t0, and the solver statistics.
        """
        t = _reals(t)
        n_par = len(points)
        n_pts = max(len(p.points) for p in points)
        handles = np.zeros((n_pts, n_par), dtype=np.int32, order="F")
        offsets = np.zeros((n_pts, n_par), order="F")
        weights = np.zeros((n_pts, n_par), order="F")
        loads_only = np.array([int(p.partial) for p in points], dtype=np.int32)
        changed = load_mask([p.changed_loads for p in points])
        for k, p in enumerate(points):
            for i, d in enumerate(p.points):
                handles[i, k] = 0 if d.core is None else d.core.handle
                offsets[i, k], weights[i, k] = d.offset, d.weight
        q, v, qs, vs, sq, sv, sq_start, sv_start, st, stat, key, msg = _api.rc_parameter_sensitivity(
            self.handle, *_parameter_arrays(settings), float(t0), _reals(q0), _reals(v0), handles, offsets, weights,
            _reals([p.step for p in points]), _reals([p.scale for p in points]), loads_only, changed,
            float(tolerance_scale),
            np.asfortranarray(sq0, float), np.asfortranarray(sv0, float), t)
        _raise(self.deck, stat, key, msg)
        stats = solver_stats(SENSITIVITY_STATS, st)
        return {"q0": qs, "v0": vs, "q": q, "v": v, "sq": sq, "sv": sv, "sq0": sq_start, "sv0": sv_start,
                "stats": stats}

    def sample(self, t, q, v) -> Sample:
        """Output quantities at the states q, v (nq, nt) and times t (nt)."""
        t = _reals(t)
        (wr, kin, pot, gmax, angles, cm, joints, axial, shear, bending, torsion, bend, moment_xy, bend_xy, psi, lam,
         sup, stat, key, msg) = _api.rc_sample(self.handle, t, np.asfortranarray(q, float), np.asfortranarray(v, float),
                               self.n_bodies, max(self.nc, 1))
        _raise(self.deck, stat, key, msg)
        return Sample(wrenches=Wrenches.from_flat(wr.T), kinetic=kin, potential=pot, g_max=gmax, angles=angles,
                      cm=cm, joints=joints, axial=axial.T, shear=shear.T, bending=bending.T,
                      torsion=torsion.T, bend_angle=bend.T, moment_xy=np.moveaxis(moment_xy, 2, 0),
                      bend_xy=np.moveaxis(bend_xy, 2, 0), psi=psi, lam=lam[:self.nc].T,
                      support_velocities=sup.T)

    def constraint_residual(self, q, t: float = 0.0) -> np.ndarray:
        """The constraint residual g(q, t) (nc entries; clamp B: position rows, then rotation rows)."""
        g, stat, key, msg = _api.rc_constraint_residual(self.handle, float(t), _reals(q), max(self.nc, 1))
        _raise(self.deck, stat, key, msg)
        return g[:self.nc].copy()

    def consistent_start(self, q, v, t: float = 0.0) -> dict:
        """The integrator's consistent start from (q, v) at t: ``q``, ``v`` projected onto the
        constraints, ``vdot`` and ``lambda`` from eq. 3.55; no integration is started."""
        q1, v1, vd, lam, stat, key, msg = _api.rc_consistent_start(self.handle, float(t), _reals(q), _reals(v),
                                                                   max(self.nc, 1))
        _raise(self.deck, stat, key, msg)
        return {"q": q1, "v": v1, "vdot": vd, "lambda": lam[:self.nc].copy()}


class CoreSession:
    """A time integration in progress in the core (IDA kept between calls)."""

    def __init__(self, model: CoreModel, handle: int, q0, v0):
        self.model = model
        self.handle = handle
        self.q0, self.v0 = q0, v0
        self.stats: dict = {}

    def advance(self, t):
        """States (nq, len(t)) at the increasing times t; raises RunError on failure."""
        t = _reals(t)
        q, v, st, stat, key, msg = _api.rc_dynamic_advance(self.handle, t, self.model.nq)
        self.stats = solver_stats(INTEGRATION_STATS, st)
        _raise(self.model.deck, stat, key, msg)
        return q, v

    def close(self):
        if self.handle:
            _api.rc_dynamic_free(self.handle)
            self.handle = 0

    def __del__(self):
        if getattr(self, "handle", 0) and getattr(self, "model", None) is not None and self.model.handle:
            self.close()
