"""The periodic steady state of a flight by shooting (issue 21 item 3).

Newton on r(x0) = x(T; x0) - x0 = 0 over one rotor period T, in the independent coordinates on
the constraint manifold, x = (a, b) with q = q0 + N a, v = v0 + N b (N: orthonormal null-space
basis of G at the start).  The Jacobian is Phi - I with Phi the monodromy matrix, integrated
with the state by IDAS forward sensitivities (``CoreModel.monodromy``, docs/model.md
"Monodromy matrix").  Each iteration is one revolution; marching needs as many revolutions as
the slowest mode takes to decay to ``periodic_tol`` (29 for a lightly damped 16-body cable),
Newton converges quadratically from the equilibrium (Peters & Hohenemser 1971; Friedmann &
Hammond 1983 use the same shooting for rotor blades).

The test of convergence is that of marching: the largest distance of a centre of mass between
x0 and x(T) below ``periodic_tol``; the flight analysis then marches from the converged state
and checks two whole revolutions against each other as before.  The monodromy of the last
iteration is the one Floquet theory needs (:mod:`pydriver.analyses.floquet`).
"""

from __future__ import annotations

import numpy as np

from pydriver.analyses.statics import equilibrium
from pydriver.errors import RunError

#: Newton iterations before shooting gives up (it converges in 2-4 from the equilibrium).
MAX_ITERATIONS = 12


def periodic_start(model, period: float, tol: float):
    """(q0, v0, info): a start on the periodic orbit; ``info`` holds the iterations, the
    differences, the solver work and the monodromy ``phi`` at the converged start."""
    settings = model.solver_settings()
    q, _, _ = equilibrium(model, t=0.0)
    v = np.zeros_like(q)
    differences, steps = [], 0
    for it in range(MAX_ITERATIONS):
        mono = model.core.monodromy(settings, 0.0, q, v, [period])
        steps += mono["stats"]["steps"]
        qs, vs = mono["q0"], mono["v0"]
        q_end, v_end = mono["q"][:, -1], mono["v"][:, -1]
        cm0 = model.core.shape(qs, 0.0)["cm"]
        cm1 = model.core.shape(q_end, period)["cm"]
        differences.append(float(np.max(np.abs(cm1 - cm0))))
        if differences[-1] < tol:
            return qs, vs, {"iterations": it + 1, "differences_m": differences, "steps": steps,
                            "phi": mono["phi"], "basis": mono["basis"]}
        basis, phi = mono["basis"], mono["phi"]
        nf = basis.shape[1]
        residual = np.concatenate([basis.T @ (q_end - qs), basis.T @ (v_end - vs)])
        try:
            delta = np.linalg.solve(phi - np.eye(2 * nf), -residual)
        except np.linalg.LinAlgError:
            raise RunError(f"deck '{model.name}': shooting: Phi - I is singular (a Floquet multiplier at 1: a "
                           "neutral mode, e.g. a free coordinate without a spring); use periodic_method = "
                           "'marching'") from None
        q = qs + basis @ delta[:nf]
        v = vs + basis @ delta[nf:]
    raise RunError(f"deck '{model.name}': shooting did not converge in {MAX_ITERATIONS} Newton iterations (the "
                   f"start and end of the period still differ by {differences[-1]:.3g} m > periodic_tol = {tol:g} m); "
                   "use periodic_method = 'marching'")
