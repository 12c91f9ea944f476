"""What the design sensitivities of every analysis share (static and modal:
:mod:`pydriver.analyses.sensitivities`; flight: :mod:`pydriver.analyses.flight_sensitivities`;
dynamic: :mod:`pydriver.analyses.dynamic_sensitivities`): a plan as the core's sensitivity
integration takes it, the equilibrium's tangents by the implicit function theorem (a static run's
and a dynamic run's start from rest), and the table every analysis reports its derivatives in.
"""

from __future__ import annotations

import numpy as np

from pydriver.core import DifferencePoint, PartialKind, SensitivityParameter
from pydriver.design import ratio_unit
from pydriver.errors import RunError


def core_parameter(pl) -> SensitivityParameter:
    """A plan (:class:`pydriver.analyses.sensitivities.Plan`) as the core's sensitivity
    integration takes it (:meth:`pydriver.core.CoreModel.parameter_sensitivity`): the rebuilt
    models' cores at its difference points, its scale (|p|, or 1 for p = 0), how the core may
    form its partial and the load slots that partial takes."""
    scale = abs(pl.parameter.value) if pl.parameter.value != 0.0 else 1.0
    partial = (PartialKind.LOADS_ONLY if pl.loads_only
               else PartialKind.BODIES_AND_LOADS if getattr(pl, "bodies_and_loads", False)
               else PartialKind.WHOLE_RESIDUALS)
    return SensitivityParameter(step=pl.h, scale=scale,
                                points=[DifferencePoint(s, w, None if m is None else m.core) for s, w, m in pl.points],
                                partial=partial, changed_loads=pl.changed_loads)


def equilibrium_tangents(model, plans: list, q, lam) -> list[np.ndarray]:
    """dx/dp = -(dR/dx)^-1 dR/dp of every plan's parameter at the equilibrium x = (q, lambda)
    (implicit function theorem; :mod:`pydriver.analyses.sensitivities`, module doc).

    Raises
    ------
    RunError
        The static Jacobian is singular there (condition number above 1e13).
    """
    nq, nc = model.nq, model.nc
    base = model.core.static_system(q, lam, jacobian=True)
    jac = np.zeros((nq + nc, nq + nc))
    jac[:nq, :nq] = base["K"]
    if nc:
        jac[:nq, nq:] = -base["G"].T
        jac[nq:, :nq] = base["G"]
    cond = np.linalg.cond(jac)
    if not np.isfinite(cond) or cond > 1.0e13:
        raise RunError(f"deck '{model.name}': the equilibrium is singular (condition number of the "
                       f"static Jacobian {cond:.1e}): its sensitivities are not defined there")
    r0 = np.concatenate([base["residual"], base["g"]])
    out = []
    for pl in plans:
        d_r = np.zeros(nq + nc)
        for _, w, m in pl.points:
            if m is None:
                d_r += w * r0
            else:
                s = m.core.static_system(q, lam)
                d_r += w * np.concatenate([s["residual"], s["g"]])
        out.append(-np.linalg.solve(jac, d_r / pl.h))
    return out


def sensitivity_table(plans: list, names: list, units: list, values: list, warnings: list) -> dict:
    """The sensitivities of the outputs ``names`` (with their ``units``) to every plan's
    parameter (``values``: per plan, one derivative per output) as a run reports them: the
    summary entry, the rows of sensitivities.csv and the warnings."""
    rows = {"output": [], "parameter": [], "value": [], "unit": []}
    table = {n: {} for n in names}
    unit_table = {n: {} for n in names}
    for pl, vals in zip(plans, values):
        p = pl.parameter
        for n, u, v in zip(names, units, vals):
            unit = ratio_unit(u, p.unit)
            rows["output"].append(n)
            rows["parameter"].append(p.name)
            rows["value"].append(float(v))
            rows["unit"].append(unit)
            table[n][p.name] = float(v)
            unit_table[n][p.name] = unit
    summary = {"method": "implicit function theorem at the equilibrium; parameter partials by differences "
                         "of the rebuilt model at the fixed state (docs/model.md, \"Design sensitivities\")",
               "parameters": {pl.parameter.name: {"value": pl.parameter.value, "unit": pl.parameter.unit,
                                                   "step": pl.h, "difference": pl.scheme} for pl in plans},
               "d_output_d_parameter": table, "units": unit_table}
    return {"summary": summary, "rows": rows, "warnings": warnings}
