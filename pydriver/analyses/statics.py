"""Static equilibrium (relative to the model frame: in a turning hub frame, the quasi-static
hover shape of thesis section 5.5)."""

from __future__ import annotations

import contextlib
import time

import numpy as np

from pydriver.analyses.common import base_summary, equilibrium_table, reactions, straight_zy_warnings
from pydriver.analyses.singularity import equilibrium_report
from pydriver.analyses.stability import (distance_from_start, equilibrium_stability, far_warning, require_stable,
                                         stability_summary)
from pydriver.errors import RunError
from pydriver.run_result import Result


def has_pulse(model) -> bool:
    """Whether the deck puts a force pulse on the model (``&loads pulse_body``, a nonzero
    ``pulse_force``: a pulse of zero force is no load, issue 35, and the core gives it no
    switch times either)."""
    return model.deck["loads.pulse_body"] > 0 and bool(np.any(np.asarray(model.deck["loads.pulse_force"]) != 0.0))


@contextlib.contextmanager
def unforced(model):
    """The model without its force pulse for the duration of a ``with`` block: an equilibrium
    and its modes are those of the steady loads; a pulse is a dynamic excitation (issue 20: a
    pulse active at t = 0 had moved the six-link reaction from 75.1 N to 25.1 N and the UH-60
    mode from 26.25 to 26.10 Hz).

    The pulse is switched off in the core (``CoreModel.updated``, issue 23) and back on when the
    block is left, also on an exception.  Scoped rather than for good because the model is the
    caller's: a dynamic run finds its start equilibrium here and then integrates the same model
    with its pulse, and a Model may be run again.  A rebuilt copy (the earlier way) cost a deck
    check and an assembly per call and was a second model of one deck.  Scopes nest.
    """
    if not has_pulse(model):
        yield model
        return
    with model.core.updated({"loads.pulse": 0.0}):
        yield model


def drop_pulse(model):
    """``model`` with its force pulse switched off for good, returned; only for a model built for
    one analysis that nobody else holds (the design sensitivities' and the optimiser's varied
    models).  A model the caller keeps takes :func:`unforced`."""
    if has_pulse(model):
        model.core.update("loads.pulse", 0.0)
    return model


def unforced_note(model) -> list[str]:
    """The summary note saying that a deck's pulse was left out (empty without a pulse)."""
    if has_pulse(model):
        return [f"the force pulse on body {int(model.deck['loads.pulse_body'])} (&loads) is a dynamic "
                f"excitation: this {model.analysis} result is about the unforced state"]
    return []


def equilibrium(model, t: float = 0.0):
    """The equilibrium of the model's steady loads from its start shape.

    Newton on the constraint manifold (``&solver static_method = 'newton'``) or damped dynamic
    settling, the thesis's route (section 5.3, ``'settle'``).  A force pulse is a dynamic
    excitation, not a steady load: the equilibrium is that of the model without it.  An unstable
    equilibrium is a RunError saying what to try (:mod:`pydriver.analyses.stability`), so every
    analysis that starts from one inherits the check.

    Returns
    -------
    q, lam : numpy.ndarray
        Coordinates [rad] and multipliers.
    stats : dict
        Solver statistics.
    """
    with unforced(model):
        q, lam, stats = _solve(model, t)
        require_stable(model, equilibrium_stability(model, q, lam, t), t)
    return q, lam, stats


def _solve(model, t: float):
    """The equilibrium by the deck's static method (:func:`equilibrium`), not yet judged."""
    s = model.deck.values["solver"]
    if s["static_method"] == "newton":
        return model.core.static(model.q0, t, s["newton_tol"], s["newton_max_iter"])
    session = model.core.start(model.solver_settings(), t, model.q0, np.zeros_like(model.q0))
    try:
        q, v = session.advance([t + s["t_end"]])
    finally:
        session.close()
    stats = dict(session.stats)
    vmax = float(np.max(np.abs(v))) if v.size else 0.0
    if vmax > s["settle_tol"]:
        raise RunError(f"deck '{model.name}': dynamic settling: not at rest at t_end (max |qdot| = {vmax:.3e} "
                       "rad/s > settle_tol); increase t_end")
    sample = model.core.sample([t + s["t_end"]], q, np.zeros_like(q))
    return q[:, 0], sample.lam[0], stats


def static_analysis(model, run_dir=None) -> Result:
    """The equilibrium, its reactions, shape table and joint loads (``run_dir``: unused, the
    registry's signature; pydriver.analyses.registry)."""
    t0 = time.perf_counter()
    notes = unforced_note(model)
    with unforced(model):
        q, lam, stats = equilibrium(model)
        zero = np.zeros((model.nq, 1))
        sample = model.core.sample([0.0], q[:, None], zero)
        stability, stability_warnings = stability_summary(model, q, lam)
    wall = time.perf_counter() - t0
    summary = base_summary(model, "static", wall)
    summary.update(solver=stats, equilibrium_stability=stability,
                   max_constraint_violation_m=float(sample.g_max[0]),
                   reactions=reactions(sample.wrenches.at(0), model.nc > 0),
                   tip_m=[float(x) for x in sample.joints[:, -1, 0]],
                   energy_J={"kinetic": 0.0, "potential": float(sample.potential[0])})
    table = equilibrium_table(model, sample)
    near, near_warnings = equilibrium_report(model, q)
    if near is not None:
        summary["cardan_singularity"] = near
    warnings = notes + straight_zy_warnings(model, table["beta_deg"]) + near_warnings + stability_warnings
    if warnings:
        summary["warnings"] = warnings
    return Result(summary=summary, table=table, extra={"q": q, "lambda": lam})
