"""Design sensitivities of a flight run (``&design parameters``; issue 24, flight increment).

The periodic revolution is a smooth function of the parameters; its outputs' derivatives come
from forward sensitivities through the DAE ("tangent integration", docs/model.md "Design
sensitivities of a flight"):

1. **Parameter sensitivities.**  ``CoreModel.parameter_sensitivity`` integrates
   s = dy/dp with the state (IDAS, residual F_y s + F_y' s' + F_p; F_y s + F_y' s' the analytic
   tangent, F_p a central difference of the GGL residual of the models rebuilt at p +- h at the
   FIXED (t, y, y'), O(h^2) with h = eps^(1/3) max(|p|, 1 unit): ~1e-11 relative, far below
   the integration's tolerances).
2. **Periodic start.**  With x = (a, b) the independent coordinates about the start (basis N,
   as the monodromy's), the periodic start satisfies x* = X(T; x*, p), so

       dx*/dp = (I - Phi)^-1 dX(T)/dp

   with Phi the monodromy at the start and dX(T)/dp the parameter sensitivities after one
   revolution from the start with zero initial state sensitivity (first integration).  Without
   the monodromy: block GMRES on one-revolution products (:func:`_periodic_start_krylov`).
3. **The revolution.**  A second integration from the start with the initial sensitivity
   (N da*, N db* - G^+ H N da*) (made consistent in the core) gives s at every output time
   (without the monodromy: the first integration's s plus the Krylov blocks' recorded histories
   combined, by linearity);
   the outputs' derivatives are central differences of the core's sample function along
   (q + e s_q, v + e s_v, p + e): no re-solve.  s(T) = s(0) checks the periodicity.
4. **Outputs** (:mod:`pydriver.analyses.history_outputs`, shared with the dynamic runs').
   Peaks and extrema: the derivative at the arg-max sample (exact away from
   ties and from a change of the sample that holds the maximum); amplitudes (max - min)/2
   likewise.  Miner damage and damage-equivalent loads with the rainflow cycle set held fixed:
   a cycle between reversal samples i, k has amplitude S = |x_k - x_i|/2 and
   dS/dp = sign(x_k - x_i) (dx_k/dp - dx_i/dp)/2, then dD/dp = sum m D_i/S_i dS_i/dp and
   dS_eq/dp = S_eq^(1-m)/n_eq sum n_i S_i^(m-1) dS_i/dp: exact between changes of the cycle
   set (a new small cycle, a reversal moving to a neighbouring sample, the worst point around
   the jacket moving to another of the circumferential points).

Parameters that move the constraint (clamp B's pose, the cable's length) need nothing of their
own: F_p carries g_p, the core's least-norm correction puts the start sensitivity's particular
part normal to the constraint manifold (orthogonal to the monodromy's basis N), and the
periodicity of the tangent coordinates is step 2's formula unchanged (docs/model.md).

**The rotor speed** p changes the period T = 60/p, so the periodic orbit is periodic at fixed
blade azimuth psi = Omega t, not at fixed t.  With z(psi; p) the orbit against azimuth,
y(t; p) = z(Omega t; p), and the fixed-time sensitivity s = dy/dp (the DAE's, with F_p of the
models rebuilt at p +- h as for any parameter) is

    s(t) = w(t) + (t/p) y'(t),      w = dz/dp at fixed azimuth, periodic,

since Omega is proportional to p.  So s is not periodic: s(T) = s(0) + (T/p) y'(0), and step 2
solves (I - Phi) dx* = N^T (dX(T)/dp - (T/p) y'(0)) (GMRES alike); the normal parts agree, for
G (T/p) v = -(T/p) g_t = -T g_psi = the change of g_p over the revolution.  The outputs are
sampled at fixed azimuth: w = s - (t/p) (v, v') at each sample (v' from the acceleration-level
solve), and the model at p + e samples at the time t p/(p + e).
"""

from __future__ import annotations

import time

import numpy as np

from pydriver.analyses.fatigue_loads import record_basis
from pydriver.analyses.history_outputs import (
    HistoryOutputs,
    amplitudes,
    history_signal,
    output_derivatives,
)
from pydriver.analyses.sensitivity_common import core_parameter, sensitivity_table
from pydriver.core import DifferencePoint, SensitivityParameter
from pydriver.errors import RunError

