"""Design sensitivities of a static or modal run (``&design parameters``; issue 24, first increment;
flight runs: :mod:`pydriver.analyses.flight_sensitivities`).

Static runs: d(reactions)/dp and d(joint loads)/dp by the implicit function theorem at the
converged equilibrium (docs/model.md, "Design sensitivities").  With x = (q, lambda) and the
equilibrium equations R(x; p) = (-k(q, 0) - G^T lambda, g(q)) = 0 (eq. 3.50/3.51 at rest):

    dx/dp = -(dR/dx)^-1 dR/dp,    dR/dx = [[K, -G^T], [G, 0]]

with K the core's exact tangent stiffness at fixed lambda (rotorcable_statics, static_system).
The explicit partial dR/dp is a central difference of the residual at the FIXED state x with
the model rebuilt at p +- h (one residual each, no re-solve).  An output y(q, p) (the core's
sample at rest) changes along the equilibrium's tangent, dy/dp = dy/dq dq/dp + dy/dp|_q, which is
the derivative at s = 0 of y(q + s dq/dp, p + s): one central difference of y on the same two
rebuilt models.  Both differences are O(h^2) (Nocedal & Wright, Numerical Optimization, eq. 8.9)
with h = eps^(1/3) max(|p|, 1 unit) (pydriver.design.step): truncation and round-off are both
~1e-11 relative.  At a range bound (a spring constant of 0) the difference is one-sided, the
second-order three-point formula (ibid., forward-difference table; Fornberg 1988).

Modal runs: d(frequency)/dp from the eigenvector formula (Fox & Kapoor, AIAA J. 6 (1968) 2426)

    d lambda_k = phi_k^T (dK_r - lambda_k dM_r) phi_k / (phi_k^T M_r phi_k),   lambda_k = (2 pi f_k)^2,

with dK_r, dM_r central differences of the reduced matrices along the equilibrium's tangent
(x + s dx/dp, p + s), each in the basis P(s) N_0 (the null-space projector at s applied to the
base basis N_0): the core's orthonormal basis may turn or flip a column between p - h and p + h,
P(s) N_0 varies smoothly and the pencil's eigenvalues do not depend on the basis.

Damped frequencies (``fd{k}_hz``, the frequencies the resonance margins and the design
optimiser's frequency constraint judge): the root s of the first-order state matrix

    A = [[0, I], [-M_r^-1 K_r, -M_r^-1 D_r]]

that is undamped mode k's damped partner (the modal analysis's pairing by MAC,
:func:`pydriver.analyses.linear_modes.damped_partners`), f_d = Im s / 2 pi, and its derivative
by the left and right eigenvectors w, z of A (Lancaster 1964; a simple eigenvalue of a
non-symmetric matrix):

    ds = w^H dA z / (w^H z),   dA = -[[0, 0], [M^-1 (dK - dM M^-1 K), M^-1 (dD - dM M^-1 D)]],

dK_r (unsymmetric: the circulatory part stays), dD_r (the gyroscopic part stays) and dM_r the
same differences along the tangent as above.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import scipy.linalg

from pydriver.analyses.common import REACTION_NAMES
from pydriver.analyses.linear_modes import modal_modes, symmetric_modes
from pydriver.analyses.registry import analysis_of
from pydriver.analyses.sensitivity_common import equilibrium_tangents, sensitivity_table
from pydriver.analyses.statics import drop_pulse, unforced
from pydriver.design import Parameter, parameters, step
from pydriver.errors import DeckError, RunError

#: Loads of a static run's table (docs/outputs.md) whose sensitivities are reported, with units.
JOINT_LOADS = (("axial", "N"), ("shear", "N"), ("bending", "Nm"), ("torsion", "Nm"))
#: Modal runs: the sensitivities of the first this many undamped frequencies.
N_FREQUENCIES = 6
#: Two frequencies closer than this (relative) are one repeated eigenvalue, which has no derivative
#: of its own (only the pair's mean has one): such modes are skipped with a warning.
REPEATED_REL = 1.0e-6


class Scheme:
    """A difference formula: offsets s_i (in steps h) and weights, f'(0) = sum_i w_i f(s_i h) / h."""

    CENTRAL = ((1.0, 0.5), (-1.0, -0.5))
    FORWARD = ((0.0, -1.5), (1.0, 2.0), (2.0, -0.5))
    BACKWARD = ((0.0, 1.5), (-1.0, -2.0), (-2.0, 0.5))


