"""The test and benchmark probes of the compiled core (``src_fortran/probes.f90``, module
``rotorcable_probes``): every model quantity at a state, the GGL residual and iteration matrix,
the linear solvers, timed kernels and a timed integration, each a function of a
:class:`~pydriver.core.CoreModel`.

Only the tests and the benchmarks import this module; the driver (``run_deck``, the analyses,
the command line) never does, so the product's import path holds none of it.  The probes are
built only with the meson option ``probes`` on (``.ci/setup`` and ``.ci/tests`` build so); in a
build without them (the product wheel of ``pip install .``) :data:`HAS_PROBES` is false and
every function here raises :class:`ProbesNotBuilt`, naming the option.

The f2py conventions (status, message, flat parameter blocks) are :mod:`pydriver.core`'s: this
module uses its helpers, so the probes unpack their results as the run API does.
"""

from __future__ import annotations

import numpy as np

from pydriver import _rotorcable
from pydriver.core import (
    INTEGRATION_STATS,
    CoreModel,
    PartialKind,
    Wrenches,
    _parameter_arrays,
    _raise,
    _reals,
    _trapped_if_asked,
    load_mask,
    solver_stats,
)


class ProbesNotBuilt(RuntimeError):
    """A test or benchmark probe was called in a build without them (-Dprobes=false, the default
    of ``pip install .``)."""


class _ProbesAbsent:
    """Stands in for the probes module in a build without it (the product wheel): any probe
    call raises, naming the build option that adds them."""

    def __getattr__(self, name):
        raise ProbesNotBuilt(
            f"{name}: the test and benchmark probes are not in this build of rotorcable; rebuild with "
            "the meson option probes on (pip install -Csetup-args=-Dprobes=true ..., as .ci/setup does)")


#: Whether this build has the probes (-Dprobes=true, meson.options).
HAS_PROBES = hasattr(_rotorcable, "rotorcable_probes")
_probes = _trapped_if_asked(_rotorcable.rotorcable_probes) if HAS_PROBES else _ProbesAbsent()


def evaluate(core: CoreModel, q, v, vdot, lam, t: float = 0.0) -> dict:
    """Every model quantity of the chain at one state (t, q, v, vdot, lambda).

    Returns
    -------
    dict
        ``M`` (composite-rigid-body), ``M_jourdain`` (thesis eq. 4.87), ``k``, ``residual``
        (M vdot - k - G^T lambda by inverse dynamics), ``g``, ``G``, ``Gdot_v`` (the acceleration
        bias, rheonomic terms included), ``G_v`` (G v + g_t), ``vdot``/``lambda`` of eq. 3.55,
        ``wrenches`` (:class:`pydriver.core.Wrenches`) and ``energy``.
    """
    lam_in = np.zeros(max(core.nc, 1))
    lam_in[:core.nc] = lam
    (m, mj, k, res, g, gj, gb, gv, vd, la, wr, en, stat, msg) = _probes.rc_probe_evaluate(
        core.handle, float(t), _reals(q), _reals(v), _reals(vdot), lam_in)
    _raise(core.deck, stat, "", msg)
    nc = core.nc
    return {"M": m, "M_jourdain": mj, "k": k, "residual": res, "g": g[:nc], "G": gj[:nc],
            "Gdot_v": gb[:nc], "G_v": gv[:nc], "vdot": vd, "lambda": la[:nc], "wrenches": Wrenches.from_flat(wr),
            "energy": float(en)}


def evaluate_model(path, q, v=None, vdot=None, lam=None, t: float = 0.0) -> dict:
    """:func:`evaluate` of a deck's model (a path or a :class:`~pydriver.model.Model`), with
    ``v``, ``vdot`` and ``lam`` zero unless given."""
    from pydriver.model import Model
    m = path if isinstance(path, Model) else Model.from_deck(path)
    q = np.asarray(q, float)
    v = np.zeros(m.nq) if v is None else np.asarray(v, float)
    vdot = np.zeros(m.nq) if vdot is None else np.asarray(vdot, float)
    lam = np.zeros(m.nc) if lam is None else np.asarray(lam, float)
    return evaluate(m.core, q, v, vdot, lam, t)