#: The rotor speed: it changes the revolution period, so its sensitivities are taken at fixed
#: blade azimuth (module doc).
ROTOR_SPEED = ("rotor.rpm", "loads.rotor_rpm")
#: Krylov blocks (one integration over the revolution each) for the periodic start's sensitivities
#: without a monodromy.
MAX_KRYLOV = 60
#: How much a later Krylov block's state tolerances may relax with its sensitivities' (inexact
#: Krylov, :func:`_periodic_start_krylov`).  The sensitivities are out of the error test and take
#: the state's steps, so the state's tolerance sets their step size: relaxing it lets the block
#: take fewer steps, but beyond ~10x their own error grows faster than the relaxation allows.
#: Measured on the main job (8 parameters, rtol 1e-6, block 2 relaxed 100x): state x10 took 900
#: steps instead of 1350 and moved the sensitivities by <= 1.2e-4 of a family's scale; x30 by
#: 7.7e-4 and x100 by 2e-3, against 1.3e-3 between the deck's rtol and 1e-8.
STATE_RELAX_MAX = 10.0


def is_rotor_speed(pl) -> bool:
    """Whether a plan varies the rotor speed."""
    return f"{pl.parameter.group}.{pl.parameter.key}" in ROTOR_SPEED


def worst_points_of(model, fatigue_table: dict | None) -> list[int] | None:
    """Per joint, the index of the worst point around the jacket from a run's fatigue table
    (``fatigue.csv``'s ``angle_deg``, 360 k / points degrees); None without one."""
    if not fatigue_table or "angle_deg" not in fatigue_table:
        return None
    points = int(model.deck.values["fatigue"]["circumferential_points"])
    return [int(round(a / 360.0 * points)) % points for a in fatigue_table["angle_deg"]]


def flight_outputs(model, ts) -> tuple[list, list, np.ndarray]:
    """(names, units, values) of the outputs whose flight sensitivities are reported."""
    o = HistoryOutputs(model, ts)
    return o.names, o.units, np.asarray(o.values)


def flight_outputs_frozen(model, ts, other_model, other_ts) -> np.ndarray:
    """The outputs of ``other_ts`` (a run of ``other_model``) with the selection of ``ts`` held
    (:meth:`HistoryOutputs.frozen`): differences of these are the reference of the sensitivities
    across a change of selection."""
    per_hour = record_basis(other_model, other_ts, periodic=True)["per_hour"] if "fatigue" in model.deck.groups else None
    return HistoryOutputs(model, ts).frozen(lambda spec: history_signal(other_model, other_ts, spec), per_hour)


def flight_selections(model, ts) -> dict:
    """What each output's value is selected by: the samples of its extremes, its rainflow cycle
    set (reversal samples and counts) and, for a joint's damage, the point around the jacket.
    Between two parameter values with the same selections the outputs are smooth functions of
    the time series (their sensitivities exact); a change of selection is a kink."""
    o = HistoryOutputs(model, ts)
    out = {}
    for name, rule in zip(o.names, o.rules):
        if rule[0] in ("sample", "range"):
            out[name] = tuple(rule[2:4]) if rule[0] == "range" else (rule[2], rule[3])
        else:
            # The cycles that carry the damage: one below 1e-9 of the sum S^m changes the output by
            # less than that when it appears or vanishes (noise-level cycles on a plateau do).
            cyc, x = rule[2], history_signal(model, ts, rule[1])
            m = rule[3].exponent if rule[0] == "damage" else rule[3]
            amp, _ = amplitudes(x, x, cyc)
            share = cyc.counts * (amp / max(float(np.max(amp, initial=0.0)), 1e-300)) ** m
            keep = share >= 1.0e-9 * max(float(np.sum(share)), 1e-300)
            out[name] = (rule[1], tuple(cyc.start[keep]), tuple(cyc.end[keep]), tuple(cyc.counts[keep]))
    return out


def _next_block(image, basis, coef_last, rhs_norms, tol):
    """The next Krylov block (:func:`_periodic_start_krylov`): orthonormal directions of the
    residual's part outside the space.

    ``image`` = Psi B_k, the last block's products.  Its part outside span(basis) (orthogonalised
    twice, for round-off) times the last block's coefficients ``coef_last`` is the residual of
    each parameter that the space cannot yet reduce; relative to that parameter's right-hand
    side (``rhs_norms``) these columns' singular directions are what the next block must span.
    The smallest are left out while the root-sum-square of their singular values, the relative
    residual they can leave, stays below tol / 2: the convergence test (max relative residual <
    tol) then still passes.  Weighting by each parameter's own right-hand side and coefficients
    keeps the directions that parameter needs, however small its right-hand side, and drops
    those no parameter needs (the main job: 3 columns against 5 for a cut of the unweighted
    directions at 1e-2 tol of the smallest right-hand side; the sensitivities moved by <= 3.4e-6
    of a family's scale)."""
    new = image
    q_all, _ = np.linalg.qr(basis)
    for _ in range(2):
        new = new - q_all @ (q_all.T @ new)
    u, sv, _ = np.linalg.svd((new @ coef_last) / rhs_norms, full_matrices=False)
    # left_out[k]: root-sum-square of the singular values from k on.
    left_out = np.sqrt(np.cumsum((sv ** 2)[::-1])[::-1])
    keep = int(np.count_nonzero(left_out > 0.5 * tol))
    return u[:, :keep]