class Plan:
    """A parameter, its step and the models rebuilt at its offsets (None: the run's own model);
    ``loads_only``: they differ from the run's model in their loads only (:func:`loads_only`)."""

    def __init__(self, parameter: Parameter, h: float, scheme: str, points: list, loads_only: bool = False):
        self.parameter, self.h, self.scheme, self.points = parameter, h, scheme, points
        self.loads_only = loads_only
        #: they have the run's kinematics and differ in their bodies and loads (:func:`bodies_and_loads`)
        self.bodies_and_loads = False
        #: the load slots (in the order built) whose load the rebuilt models change (None: all)
        self.changed_loads = None


#: What pydriver.assembly.build makes of a deck besides the loads: the chain, support A's pose
#: and motion, support B, the rotor (the description's entries), and the deck groups read for
#: them directly.  A parameter whose rebuilt models agree with the run's in all of these moves
#: the loads only.
NOT_LOADS = ("bodies", "first_coord", "base_rotation", "base_moves", "support", "support_parameters", "clamp",
             "rotor")
NOT_LOADS_GROUPS = ("chain", "shape", "clamp_a")


def _same(a, b) -> bool:
    """Equal to the bit, through dicts, sequences, dataclasses and arrays."""
    if dataclasses.is_dataclass(a) and dataclasses.is_dataclass(b):
        return type(a) is type(b) and _same(dataclasses.asdict(a), dataclasses.asdict(b))
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b))
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return np.shape(a) == np.shape(b) and bool(np.array_equal(a, b))
    return a == b


def loads_only(model, varied) -> bool:
    """Whether ``varied`` (a rebuilt model) differs from ``model`` in its loads only, so that the
    core may difference the loads' generalized forces for F_p (rotorcable_parameter_sensitivity,
    loads_partial) instead of whole residuals."""
    return (all(_same(model.description[k], varied.description[k]) for k in NOT_LOADS)
            and all(_same(model.deck.values.get(g), varied.deck.values.get(g)) for g in NOT_LOADS_GROUPS))


def bodies_and_loads(model, varied) -> bool:
    """Whether ``varied`` (a rebuilt model) has the kinematics of ``model`` (body lengths, locked
    joints, joint kind and first body, support A, support B, the rotor) and differs in its
    bodies' masses and radii and its loads only, so that the core may take F_p from the rebuilt
    models' Newton-Euler passes on the run's motion instead of whole residuals
    (rotorcable_parameter_sensitivity, bodies_partial)."""
    a, b = model.description["bodies"], varied.description["bodies"]
    chain_a, chain_b = model.deck.values.get("chain", {}), varied.deck.values.get("chain", {})
    return (_same(a.lengths, b.lengths) and _same(a.locked, b.locked)
            and all(_same(model.description[k], varied.description[k]) for k in NOT_LOADS if k != "bodies")
            and all(_same(model.deck.values.get(g), varied.deck.values.get(g)) for g in ("shape", "clamp_a"))
            and all(_same(chain_a.get(k), chain_b.get(k)) for k in ("joint", "first_body")))


def changed_loads(model, varied: list) -> list[bool] | None:
    """Per load slot of ``model`` (the order assembly built them), whether any of the rebuilt
    models ``varied`` has another load there; None when they hold other kinds of load.  A load
    is its kind and its packed parameters (``description['loads']``), which is all the core
    receives; so an unchanged slot gives the same forces at every point, and its share of a
    difference (weights summing to 0) is exactly 0."""
    loads = model.description["loads"]
    if any(list(m.description["loads"]) != list(loads) for m in varied):
        return None
    return [any(not _same(loads[kind], m.description["loads"][kind]) for m in varied) for kind in loads]


