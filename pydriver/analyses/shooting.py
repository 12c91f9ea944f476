"""The periodic steady state of a flight by shooting (issue 21 item 3; Newton-Picard, issue 39
item 3).

Solve r(x0) = x(T; x0) - x0 = 0 over one rotor period T, in the independent coordinates on the
constraint manifold, x = (a, b) with q = q0 + N a, v = v0 + N b (N: orthonormal null-space basis
of G at the start).  Its Jacobian is Phi - I, Phi the monodromy matrix.  Marching needs as many
revolutions as the slowest mode takes to decay to ``periodic_tol`` (72 for the 0.5 %-damped cable
of benchmarks/shooting_vs_marching.py); Newton with the whole Phi converges in 2-3 iterations
(Peters & Hohenemser 1971; Friedmann & Hammond 1983 use it for rotor blades), but each of its
revolutions carries 2 nf sensitivity columns and cost 60-80 plain ones on that cable.

So this is the Newton-Picard method (Lust, Roose, Spence & Champneys, SIAM J. Sci. Comput. 19
(1998) 1188-1209): Newton only on the subspace V of the few slowly decaying modes, Picard (a plain
period map, i.e. marching) on its complement, where every mode shrinks by a factor
|rho| < PICARD_RATE a revolution anyway.  V is spanned by the hover state's modes whose hover
multiplier exp(-zeta w T) is at least PICARD_RATE (pydriver.analyses.floquet_subspace, the same
estimate that selects the Floquet subspace), each as a displacement (u, 0) and a velocity
(0, Omega u); one revolution with those k columns (``CoreModel.monodromy_columns``) gives
Phi V, and the update is
    dx = V (V^T Phi V - I)^-1 (-V^T r) + (I - V V^T) r
(Lust et al.'s eq. 3.10 without the coupling term V^T Phi (I - V V^T) r, which is small when V is
nearly invariant and costs one more column: the iteration then converges linearly at a rate
below PICARD_RATE instead of quadratically, in 2-4 iterations on the main job's cables).  The
columns only steer Newton, so they are integrated to COLUMN_ATOL, loose enough that the state's
own error test sets the steps.

The test of convergence is that of marching: the largest distance of a centre of mass between
x0 and x(T) below ``periodic_tol``; the flight analysis then marches from the converged state and
checks two whole revolutions against each other as before.  There is no whole monodromy here:
Floquet stability and the periodic start of the design sensitivities take theirs as after
marching (pydriver.analyses.flight).
"""

from __future__ import annotations

import numpy as np

from pydriver.analyses.statics import equilibrium
from pydriver.errors import RunError

#: Newton-Picard iterations before shooting gives up (it converges in 2-4 from the equilibrium).
MAX_ITERATIONS = 12
#: Modes whose hover multiplier is below this are left to Picard (module doc): from a start
#: transient of 1e-3 m they reach a periodic_tol of 1e-6 m in at most 6 revolutions even alone.
#: Measured on the 0.5 %-damped cable (benchmarks/shooting_vs_marching.py, 5 of its hover modes
#: above 0.3): 3 iterations; with 0.5 (3 modes) 5, with 0.8 (1 mode) 13.
PICARD_RATE = 0.3
#: Absolute tolerance of the Newton columns per unit of a direction (module doc): the update's
#: Jacobian needs a few digits only (an inexact Newton, Dembo, Eisenstat & Steihaug 1982).
COLUMN_ATOL = 1.0e-2


def newton_directions(period: float, hover) -> tuple[np.ndarray, np.ndarray]:
    """The start perturbations (dq, dv) (nq, 2 k) spanning V: the hover modes with a hover
    multiplier of at least PICARD_RATE, at least the least damped one (a well damped cable then
    converges in Newton's 2-3 iterations instead of Picard's 4-6), as (u, 0) and (0, Omega u),
    u of unit length."""
    from pydriver.analyses.floquet_subspace import hover_multipliers
    rho = hover_multipliers(hover.summary, period)
    count = max(1, int(np.count_nonzero(rho >= PICARD_RATE)))
    shapes = np.asarray(hover.extra["mode_shapes_q"], float)[:, :count]
    u = shapes / np.linalg.norm(shapes, axis=0)
    zero = np.zeros_like(u)
    return np.hstack([u, zero]), np.hstack([zero, 2.0 * np.pi / period * u])


def periodic_start(model, period: float, tol: float, hover=None):
    """(q0, v0, info): a start on the periodic orbit by Newton-Picard (module doc); ``info`` holds
    the iterations, the differences, the solver work and the Newton columns.  ``hover``: the
    flight's hover modes (a modal Result), computed here when not given."""
    if hover is None:
        from pydriver.analyses.hover_modes import hover_modes
        hover = hover_modes(model)
    settings = model.solver_settings()
    q, _, _ = equilibrium(model, t=0.0)
    v = np.zeros_like(q)
    dq, dv = newton_directions(period, hover)
    differences, steps = [], 0
    for it in range(MAX_ITERATIONS):
        mono = model.core.monodromy_columns(settings, 0.0, q, v, [period], dq, dv, COLUMN_ATOL)
        steps += mono["stats"]["steps"]
        qs, vs, basis = mono["q0"], mono["v0"], mono["basis"]
        q_end, v_end = mono["q"][:, -1], mono["v"][:, -1]
        cm0 = model.core.shape(qs, 0.0)["cm"]
        cm1 = model.core.shape(q_end, period)["cm"]
        differences.append(float(np.max(np.abs(cm1 - cm0))))
        if differences[-1] < tol:
            return qs, vs, {"iterations": it + 1, "differences_m": differences, "steps": steps,
                            "newton_columns": int(dq.shape[1])}
        nf = basis.shape[1]
        residual = np.concatenate([basis.T @ (q_end - qs), basis.T @ (v_end - vs)])
        # V orthonormal in x (the directions as integrated: their parts off the manifold dropped).
        v_basis, r_factor = np.linalg.qr(np.vstack([basis.T @ dq, basis.T @ dv]))
        try:
            phi_v = np.linalg.solve(r_factor.T, mono["images"].T).T       # Phi V
            newton = np.linalg.solve(v_basis.T @ phi_v - np.eye(v_basis.shape[1]), -(v_basis.T @ residual))
        except np.linalg.LinAlgError:
            raise RunError(f"deck '{model.name}': shooting: V^T Phi V - I is singular (a Floquet multiplier at "
                           "1: a neutral mode, e.g. a free coordinate without a spring); use periodic_method = "
                           "'marching'") from None
        delta = v_basis @ newton + (residual - v_basis @ (v_basis.T @ residual))
        q = qs + basis @ delta[:nf]
        v = vs + basis @ delta[nf:]
    raise RunError(f"deck '{model.name}': shooting did not converge in {MAX_ITERATIONS} Newton-Picard iterations (the "
                   f"start and end of the period still differ by {differences[-1]:.3g} m > periodic_tol = {tol:g} m); "
                   "use periodic_method = 'marching'")