def _periodic_start_krylov(model, settings, period, q0, v0, d_x, t_out):
    """The periodic start's sensitivities s* = (s_q, s_v) without the monodromy, and the
    homogeneous part of the sensitivities along the revolution, by block GMRES in one Krylov
    space shared by all parameters.

    s* solves (I - Psi) s* = dX(T)/dp, Psi s the sensitivity after one revolution from s with the
    parameter partials off (the core's projection onto the constraint rows included).  The space
    grows by blocks: B_0 = the right-hand sides, B_(k+1) = the directions of the residual that
    B_k leaves outside the space, each parameter's relative to its right-hand side, cut where
    the directions left out leave less than half the tolerance (:func:`_next_block`): a
    monodromy of low numerical rank, as a damped cable's, gives a thin block (the main job's has
    3 multiplier pairs above 1e-8; 8 parameters take blocks of 8 and 3 columns).  Each block is
    one integration of its
    columns over the revolution, recording S(t) B_k at every output time t_out; s* = B c with c
    the least-squares solution of (B - Psi B) c = dX(T)/dp per parameter, and the homogeneous
    part of the sensitivities is S(t) s* = (S(t) B) c: no further integration (the periodic
    revolution's sensitivities are the first integration's plus these, by linearity).

    The rates are weighted by T / 2 pi, so that q and v count alike.  Converged at a relative
    residual of the integration's rtol, beyond which the products carry integration error only.
    One-parameter GMRES (the earlier way) took 4 one-revolution products per parameter here,
    this 2 blocks: 8 + 3 column-revolutions for 8 parameters against 32."""
    nq, n_par = model.nq, d_x.shape[1]
    scale = np.concatenate([np.ones(nq), np.full(nq, period / (2.0 * np.pi))])
    tol = float(settings["rtol"])
    rhs = scale[:, None] * d_x
    size = max(float(np.max(np.linalg.norm(rhs, axis=0))), 1e-300)
    rhs_norms = np.maximum(np.linalg.norm(rhs, axis=0), 1e-300)
    basis, images, hist_q, hist_v, start_q, start_v = [], [], [], [], [], []
    work = {"matvecs": 0, "steps": 0, "block_columns": [], "tolerance_scales": []}
    block = rhs / size
    res = [np.inf]
    relax = 1.0
    for it in range(MAX_KRYLOV):
        w_in = block / scale[:, None]
        m = block.shape[1]
        # The parameter partials off: a difference of this model with itself, at h = pbar = 1.
        off = [SensitivityParameter(step=1.0, scale=1.0,
                                    points=[DifferencePoint(1.0, 0.5, None), DifferencePoint(-1.0, -0.5, None)])] * m
        # The state of a relaxed block is relaxed too, by at most STATE_RELAX_MAX (see there).
        state_relax = min(relax, STATE_RELAX_MAX)
        run = model.core.parameter_sensitivity(
            dict(settings, rtol=tol * state_relax, atol=settings["atol"] * state_relax), 0.0, q0, v0, off,
            w_in[:nq], w_in[nq:], t_out, tolerance_scale=relax / state_relax)
        work["matvecs"] += m
        work["tolerance_scales"].append(relax)
        work["steps"] += run["stats"]["steps"]
        work["block_columns"].append(m)
        basis.append(block)
        images.append(scale[:, None] * np.vstack([run["sq"][:, -1, :], run["sv"][:, -1, :]]))
        hist_q.append(run["sq"])
        hist_v.append(run["sv"])
        start_q.append(run["sq0"])
        start_v.append(run["sv0"])
        b_all, img = np.hstack(basis), np.hstack(images)
        coef, *_ = np.linalg.lstsq(b_all - img, rhs, rcond=None)
        res = np.linalg.norm((b_all - img) @ coef - rhs, axis=0) / rhs_norms
        if max(res) < tol:
            hom_q = np.einsum("itj,jk->itk", np.concatenate(hist_q, axis=2), coef)
            hom_v = np.einsum("itj,jk->itk", np.concatenate(hist_v, axis=2), coef)
            hom0 = (np.hstack(start_q) @ coef, np.hstack(start_v) @ coef)
            return (b_all @ coef) / scale[:, None], (hom_q, hom_v, hom0), {
                "periodic_start": "krylov", "krylov_iterations": it + 1, **work}
        block = _next_block(images[-1], b_all, coef[-block.shape[1]:], rhs_norms, tol)
        if block.shape[1] == 0:
            break
        # Inexact Krylov (Simoncini & Szyld, SIAM J. Sci. Comput. 25 (2003) 454, and Bouras &
        # Fraysse, SIAM J. Matrix Anal. Appl. 26 (2005) 660): the next block only corrects the
        # residual left, max(res) relative, so its products need that much less accuracy: the
        # error they bring is ~ max(res) x (their error) against the first block's own.  So its
        # columns are integrated at tolerances 1/max(res) looser, at most to 1e-2 (beyond it the
        # corrector's test would pass unconverged iterates); the block's state by at most
        # STATE_RELAX_MAX of that.
        relax = float(np.clip(1.0 / max(max(res), 1e-300), 1.0, max(1.0, 1.0e-2 / tol)))
    raise RunError(f"deck '{model.name}': the periodic start's sensitivities did not converge in {len(basis)} "
                   f"Krylov blocks (relative residual {max(res):.1e} > rtol {tol:g}); turn &solver floquet on "
                   "(the monodromy's direct solve)")


