"""Design sensitivities of a dynamic run (``&design parameters`` with ``analysis = 'dynamic'``;
issue 24; docs/model.md "Design sensitivities of a dynamic run").

The run's time series is a smooth function of the parameters; its outputs' derivatives come
from the forward sensitivities s = dy/dp through the DAE, as in a flight
(:mod:`pydriver.analyses.flight_sensitivities`; the outputs and their rules are
:mod:`pydriver.analyses.history_outputs`), with two differences:

1. **The start.**  A run from the deck's shape starts at the deck's shape projected onto the
   constraint manifold (``Model.q0``), which moves with a parameter that moves the constraint:
   s(0) is the difference of the rebuilt models' own projected starts (O(h^2); zero for a
   parameter that leaves the constraint alone).  A least-norm correction would be another
   first-order start: the projection's steps are not least-norm (energy descent).  A run from rest in the equilibrium
   (``&case start = 'equilibrium'``) starts at q*(p): s_q(0) = dq*/dp by the implicit function
   theorem at the equilibrium
   (:func:`pydriver.analyses.sensitivity_common.equilibrium_tangents`, the static runs'
   formula), s_v(0) = 0.
2. **Pulse edges.**  The core steps onto every switch time of the loads and restarts the
   sensitivities there with the state (IDASensReInit; s_q, s_v continuous, s_v' and s_lambda
   made consistent with the loads after the switch): the switch times do not depend on the
   differentiable keys.

The outputs are those of a flight's revolution over the whole record: reaction extremes, peak
and amplitude joint loads, and with ``&fatigue`` the damage per hour and DELs of the record
repeated (rainflow of the open history, its residue as half cycles, the cycle set held fixed).
"""

from __future__ import annotations

import contextlib
import time

import numpy as np

from pydriver.analyses.history_outputs import HistoryOutputs, output_derivatives
from pydriver.analyses.sensitivity_common import (
    core_parameter,
    equilibrium_tangents,
    sensitivity_table,
)
from pydriver.analyses.statics import equilibrium, unforced
from pydriver.errors import RunError


def start_sensitivities(model, plans) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(q0, v0, s_q(0), s_v(0)) of the run's start (module doc, item 1)."""
    nq, n_par = model.nq, len(plans)
    sv0 = np.zeros((nq, n_par))
    if model.deck["case.start"] == "equilibrium":
        q, lam, _ = equilibrium(model)
        with contextlib.ExitStack() as scope:       # the steady loads: every pulse off in scope
            for m in [model] + [m for pl in plans for _, _, m in pl.points if m is not None]:
                scope.enter_context(unforced(m))
            sq0 = np.column_stack([dx[:nq] for dx in equilibrium_tangents(model, plans, q, lam)])
        return q, np.zeros(nq), sq0, sv0
    # The deck's shape and rates as each rebuilt model starts them (projected onto its constraint
    # manifold): the derivative of the start the whole run takes, to O(h^2).
    sq0 = np.zeros((nq, n_par))
    for k, pl in enumerate(plans):
        for _, w, m in pl.points:
            sq0[:, k] += w * (model if m is None else m).q0 / pl.h
            sv0[:, k] += w * (model if m is None else m).v0 / pl.h
    return model.q0, model.v0, sq0, sv0


def dynamic_result_sensitivities(model, plans, result) -> dict:
    """The registry's differentiation of a finished dynamic run (pydriver.analyses.registry)."""
    return dynamic_sensitivities(model, plans, result.timeseries)


def dynamic_sensitivities(model, plans, ts: dict, worst_points=None, jacket_extremes: bool = False) -> dict:
    """d(output)/dp of a dynamic run (module doc) from its time series ``ts`` (in memory);
    ``worst_points`` and ``jacket_extremes`` as in
    :func:`pydriver.analyses.flight_sensitivities.flight_sensitivities` (a usage spectrum's run-up
    at the spectrum's worst points)."""
    if ts is None:
        raise RunError(f"deck '{model.name}': the design sensitivities of a dynamic run need its time series in "
                       "memory; this run streamed it to disk (a larger &solver dt_out keeps it in memory)")
    t_wall = time.perf_counter()
    points = [core_parameter(pl) for pl in plans]
    q0, v0, sq0, sv0 = start_sensitivities(model, plans)
    t = np.asarray(ts["t"], float)
    run = model.core.parameter_sensitivity(model.solver_settings(), float(t[0]), q0, v0, points, sq0, sv0, t[1:])
    q = np.column_stack([run["q0"], run["q"]])
    v = np.column_stack([run["v0"], run["v"]])
    sq = np.concatenate([run["sq0"][:, None, :], run["sq"]], axis=1)
    sv = np.concatenate([run["sv0"][:, None, :], run["sv"]], axis=1)
    outputs = HistoryOutputs(model, ts, periodic=False, worst_points=worst_points, jacket_extremes=jacket_extremes)
    values = output_derivatives(model, plans, outputs, ts, t, q, v, sq, sv)
    sens = sensitivity_table(plans, outputs.names, outputs.units, values, [])
    sens["summary"]["method"] = (
        "forward sensitivities through the DAE (IDAS, parameter partials by differences of the rebuilt model at "
        "the fixed state; restarted at pulse edges), start from the deck's shape or dq*/dp of the equilibrium; "
        "extremes at the arg-max sample, damage and DEL with the rainflow cycle set held fixed (docs/model.md, "
        "\"Design sensitivities of a dynamic run\")")
    sens["summary"]["solver"] = run["stats"]
    sens["values"] = dict(zip(outputs.names, (float(x) for x in outputs.values)))
    sens["summary"]["wall_time_s"] = time.perf_counter() - t_wall
    return sens