def plan(model) -> list[Plan]:
    """The deck's parameters with their rebuilt models; raises the deck's error (naming
    ``&design parameters``) for a parameter that cannot be varied about its value in this deck.
    Called before the analysis, so that bad input is refused before any solve."""
    out = []
    for p in parameters(model.deck):
        h = step(p)

        def build(s):
            if s == 0.0:
                return None
            varied = model.with_changes(p.changes(model.deck, p.value + s * h))   # its own model
            # A run from t = 0 differentiates the loads as integrated, pulse included (its start
            # equilibrium switches the pulse off in scope, dynamic_sensitivities).
            return varied if analysis_of(model).time_axis == "t_end" else drop_pulse(varied)

        models, errors = {}, {}
        for s in (1.0, -1.0):
            try:
                models[s] = build(s)
            except DeckError as err:
                errors[s] = err
        if not errors:
            scheme, formula = "central", Scheme.CENTRAL
        elif 1.0 in models:
            scheme, formula = "forward", Scheme.FORWARD
        elif -1.0 in models:
            scheme, formula = "backward", Scheme.BACKWARD
        else:
            err = errors[1.0]
            raise DeckError(model.name, "design", "parameters",
                            f"'{p.name}' cannot be varied about its value {p.value:g} in this deck: "
                            f"{err.group}.{err.key}: {err.reason}")
        points = []
        for s, w in formula:
            if s not in models and s != 0.0:
                try:
                    models[s] = build(s)
                except DeckError as err:
                    raise DeckError(model.name, "design", "parameters",
                                    f"'{p.name}' cannot be varied by {2 * h:g} on either side of "
                                    f"{p.value:g}: {err.group}.{err.key}: {err.reason}") from None
            points.append((s, w, models.get(s)))
        varied = [m for _, _, m in points if m is not None]
        out.append(Plan(p, h, scheme, points, all(loads_only(model, m) for m in varied)))
        if not out[-1].loads_only:
            out[-1].bodies_and_loads = all(bodies_and_loads(model, m) for m in varied)
        if out[-1].loads_only or out[-1].bodies_and_loads:
            out[-1].changed_loads = changed_loads(model, varied)
    return out