def flight_result_sensitivities(model, plans, result) -> dict:
    """The registry's differentiation of a finished flight run (pydriver.analyses.registry): from
    the start of its periodic orbit, each joint's worst point around the jacket taken from its own
    fatigue table."""
    orbit = result.extra["orbit"]
    return flight_sensitivities(model, plans, orbit["period_s"], orbit, result.timeseries,
                                worst_points_of(model, result.extra.get("tables", {}).get("fatigue.csv")))


def flight_sensitivities(model, plans, period: float, start: dict, ts: dict, worst_points=None,
                         jacket_extremes: bool = False) -> dict:
    """d(output)/dp of a flight's periodic revolution (module doc).

    Parameters
    ----------
    model : Model
        The run's model.
    plans : list of Plan
        The parameters with their rebuilt models (:func:`pydriver.analyses.sensitivities.plan`).
    period : float
        The revolution period T [s].
    start : dict
        The start on the orbit at t = 0 where the monodromy was taken: ``q0``, ``v0``, ``phi``
        (2 nf, 2 nf) and ``basis`` N (nq, nf).
    ts : dict
        The run's last revolution (time series), which selects the peaks and cycles; its times
        relative to its start are the output times.
    worst_points : list of int, optional
        Per joint, its worst point around the jacket as the run's fatigue analysis found it
        (:func:`worst_points_of`); None: found again here.
    jacket_extremes : bool, optional
        Also the largest, smallest and first value of each joint's worst point's history
        (``jacket_max{j}``, ``jacket_min{j}``, ``jacket_first{j}``) and the damage per hour of its
        closed cycles (``closed_damage_per_hour{j}``): what a usage spectrum combines across its
        regimes (:mod:`pydriver.analyses.spectrum_design`).
    """
    t_wall = time.perf_counter()
    settings = model.sensitivity_solver_settings()
    points = [core_parameter(pl) for pl in plans]
    n_par, nq = len(plans), model.nq
    q0, v0 = start["q0"], start["v0"]
    zeros = np.zeros((nq, n_par))
    t_rel = np.asarray(ts["t"], float) - float(ts["t"][0])
    # Without the monodromy the first integration records every output time: the revolution's
    # sensitivities are its own plus the Krylov blocks' homogeneous part (_periodic_start_krylov).
    t_first = [period] if "phi" in start else t_rel[1:]
    first = model.core.parameter_sensitivity(settings, 0.0, q0, v0, points, zeros, zeros, t_first)
    # The rotor speed's columns: s(T) = s(0) + (T/p) y'(0) (module doc, "The rotor speed").
    speed = np.array([is_rotor_speed(pl) for pl in plans])
    rates0 = model.core.consistent_start(q0, v0, 0.0)
    # Only the rotor speed's columns divide by their value (never 0: a flight's speed is > 0);
    # another parameter's value may be 0 and is not divided by.
    per_speed = np.zeros(len(plans))
    per_speed[speed] = period / np.array([pl.parameter.value for pl, is_speed in zip(plans, speed) if is_speed])
    secular = np.outer(np.concatenate([rates0["v"], rates0["vdot"]]), per_speed)
    d_x = np.vstack([first["sq"][:, -1, :], first["sv"][:, -1, :]]) - secular
    if "phi" in start:
        basis, phi = start["basis"], start["phi"]
        nf = basis.shape[1]
        try:
            red = np.linalg.solve(np.eye(2 * nf) - phi, np.vstack([basis.T @ d_x[:nq], basis.T @ d_x[nq:]]))
        except np.linalg.LinAlgError:
            raise RunError(f"deck '{model.name}': I - Phi is singular (a Floquet multiplier at 1): the periodic "
                           "state has no sensitivity to the parameters") from None
        d_start, how = np.vstack([basis @ red[:nf], basis @ red[nf:]]), {"periodic_start": "monodromy"}
        second = model.core.parameter_sensitivity(settings, 0.0, q0, v0, points, d_start[:nq], d_start[nq:],
                                                  t_rel[1:])
    else:
        d_start, (hom_q, hom_v, hom0), how = _periodic_start_krylov(model, settings, period, q0, v0, d_x, t_rel[1:])
        second = {"q0": first["q0"], "v0": first["v0"], "q": first["q"], "v": first["v"],
                  "sq0": first["sq0"] + hom0[0], "sv0": first["sv0"] + hom0[1],
                  "sq": first["sq"] + hom_q, "sv": first["sv"] + hom_v, "stats": None}
    # Sample 0 is the start, with its consistent start sensitivity.
    q = np.column_stack([second["q0"], second["q"]])
    v = np.column_stack([second["v0"], second["v"]])
    sq = np.concatenate([second["sq0"][:, None, :], second["sq"]], axis=1)
    sv = np.concatenate([second["sv0"][:, None, :], second["sv"]], axis=1)
    d_end = np.vstack([second["sq"][:, -1, :], second["sv"][:, -1, :]]) - secular
    if np.any(speed):
        # At a fixed blade azimuth: w = s - (t/p) y' is the periodic part (module doc).
        vdot = np.column_stack([model.core.consistent_start(q[:, k], v[:, k], t)["vdot"]
                                for k, t in enumerate(t_rel)])
        for k in np.flatnonzero(speed):
            c = t_rel / plans[k].parameter.value
            sq[:, :, k] -= c * v
            sv[:, :, k] -= c * vdot
    if "phi" in start:
        # In Phi's coordinates: the core completes s_v(0) = N db by the velocity rows' normal part.
        d_end = np.vstack([basis.T @ d_end[:nq], basis.T @ d_end[nq:]])
        d_start = red
    periodicity = float(np.max(np.abs(d_end - d_start)) / max(float(np.max(np.abs(d_start))), 1e-300))
    outputs = HistoryOutputs(model, ts, worst_points=worst_points, jacket_extremes=jacket_extremes)
    values = output_derivatives(model, plans, outputs, ts, t_rel, q, v, sq, sv, speed)
    per_hour = np.array([rule[0] == "damage" for rule in outputs.rules])
    for k in np.flatnonzero(speed):
        # Damage per hour = damage per revolution x 60 p revolutions per hour.
        values[k] = values[k] + np.where(per_hour, np.asarray(outputs.values) / plans[k].parameter.value, 0.0)
    sens = sensitivity_table(plans, outputs.names, outputs.units, values, [])
    sens["summary"]["method"] = (
        "forward sensitivities through the DAE (IDAS, parameter partials by differences of the rebuilt model "
        "at the fixed state), periodic start by (I - Phi)^-1 dX(T)/dp; peaks at the arg-max sample, damage "
        "and DEL with the rainflow cycle set held fixed (docs/model.md, \"Design sensitivities of a flight\")")
    sens["summary"]["periodicity_residual"] = periodicity
    solver = {"first": first["stats"], **how, "linear_solver": settings["linear_solver"]}
    if second["stats"] is not None:
        solver["second"] = second["stats"]
    sens["summary"]["solver"] = solver
    sens["values"] = dict(zip(outputs.names, (float(x) for x in outputs.values)))
    sens["summary"]["wall_time_s"] = time.perf_counter() - t_wall
    return sens
