"""The block (Schur-complement) linear solver of the GGL iteration matrix and the kept
physics Jacobian (issue 4, item 3).

The block solver drops the O(|mu|) block d(G^T mu)/dq, which is exactly zero at the
consistent starts used here (mu = 0), so it must solve the same linear system as a dense LU.
"""

import numpy as np
import pytest

import pydriver
from pydriver import core_probes as probes
from conftest import INPUTS

DECKS = ["three_body", "six_link_dynamic", "uh60_part2_decay"]


def _iteration(stem, cj, n_rhs=4):
    """The iteration matrix at the deck's consistent start (mu = 0) and its block solutions."""
    m = pydriver.Model.from_deck(INPUTS / f"{stem}.nml")
    y, yd = probes.consistent_ggl_state(m.core, m.q0, m.v0)
    b = np.random.default_rng(7).standard_normal((len(y), n_rhs))
    out = probes.iteration_matrix(m.core, y, yd, cj, b)
    return out["jacobian"], out["x_block"], b


@pytest.mark.parametrize("stem", DECKS)
@pytest.mark.parametrize("cj", [1.0, 1.0e3, 1.0e8, 1.0e16])
def test_block_solve_is_backward_stable(stem, cj):
    """Normwise backward error ||J x - b|| / (||J|| ||x|| + ||b||) at machine precision.

    cj spans IDA's range from long steps (1) to the first steps of tight runs (1e16), where
    J's condition number reaches 1e34 and forward errors mean nothing for any solver; the
    backward error is what LU with partial pivoting guarantees (~ n eps).  Measured: 1e-17
    and below; the bound 1e-13 leaves 500x for other BLAS builds while an elimination slip
    (a wrong sign or block) gives O(1)."""
    jac, x, b = _iteration(stem, cj)
    for k in range(b.shape[1]):
        err = np.abs(jac @ x[:, k] - b[:, k]).max()
        scale = np.abs(jac).sum(axis=1).max() * np.abs(x[:, k]).max() + np.abs(b[:, k]).max()
        assert err / scale < 1e-13


@pytest.mark.parametrize("stem", DECKS)
@pytest.mark.parametrize("cj", [1.0e3, 1.0e6, 1.0e8, 1.0e14, 1.0e16])
def test_block_solve_keeps_every_block_at_short_steps(stem, cj):
    """Each block of the solution (q, v, lambda, mu corrections) to 1e-6 of its own size.

    At large cj the iteration matrix is badly scaled, not ill-conditioned: equilibrated (rows,
    then columns, by their largest entry) its condition number stays <= 1e8 (measured 1e2 ...
    2e7), so the reference, LAPACK's LU of the equilibrated matrix, is good to ~eps cond.  The
    normwise backward error of the test above cannot see the v and lambda blocks there; IDA's
    Newton iteration does (it failed down to hmin on the UH-60 decay at atol 1e-12 when the pure
    Schur elimination had 15 % error in them at cj = 1e14).  Measured since the solver factorises
    the whole matrix above cj = 1e6: 2e-8 at worst (the elimination at cj = 1e6); the bound
    leaves 50x for other BLAS builds, and Newton needs only a few digits."""
    jac, x, b = _iteration(stem, cj)
    rows = 1.0 / np.abs(jac).max(axis=1)
    scaled = jac * rows[:, None]
    cols = 1.0 / np.abs(scaled).max(axis=0)
    scaled = scaled * cols[None, :]
    assert np.linalg.cond(scaled) < 1.0e8
    ref = cols[:, None] * np.linalg.solve(scaled, rows[:, None] * b)
    m = pydriver.Model.from_deck(INPUTS / f"{stem}.nml")
    nq, nc = m.nq, m.nc
    for lo, hi in ((0, nq), (nq, 2 * nq), (2 * nq, 2 * nq + nc), (2 * nq + nc, 2 * nq + 2 * nc)):
        if hi > lo:
            assert np.abs(x[lo:hi] - ref[lo:hi]).max() <= 1.0e-6 * np.abs(ref[lo:hi]).max()