def static_outputs(model, q) -> tuple[np.ndarray, list, list]:
    """The outputs of a static run at the state q: reactions and joint loads (values, names, units)."""
    sample = model.core.sample([0.0], q[:, None], np.zeros((model.nq, 1)))
    n_wrench = 12 if model.nc > 0 else 6
    values = [sample.wrenches.as_flat()[0][:n_wrench]]
    names = list(REACTION_NAMES[:n_wrench])
    units = ["N", "N", "N", "Nm", "Nm", "Nm"] * (n_wrench // 6)
    for load, unit in JOINT_LOADS:
        values.append(getattr(sample, load)[0])
        names += [f"{load}{j + 1}_{unit}" for j in range(model.n_bodies)]
        units += [unit] * model.n_bodies
    return np.concatenate(values), names, units


def static_sensitivities(model, plans: list[Plan], q, lam) -> dict:
    """d(output)/dp of a static run's outputs at its equilibrium (q, lambda), every plan."""
    with unforced(model):
        return _static_sensitivities(model, plans, q, lam)


def _static_sensitivities(model, plans: list[Plan], q, lam) -> dict:
    y0, names, units = static_outputs(model, q)
    dx = equilibrium_tangents(model, plans, q, lam)
    values = []
    for pl, x_p in zip(plans, dx):
        dq = x_p[:model.nq]
        dy = np.zeros_like(y0)
        for s, w, m in pl.points:
            dy += w * (y0 if m is None else static_outputs(m, q + s * pl.h * dq)[0])
        values.append(dy / pl.h)
    return sensitivity_table(plans, names, units, values, [])


def _reduced(m, q, lam, n0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """K_r, M_r, D_r of model m at (q, lambda) in the basis P N_0 (P the projector onto its null
    space); K_r and D_r with their skew parts."""
    mm = m.core.modal_matrices(q, lam)
    t = mm["basis"].T @ n0
    return t.T @ mm["K_r"] @ t, t.T @ mm["M_r"] @ t, t.T @ mm["D_r"] @ t


def modal_sensitivities(model, plans: list[Plan], q, lam, modes: int = N_FREQUENCIES,
                        below_hz: float | None = None) -> dict:
    """d(f_k)/dp of the first undamped frequencies and d(fd_k)/dp of the damped frequencies of a
    modal run about its equilibrium (the module doc).

    Parameters
    ----------
    modes : int
        The damped frequencies of the first ``modes`` modes are differentiated (the undamped ones:
        always the first :data:`N_FREQUENCIES`).
    below_hz : float, optional
        Also every mode whose damped frequency lies below this [Hz], and the lowest one above (the
        design optimiser's frequency margin: every mode up to the highest harmonic).
    """
    with unforced(model):
        return _modal_sensitivities(model, plans, q, lam, modes, below_hz)


def _modal_sensitivities(model, plans: list[Plan], q, lam, modes: int = N_FREQUENCIES,
                         below_hz: float | None = None) -> dict:
    mm = model.core.modal_matrices(q, lam)
    n0 = mm["basis"]
    k_full, m0, d0 = _reduced(model, q, lam, n0)
    k0 = 0.5 * (k_full + k_full.T)         # the undamped modes take the symmetric part
    # The modal analysis's undamped problem K_r phi = lambda M_r phi, phi^T M_r phi = 1; the
    # eigenvalues as solved (a non-positive one is a warning here, not an error).
    ev, phi = symmetric_modes(k0, m0)
    count = min(N_FREQUENCIES, ev.size)
    warnings = []
    keep = []
    for k in range(count):
        if ev[k] <= 0.0:
            warnings.append(f"mode {k + 1} has no positive stiffness: its frequency has no sensitivity")
            continue
        gaps = [abs(ev[k] - ev[i]) for i in (k - 1, k + 1) if 0 <= i < ev.size]
        if gaps and min(gaps) < REPEATED_REL * abs(ev[k]):
            warnings.append(f"mode {k + 1} is repeated: a repeated frequency has no derivative of its own")
            continue
        keep.append(k)
    freqs = np.sqrt(np.maximum(ev, 0.0)) / (2.0 * np.pi)
    damped, damped_warnings = _damped_roots(mm, k_full, m0, d0, modes, below_hz)
    warnings += damped_warnings
    names = [f"f{k + 1}_hz" for k in keep] + [f"fd{k + 1}_hz" for k in damped]
    units = ["Hz"] * len(names)
    dx = equilibrium_tangents(model, plans, q, lam)
    values = []
    for pl, x_p in zip(plans, dx):
        d_k = np.zeros_like(k_full)
        d_m = np.zeros_like(m0)
        d_d = np.zeros_like(d0)
        for s, w, m in pl.points:
            if m is None:
                d_k += w * k_full
                d_m += w * m0
                d_d += w * d0
            else:
                ks, ms, ds = _reduced(m, q + s * pl.h * x_p[:model.nq], lam + s * pl.h * x_p[model.nq:], n0)
                d_k += w * ks
                d_m += w * ms
                d_d += w * ds
        d_k /= pl.h
        d_m /= pl.h
        d_d /= pl.h
        d_k_sym = 0.5 * (d_k + d_k.T)
        out = []
        for k in keep:
            v = phi[:, k]
            d_ev = v @ (d_k_sym - ev[k] * d_m) @ v / (v @ m0 @ v)      # Fox & Kapoor (1968)
            out.append(d_ev / (8.0 * np.pi**2 * freqs[k]))              # lambda = (2 pi f)^2
        if damped:
            d_a = _state_matrix_difference(m0, k_full, d0, d_k, d_m, d_d)
            out += [_damped_derivative(root, d_a) for root in damped.values()]
        values.append(np.asarray(out))
    sens = sensitivity_table(plans, names, units, values, warnings)
    sens["values"] = {f"f{k + 1}_hz": float(freqs[k]) for k in keep}      # the optimiser's objective
    sens["values"].update({f"fd{k + 1}_hz": float(root["s"].imag / (2.0 * np.pi)) for k, root in damped.items()})
    return sens


def _damped_roots(mats: dict, k_r, m_r, d_r, modes: int, below_hz: float | None) -> tuple[dict, list]:
    """{mode index k: its damped root s with A's left and right eigenvectors} of the modes whose
    damped frequency is differentiated (the first ``modes``, and those below ``below_hz``), and
    the warnings for those that have none (not oscillating, repeated)."""
    try:
        partner = modal_modes(mats)
    except RunError as err:
        return {}, [f"the damped frequencies have no sensitivities: {err}"]
    fd = partner["f_damped_hz"]
    wanted = set(range(min(modes, fd.size)))
    if below_hz is not None:
        wanted |= set(np.flatnonzero((fd > 0.0) & (fd < below_hz)).tolist())
        above = np.flatnonzero(fd >= below_hz)
        if above.size:                      # and the lowest one above (it must not come down into range)
            wanted.add(int(above[np.argmin(fd[above])]))
    wanted = sorted(wanted)
    nf = m_r.shape[0]
    a = np.block([[np.zeros((nf, nf)), np.eye(nf)], [-np.linalg.solve(m_r, k_r), -np.linalg.solve(m_r, d_r)]])
    roots, left, right = scipy.linalg.eig(a, left=True, right=True)
    out, warnings = {}, []
    for k in wanted:
        if not partner["oscillating"][k]:
            warnings.append(f"mode {k + 1} does not oscillate (overdamped or zero stiffness): its damped frequency "
                            "has no sensitivity")
            continue
        s = partner["damped_root"][k]
        distance = np.abs(roots - s)
        order = np.argsort(distance)
        if distance[order[1]] < REPEATED_REL * abs(s):
            warnings.append(f"mode {k + 1}'s damped root is repeated: it has no derivative of its own")
            continue
        j = int(order[0])
        out[int(k)] = {"s": roots[j], "left": left[:, j], "right": right[:, j]}
    return out, warnings


def _state_matrix_difference(m_r, k_r, d_r, d_k, d_m, d_d) -> tuple[np.ndarray, np.ndarray]:
    """The lower blocks of dA (the upper ones are 0): -M^-1 (dK - dM M^-1 K), -M^-1 (dD - dM M^-1 D)."""
    return (-np.linalg.solve(m_r, d_k - d_m @ np.linalg.solve(m_r, k_r)),
            -np.linalg.solve(m_r, d_d - d_m @ np.linalg.solve(m_r, d_r)))


def _damped_derivative(root: dict, d_a: tuple) -> float:
    """d(fd)/dp = Im(ds)/2 pi of one damped root, ds = w^H dA z / (w^H z) (module doc)."""
    w, z = root["left"], root["right"]
    nf = z.size // 2
    da_z = d_a[0] @ z[:nf] + d_a[1] @ z[nf:]
    ds = (w[nf:].conj() @ da_z) / (w.conj() @ z)
    return float(ds.imag / (2.0 * np.pi))


def static_result_sensitivities(model, plans: list[Plan], result) -> dict:
    """The registry's differentiation of a finished static run (pydriver.analyses.registry)."""
    return static_sensitivities(model, plans, result.extra["q"], result.extra["lambda"])


def modal_result_sensitivities(model, plans: list[Plan], result) -> dict:
    """The registry's differentiation of a finished modal run."""
    return modal_sensitivities(model, plans, result.extra["q"], result.extra["lambda"])


def attach_sensitivities(model, result, plans: list[Plan]) -> None:
    """Add the sensitivities of a finished run to its result (summary and ``sensitivities.csv``),
    as its analysis differentiates it (the registry's ``sensitivities``)."""
    if not plans:
        return
    sens = analysis_of(model).differentiate(model, plans, result)
    result.summary["sensitivities"] = sens["summary"]
    if sens["warnings"]:
        result.summary.setdefault("warnings", []).extend(sens["warnings"])
    result.extra.setdefault("tables", {})["sensitivities.csv"] = sens["rows"]
    result.extra.setdefault("units", {})["sensitivities.csv"] = {"value": "*"}