def parameter_partial(core: CoreModel, models, weights, h: float, y, yd, t: float = 0.0,
                      partial: PartialKind = PartialKind.WHOLE_RESIDUALS, changed_loads=None) -> np.ndarray:
    """F_p = sum_i w_i F(models[i]) / h at (t, y, y') (None: this model), as the sensitivity
    integration takes it; ``partial`` LOADS_ONLY: from the loads' generalized forces on this
    model's kinematics (rotorcable_parameter_sensitivity, loads_partial), or BODIES_AND_LOADS:
    from the rebuilt models' bodies and loads on its motion (bodies_partial), of the load slots
    where ``changed_loads`` (default: all)."""
    handles = np.array([0 if m is None else m.handle for m in models], dtype=np.int32)
    changed = load_mask([changed_loads])
    fp, stat, msg = _probes.rc_probe_parameter_partial(core.handle, handles, _reals(weights), float(h),
                                                       int(partial), changed[:, 0], float(t), _reals(y),
                                                       _reals(yd))
    _raise(core.deck, stat, "", msg)
    return fp


def consistent_ggl_state(core: CoreModel, q, v, t: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """GGL unknowns y = (q, v, lambda, 0) and yd = (v, vdot, 0, 0) at the consistent start."""
    n = 2 * core.nq + 2 * core.nc
    y, yd, stat, msg = _probes.rc_probe_consistent_start(core.handle, float(t), _reals(q), _reals(v), n)
    _raise(core.deck, stat, "", msg)
    return y, yd


def ggl_residual(core: CoreModel, y, yd, t: float = 0.0) -> np.ndarray:
    """The GGL residual F(t, y, y') that IDA integrates."""
    r, stat, msg = _probes.rc_probe_ggl_residual(core.handle, float(t), _reals(y), _reals(yd))
    _raise(core.deck, stat, "", msg)
    return r


#: The physics columns of :func:`iteration_matrix`: analytic (whole matrices, the run's), analytic
#: by one tangent sweep per column (their check), central differences (the check of both).
JACOBIAN_METHODS = {"analytic": 1, "tangent_sweeps": 2, "finite_difference": 0}


def iteration_matrix(core: CoreModel, y, yd, cj: float, b, n_rep: int = 1, t: float = 0.0,
                     jacobian: str = "analytic") -> dict:
    """The GGL iteration matrix at (y, y', cj), its physics columns by ``jacobian`` (a key of
    :data:`JACOBIAN_METHODS`), with the block solver's solutions of J x = b and the timings."""
    (jac, x, nbf, nbs, ndf, nds, stat, msg) = _probes.rc_probe_iteration_matrix(
        core.handle, float(t), float(cj), _reals(y), _reals(yd), JACOBIAN_METHODS[jacobian],
        np.asfortranarray(b, float), int(n_rep))
    _raise(core.deck, stat, "", msg)
    return {"jacobian": jac, "x_block": x, "ns_block_factor": nbf, "ns_block_solve": nbs,
            "ns_dense_factor": ndf, "ns_dense_solve": nds}


def chain_solver(core: CoreModel, y, cj: float, b, n_rep: int = 1, t: float = 0.0) -> dict:
    """The chain solver's approximate iteration matrix at (t, q, cj), its solutions of J x = b
    and the block solver's solutions of the same matrix, with the chain's timings."""
    (jac, xc, xb, nf, ns, stat, msg) = _probes.rc_probe_chain_solver(
        core.handle, float(t), float(cj), _reals(y), np.asfortranarray(b, float), int(n_rep))
    _raise(core.deck, stat, "", msg)
    return {"jacobian": jac, "x_chain": xc, "x_block": xb, "ns_factor": nf, "ns_solve": ns}


def time_kernels(core: CoreModel, y, yd, n_rep: int, t: float = 0.0) -> dict:
    """The residual at (t, y, y') and the wall time per call [ns] of the residual (timed over
    ``n_rep`` calls in Fortran), of the iteration matrix with analytic physics columns (whole
    matrices; ``jacobian_sweeps_ns``: by tangent sweeps) and with finite-difference ones, of the
    equation of motion's derivatives d(res)/dq, d(res)/dv and M (``derivatives_ns``; n_rep/100 + 1
    calls each) and of the mass matrix.  Each call but the mass matrix's is at a new time, so
    it pays for its own residual pass (none finds it in the workspace)."""
    r, ns_res, ns_jac, ns_jac_fd, ns_mass, ns_jac_sw, ns_der, stat, msg = _probes.rc_probe_time_kernels(
        core.handle, float(t), _reals(y), _reals(yd), int(n_rep))
    _raise(core.deck, stat, "", msg)
    return {"residual": r, "residual_ns": ns_res, "jacobian_ns": ns_jac, "jacobian_fd_ns": ns_jac_fd,
            "jacobian_sweeps_ns": ns_jac_sw, "derivatives_ns": ns_der, "mass_matrix_ns": ns_mass}


def eom_derivatives(core: CoreModel, q, v, vdot, lam, t: float = 0.0) -> dict:
    """The equation-of-motion residual's derivatives as whole matrices at (t, q, v, vdot,
    lambda): ``dres_dq``, ``dres_dv`` (lambda fixed) and ``mass`` (d(res)/d(vdot)), by the
    core's one-pass analytic derivatives."""
    lam_in = np.zeros(max(core.nc, 1))
    lam_in[:core.nc] = lam
    dq, dv, m, stat, msg = _probes.rc_probe_eom_derivatives(core.handle, float(t), _reals(q), _reals(v),
                                                           _reals(vdot), lam_in)
    _raise(core.deck, stat, "", msg)
    return {"dres_dq": dq, "dres_dv": dv, "mass": m}


def ode_jacobian(core: CoreModel, q, v, baumgarte_omega: float = 50.0, t: float = 0.0) -> dict:
    """The ODE route's right-hand side ``ydot`` = (v, vdot) and its Jacobian d(y')/dy, y = (q, v),
    at (t, q, v): ``analytic`` (what GSL msbdf gets) and ``differences`` (the forward differences
    it got before)."""
    n = 2 * core.nq
    yd, ja, jd, stat, msg = _probes.rc_probe_ode_jacobian(core.handle, float(t), _reals(q), _reals(v),
                                                          float(baumgarte_omega), n)
    _raise(core.deck, stat, "", msg)
    return {"ydot": yd, "analytic": ja, "differences": jd}


def articulated_solve(core: CoreModel, q, armature, tau, t: float = 0.0) -> np.ndarray:
    """(M(q) + diag(armature))^-1 tau by the articulated-body factorisation (the chain
    solver's kernel)."""
    x, stat, msg = _probes.rc_probe_articulated_solve(core.handle, float(t), _reals(q), _reals(armature),
                                                      _reals(tau))
    _raise(core.deck, stat, "", msg)
    return x


def residual_tangent(core: CoreModel, y, yd, dy, dyd, t: float = 0.0) -> np.ndarray:
    """First-order change of the GGL residual at (y, y') for the change (dy, dyd): the
    analytic Jacobian's tangent sweep (with dyd = cj dy, the iteration matrix times dy)."""
    dr, stat, msg = _probes.rc_probe_residual_tangent(core.handle, float(t), _reals(y), _reals(yd),
                                                      _reals(dy), _reals(dyd))
    _raise(core.deck, stat, "", msg)
    return dr


COLUMN_ROUTES = {"chosen": 0, "sweeps": 1, "matrices": 2}


def residual_tangent_columns(core: CoreModel, y, yd, dy, dyd, t: float = 0.0, route: str = "sweeps") -> np.ndarray:
    """:func:`residual_tangent` of every column of dy, dyd (n, m) at once.  ``route``: "sweeps"
    (the chain's tangents over blocks of columns, bit for bit the single sweeps), "matrices" (the
    whole derivative matrices times the columns) or "chosen" (the sensitivity residuals' path:
    whichever of the two is cheaper for m columns)."""
    dr, stat, msg = _probes.rc_probe_residual_tangent_columns(core.handle, float(t), _reals(y), _reals(yd),
                                                              np.asfortranarray(dy, float),
                                                              np.asfortranarray(dyd, float),
                                                              COLUMN_ROUTES[route])
    _raise(core.deck, stat, "", msg)
    return dr


def integrate_timed(core: CoreModel, method: int, settings: dict, t0: float, t_end: float, q0, v0, n_samples: int,
                    baumgarte_omega: float = 50.0) -> dict:
    """One timed integration (1 IDA, 2 GSL rk8pd, 3 GSL msbdf): CM samples (n_samples, n, 3)
    at equally spaced times t0 ... t_end, the end state, statistics, CPU and wall time of
    the integration alone.  ``settings`` as for :meth:`pydriver.core.CoreModel.start`."""
    (cm, q_end, v_end, st, cpu, wall, stat, msg) = _probes.rc_probe_integrate(
        core.handle, int(method), *_parameter_arrays(settings), float(baumgarte_omega), float(t0), float(t_end),
        _reals(q0), _reals(v0), int(n_samples), core.n_bodies)
    _raise(core.deck, stat, "", msg)
    return {"cm_samples": cm.transpose(2, 1, 0).copy(), "q_end": q_end, "v_end": v_end,
            "stats": solver_stats(INTEGRATION_STATS, st),
            "cpu_s": float(cpu), "wall_s": float(wall)}


def rank_margin(core: CoreModel, q, t: float = 0.0) -> float:
    """sigma_min / sigma_max of the constraint Jacobian (1 for a free end)."""
    return float(_probes.rc_probe_rank_margin(core.handle, float(t), _reals(q)))
