"""The linearised equations of the modal and Campbell analyses against finite differences.

Statics and modal analysis take the tangent stiffness K = d(residual at rest)/dq and the damping
matrix D = d/dv (v = vdot = 0, multipliers fixed) from the analytic derivatives as whole
matrices (statics.f90, rest_tangent; against the tangent sweeps in
tests/test_analytic_derivatives.py).  Here they are rebuilt independently from central differences of
the inverse-dynamics residual M vdot - k - G^T lambda (the probe ``evaluate``), projected on the
same null-space basis N of G, and compared with the K_r = N^T K N and D_r = N^T D N that the
eigenvalue problems use.  Decks: the clamped UH-60 cable with gravity and springs (modal deck),
the turning hub frame (Campbell deck: centrifugal stiffness, gyroscopic damping) and the
physical xyz cable with rotation-vector springs and cross-flow drag (forward flight).
"""

import numpy as np
import pytest

import pydriver
from pydriver import core_probes as probes
from conftest import INPUTS
from pydriver.analyses.statics import equilibrium

DECKS = ["uh60_part2_modal", "uh60_part2_campbell", "uh60_part2_forward_flight_cable"]


def _central_difference_matrices(m, q, lam, h_q, h_v):
    """Columns of d(residual)/dq (step h_q) and d(residual)/dv (step h_v) at rest."""
    nq = m.nq
    zero = np.zeros(nq)

    def residual(qq, vv):
        return probes.evaluate(m.core, qq, vv, zero, lam)["residual"]

    k_fd, d_fd = np.empty((nq, nq)), np.empty((nq, nq))
    for k in range(nq):
        e = np.zeros(nq)
        e[k] = 1.0
        k_fd[:, k] = (residual(q + h_q * e, zero) - residual(q - h_q * e, zero)) / (2.0 * h_q)
        d_fd[:, k] = (residual(q, h_v * e) - residual(q, -h_v * e)) / (2.0 * h_v)
    return k_fd, d_fd


@pytest.mark.parametrize("stem", DECKS)
def test_reduced_stiffness_and_damping_match_central_differences(stem):
    """Stiffness: step 1e-5 rad; truncation ~h^2 of the entries (1e-10) and round-off ~eps |f| /
    (h |K|) ~ 1e-11 (measured 4e-12 ... 6e-12 of the largest entry).  Damping: its entries
    (~0.05 N m s) are small next to the residual (gravity and centrifugal moments), so its
    difference is bound by round-off (error ~ 1/h: 3e-9 at 1e-5 rad/s); the rates enter the
    residual linearly (dampers), quadratically (Coriolis and velocity terms) or smoothly (drag in
    a stream), so a step of 1e-3 rad/s adds no truncation beyond ~1e-11 (measured 3e-12 ...
    4e-11).  Bound 1e-7 of the largest entry of each matrix: a margin of over 1000 on both.
    Both keep their skew parts: the damping's gyroscopic one, which the Campbell and flight
    decks have (12 % and 46 % of the largest entry), and the stiffness's circulatory one (7e-4 of
    the largest entry on the flight cable: far above the bound, so the comparison checks it;
    the damped eigenproblems use it, the undamped one takes the symmetric part)."""
    m = pydriver.Model.from_deck(INPUTS / f"{stem}.nml")
    q, lam, _ = equilibrium(m)
    mats = m.core.modal_matrices(q, lam)
    basis = mats["basis"]
    k_fd, d_fd = _central_difference_matrices(m, q, lam, 1.0e-5, 1.0e-3)
    k_r = basis.T @ k_fd @ basis
    d_r = basis.T @ d_fd @ basis
    assert np.abs(mats["K_r"] - k_r).max() <= 1.0e-7 * np.abs(k_r).max()
    assert np.abs(mats["D_r"] - d_r).max() <= 1.0e-7 * np.abs(d_r).max()
    # The basis is orthonormal and spans the null space of G at the equilibrium.
    g = probes.evaluate(m.core, q, np.zeros(m.nq), np.zeros(m.nq), lam)["G"]
    assert np.allclose(basis.T @ basis, np.eye(basis.shape[1]), atol=1.0e-12)
    if m.nc:
        assert np.abs(g @ basis).max() <= 1.0e-12 * max(1.0, np.abs(g).max())