def test_block_solver_starts_at_a_tight_absolute_tolerance(deck_copy):
    """UH-60 decay (block solver, the 'auto' choice at n = 11) at rtol 1e-6, atol 1e-12 for
    0.02 s: IDA's first step from rest is ~5e-15 s (cj ~ 1e14).  The run failed there
    (corrector convergence down to hmin) while the block elimination lost the v and lambda
    digits; it now runs and ends where the dense LU run ends, to 1e-8 m (a 0.1 mm motion; at
    rtol 1e-6 each run is within ~1e-9 m of the exact motion, benchmarks/README.md)."""
    ends = []
    for solver in ("'block'", "'dense'"):
        deck = deck_copy("uh60_part2_decay", "solver", {"t_end": "0.02", "atol": "1.0e-12",
                                                         "linear_solver": solver})
        ends.append(_end_state(deck)[1])
    assert np.abs(ends[0] - ends[1]).max() < 1.0e-8


@pytest.mark.parametrize("stem", DECKS)
def test_block_solve_matches_dense_lu_when_well_conditioned(stem):
    """At cj = 1e3 (cond <= 1e10) the block and the dense LU solutions agree to
    cond * eps = 1e-6 relative; measured ~1e-13."""
    jac, x, b = _iteration(stem, 1.0e3)
    ref = np.linalg.solve(jac, b)
    assert np.abs(x - ref).max() / np.abs(ref).max() < 1e-9


def _end_state(deck):
    r = pydriver.run_deck(deck)
    ts = r.timeseries
    return r, np.array([ts[c][-1] for c in ts if c[0] in "xyz" and c[1:].isdigit()])


@pytest.mark.parametrize("changes", [{"linear_solver": "'dense'"}, {"jacobian_max_age": "1"}])
def test_solver_options_give_the_same_motion(deck_copy, changes):
    """The six-link swing with SUNDIALS's dense LU, or with the physics Jacobian formed at
    every setup, ends where the default (block solver, Jacobian kept 50 steps) ends: the
    three differ only in Newton's path, so by the integration error (rtol 1e-8: measured
    7e-10 m for the dense LU, 1e-11 m for the Jacobian age); 1e-7 m is well above it and far
    below the 0.1 m motion."""
    base, x0 = _end_state(INPUTS / "six_link_dynamic.nml")
    other, x1 = _end_state(deck_copy("six_link_dynamic", "solver", changes))
    assert np.abs(x1 - x0).max() < 1e-7
    assert other.summary["max_constraint_violation_m"] < 1e-9


@pytest.mark.parametrize("stem", ["six_link_dynamic", "uh60_part2_decay"])
def test_ggl_constraint_rows_against_formed_jacobian(stem):
    """The residual builds G^T mu and G v without forming G (add_jacobian_transpose_times,
    clamp_velocity); they must equal the products with G from constraint_jacobian
    (finite-difference-checked in test_model_kernels).  Random q, v, mu; only round-off
    separates the two (measured ~1e-16 relative), bound 1e-12."""
    m = pydriver.Model.from_deck(INPUTS / f"{stem}.nml")
    nq, nc = m.nq, m.nc
    n = 2 * nq + 2 * nc
    rng = np.random.default_rng(3)
    y = rng.standard_normal(n)
    yd = rng.standard_normal(n)
    r = probes.ggl_residual(m.core, y, yd)
    y0 = y.copy()
    y0[2 * nq + nc:] = 0.0
    r0 = probes.ggl_residual(m.core, y0, yd)
    q, v, mu = y[:nq], y[nq:2 * nq], y[2 * nq + nc:]
    g_jac = probes.evaluate(m.core, q, v, np.zeros(nq), np.zeros(nc))["G"]
    gtmu = g_jac.T @ mu
    assert np.abs((r - r0)[:nq] - gtmu).max() <= 1e-12 * np.abs(gtmu).max()
    assert np.abs(r0[:nq] - (yd[:nq] - v)).max() <= 1e-13
    gv = g_jac @ v
    assert np.abs(r[2 * nq + nc:] - gv).max() <= 1e-12 * np.abs(gv).max()
