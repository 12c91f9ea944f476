"""The O(n) chain linear solver (``&solver linear_solver = 'chain'``, issue 14 item 2).

It solves an approximate GGL iteration matrix (cj M + joint damping + joint stiffness / cj in
the v rows, the constraint blocks exact, geometric stiffness, gyroscopic terms and d(G v)/dq
dropped) by an articulated-body factorisation and a Schur complement on the clamp rows.  Two
checks: on that matrix it must agree with the block (LU) solver, and a whole integration with
it must end where the default solver ends, to within the integration error.
"""

import numpy as np
import pytest

import pydriver
from conftest import INPUTS

DECKS = ["three_body", "six_link_dynamic", "uh60_part2_decay"]
EPS = np.finfo(float).eps


def _chain(stem, cj, n_rhs=3):
    m = pydriver.Model.from_deck(INPUTS / f"{stem}.nml")
    y, _ = m.core.consistent_ggl_state(m.q0, m.v0)
    b = np.random.default_rng(11).standard_normal((len(y), n_rhs))
    return m.core.chain_solver(y, cj, b), b


@pytest.mark.parametrize("stem", DECKS)
@pytest.mark.parametrize("cj", [1.0, 1.0e3])
def test_chain_solve_matches_block_solve_of_the_same_matrix(stem, cj):
    """Both solve the chain's approximate matrix J; their solutions differ by the forward
    error of two stable solvers, at most a small multiple of cond(J) eps (Higham 2002, ch. 7):
    bound 100 cond(J) eps, which is below 1e-10 for these matrices except where cond(J) itself
    says no solver can do better.  The backward error of the chain solution must be of order eps
    (iterative refinement; LU's own bound ~ n eps, here 1e-13 as in test_linear_solver)."""
    out, b = _chain(stem, cj)
    jac, xc, xb = out["jacobian"], out["x_chain"], out["x_block"]
    cond = np.linalg.cond(jac)
    assert np.abs(xc - xb).max() / np.abs(xb).max() <= 100.0 * cond * EPS
    for k in range(b.shape[1]):
        err = np.abs(jac @ xc[:, k] - b[:, k]).max()
        scale = np.abs(jac).sum(axis=1).max() * np.abs(xc[:, k]).max() + np.abs(b[:, k]).max()
        assert err / scale < 1e-13


def test_chain_matrix_is_the_iteration_matrix_without_the_dropped_terms():
    """The chain matrix equals the full iteration matrix in every block it keeps: the q rows
    (cj I, -I, G^T), the constraint rows (G) and the mass part of the v rows.  The difference in
    the v rows is dF_v/dq - C and dF_v/dv - D (geometric stiffness, gyroscopic terms), which
    does not scale with cj: it is the same at cj = 1e3 and 1e6 to round-off of cj M
    (eps cj |M| relative, bound 1e-9 of |J| at cj = 1e6)."""
    m = pydriver.Model.from_deck(INPUTS / "uh60_part2_decay.nml")
    y, yd = m.core.consistent_ggl_state(m.q0, m.v0)
    nq = m.nq
    zeros = np.zeros((len(y), 1))
    diffs = []
    for cj in (1.0e3, 1.0e6):
        full = m.core.iteration_matrix(y, yd, cj, zeros)["jacobian"]
        approx = m.core.chain_solver(y, cj, zeros)["jacobian"]
        d = full - approx
        keep = np.ones_like(d, dtype=bool)
        keep[nq:2 * nq, :2 * nq] = False
        assert np.abs(d[keep]).max() <= 1e-12 * np.abs(full).max()
        diffs.append(d[nq:2 * nq, :2 * nq])
    assert np.abs(diffs[1] - diffs[0]).max() <= 1e-9 * np.abs(full).max()


def _end_state(deck):
    r = pydriver.run_deck(deck)
    ts = r.timeseries
    return r, np.array([ts[c][-1] for c in ts if c[0] in "xyz" and c[1:].isdigit()])


@pytest.mark.parametrize("stem, changes, bound", [
    ("six_link_dynamic", {}, 1e-7),
    ("uh60_part2_decay", {"t_end": "0.05", "dt_out": "0.05"}, 1e-7)])
def test_chain_solver_gives_the_same_motion(deck_copy, stem, changes, bound):
    """A run with the chain solver ends where the block solver's run ends.  The two differ
    only in the Newton iteration matrix, so by the integration error: at rtol 1e-8 and atol
    1e-10 rad on the angles of bodies of at most 0.6 m the local errors are ~1e-9 m and their
    sum over the run ~1e-8 m; 1e-7 m is above that and far below the motion (cm, or the 1 N
    pulse's mm)."""
    _, x0 = _end_state(deck_copy(stem, "solver", dict(changes)))
    other, x1 = _end_state(deck_copy(stem, "solver", {**changes, "linear_solver": "'chain'"}))
    assert np.abs(x1 - x0).max() < bound
    assert other.summary["max_constraint_violation_m"] < 1e-9
