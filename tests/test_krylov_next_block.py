"""The next Krylov block of the periodic start's block GMRES (flight_sensitivities._next_block)
on a matrix problem with a known solution: a contracting operator of low numerical rank, as a
damped cable's one-revolution sensitivity map, and right-hand sides five decades apart, as the
main job's parameters' are."""

import numpy as np

from pydriver.analyses.flight_sensitivities import _next_block


def _problem(n=40, n_par=6, seed=3):
    rng = np.random.default_rng(seed)
    u, _ = np.linalg.qr(rng.standard_normal((n, n)))
    v, _ = np.linalg.qr(rng.standard_normal((n, n)))
    # Singular values as the main job's multipliers: one 0.1, then decades down to round-off.
    psi = u @ np.diag(0.1 * 10.0 ** (-2.0 * np.arange(n))) @ v.T
    rhs = rng.standard_normal((n, n_par)) * 10.0 ** -np.linspace(0.0, 5.0, n_par)
    return psi, rhs


def _block_gmres(psi, rhs, tol, blocks=2):
    norms = np.linalg.norm(rhs, axis=0)
    basis, images = [rhs / norms.max()], []
    for _ in range(blocks):
        images.append(psi @ basis[-1])
        b_all, img = np.hstack(basis), np.hstack(images)
        coef, *_ = np.linalg.lstsq(b_all - img, rhs, rcond=None)
        res = np.linalg.norm((b_all - img) @ coef - rhs, axis=0) / norms
        if max(res) < tol:
            return b_all @ coef, res, [b.shape[1] for b in basis]
        basis.append(_next_block(images[-1], b_all, coef[-basis[-1].shape[1]:], norms, tol))
    return None, res, [b.shape[1] for b in basis]


def test_next_block_converges_to_the_direct_solve_for_every_right_hand_side():
    tol = 1e-6
    psi, rhs = _problem()
    x, res, columns = _block_gmres(psi, rhs, tol)
    # Converged after the second block: the directions left out leave < tol / 2 by construction.
    assert x is not None, f"not converged after two blocks: residuals {res}"
    assert max(res) < tol
    # Thin: far fewer directions than the 40 unknowns and the 6 right-hand sides.
    assert columns[1] < columns[0]
    exact = np.linalg.solve(np.eye(psi.shape[0]) - psi, rhs)
    # Each parameter to its own relative tolerance, however small its right-hand side: the error
    # is at most the residual times |(I - Psi)^-1| <= 1/(1 - 0.1), 1.1 tol.
    err = np.linalg.norm(x - exact, axis=0) / np.linalg.norm(exact, axis=0)
    assert np.all(err < 1.2 * tol), err
