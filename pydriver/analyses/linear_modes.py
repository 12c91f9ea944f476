"""Modes of the linearised equations about an equilibrium: the one place where they are solved
(issue 23 item 3; docs/model.md, "Modal analysis").

The core linearises (``CoreModel.modal_matrices``, src_fortran/modal.f90): on the constraint
manifold q = q* + N z, M_r zdd + D_r zd + K_r z = 0 with M_r = N^T M N, K_r = N^T K N (its skew,
circulatory part kept) and D_r = N^T D N (its skew, gyroscopic part kept).  Here:

* :func:`undamped_modes`: sym(K_r) phi = w^2 M_r phi, the conservative part (LAPACK dsygv through
  SciPy, :func:`symmetric_modes`, which the frequency sensitivities solve too), with the
  zero-stiffness and stability rules of the modal analysis;
* :func:`complex_modes`: the eigenvalues s and complex shapes of the first-order system
  [0 I; -M_r^-1 K_r, -M_r^-1 D_r], zero-stiffness modes first, then one of each oscillating pair
  by frequency, then the real roots; the Campbell diagram follows these by MAC from speed to
  speed;
* :func:`modal_modes`: what the modal analysis reports (``modes.csv``): every undamped mode with
  the damped eigenvalue of :func:`complex_modes` whose shape matches it best (mass-weighted MAC),
  its damped frequency and damping ratio.

The modal analysis, the hover modes of a flight run, the resonance margins and the Campbell
diagram all take their modes from here; the Campbell diagram's first frequency at 0 rpm is the
modal analysis's first damped frequency (tests/test_campbell.py).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

from pydriver.errors import RunError

#: K_r eigenvalues (w^2) below this fraction of the largest are zero stiffness (a coordinate
#: without a spring and without a load across it: a free pivot, a twist without a twist spring);
#: only a clearly negative one means an unstable equilibrium.  1e-9: round-off of the tangent
#: stiffness (analytic, ~1e-12 of its largest entry; tests/test_modal_matrices.py) with margin.
ZERO_STIFFNESS_REL = 1.0e-9


def mac(a: np.ndarray, b: np.ndarray, m_full: np.ndarray) -> np.ndarray:
    """Mass-weighted MAC between the columns of a and b (complex shapes in q)."""
    ma, mb = m_full @ a, m_full @ b                # products by BLAS: O(n^3), not einsum's loops
    cross = a.conj().T @ mb
    na = np.real(np.sum(a.conj() * ma, axis=0))
    nb = np.real(np.sum(b.conj() * mb, axis=0))
    return np.abs(cross) ** 2 / np.maximum(np.outer(na, nb), np.finfo(float).tiny)


def _check_finite(mats: dict) -> None:
    if not all(np.all(np.isfinite(mats[k])) for k in ("M_r", "K_r", "D_r")):
        raise RunError("modal analysis: non-finite mass, stiffness or damping matrix")


def symmetric_modes(k_s: np.ndarray, m_r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """w^2 (ascending, as solved) and the M_r-orthonormal shapes of k_s phi = w^2 m_r phi, k_s
    symmetric, m_r symmetric positive definite (LAPACK dsygv).  RunError if it fails."""
    try:
        return scipy.linalg.eigh(k_s, m_r, driver="gv")
    except (np.linalg.LinAlgError, ValueError) as err:
        raise RunError(f"modal analysis: generalized symmetric eigenproblem failed (dsygv: {err})") from err


def undamped_modes(mats: dict) -> tuple[np.ndarray, np.ndarray]:
    """w^2 (ascending; zero-stiffness ones set to 0) and the M_r-orthonormal shapes Z (nf, nf)
    of sym(K_r) phi = w^2 M_r phi.

    The symmetric part only: the circulatory skew part of K_r (the drag of the still air through
    which a turning cable moves) enters the damped system, as the gyroscopic part of D_r does.
    A clearly negative w^2 (below -ZERO_STIFFNESS_REL of the largest |w^2|) is an unstable
    equilibrium: RunError."""
    _check_finite(mats)
    w2, z = symmetric_modes(0.5 * (mats["K_r"] + mats["K_r"].T), mats["M_r"])
    w_zero = ZERO_STIFFNESS_REL * max(float(np.max(np.abs(w2), initial=0.0)), np.finfo(float).tiny)
    if w2.size and w2[0] < -w_zero:
        raise RunError("modal analysis: the equilibrium is unstable (negative stiffness eigenvalue)")
    return np.where(w2 < w_zero, 0.0, w2), z


def zero_stiffness_basis(m_r: np.ndarray, k_r: np.ndarray) -> np.ndarray:
    """An M_r-orthonormal basis (nf, k) of the coordinates K_r does not resist (k may be 0).

    With M_r = L L^T, K_r x = 0 is (L^-1 K_r L^-T) y = 0 for y = L^T x; the singular vectors of
    that matrix with (relatively) zero singular values are orthonormal, so x = L^-T y is
    M_r-orthonormal.  The SVD needs no symmetry (a follower load makes K_r unsymmetric)."""
    chol = np.linalg.cholesky(m_r)
    scaled = np.linalg.solve(chol, np.linalg.solve(chol, k_r.T).T)
    _, sing, vh = np.linalg.svd(scaled)
    null = sing <= ZERO_STIFFNESS_REL * np.max(sing, initial=0.0)
    return np.linalg.solve(chol.T, vh[null].conj().T)


def complex_modes(mats: dict) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Eigenvalues s and shapes in q of the linearised system, lowest first.

    First the zero-stiffness modes (s = 0, an M_r-orthonormal basis of K_r's null space: the
    eigenvectors eig returns there are defective, parallel pairs when nothing damps them),
    then one of each oscillating pair (Im s > 0) by ascending frequency, then the other
    non-oscillating ones (real s: overdamped, or, with Re s > 0, a divergent equilibrium).
    Also returns which are oscillating and which have zero stiffness.  numpy's eig (LAPACK
    dgeev) on the state matrix: at the sizes of a cable model it is exact enough.  A singular
    M_r raises numpy.linalg.LinAlgError."""
    m, k, d, basis = mats["M_r"], mats["K_r"], mats["D_r"], mats["basis"]
    nf = m.shape[0]
    minv = np.linalg.inv(m)
    a = np.block([[np.zeros((nf, nf)), np.eye(nf)], [-minv @ k, -minv @ d]])
    s, v = np.linalg.eig(a)
    v = v.astype(complex)                         # all-real spectra come back as real arrays
    null = zero_stiffness_basis(m, k)
    n_zero = null.shape[1]
    keep = np.ones(len(s), bool)
    if n_zero:
        # The null space has between n_zero (damped) and 2 n_zero (undamped: Jordan pairs) roots
        # at 0; eig scatters a Jordan pair by ~sqrt(round-off), hence the loose 1e-4.
        smallest = np.argsort(np.abs(s))
        near = int(np.count_nonzero(np.abs(s) <= 1e-4 * max(1.0, np.max(np.abs(s)))))
        keep[smallest[:min(max(near, n_zero), 2 * n_zero)]] = False
    tiny = 1e-9 * max(1.0, np.max(np.abs(s)))
    osc = keep & (s.imag > tiny)
    real = keep & (np.abs(s.imag) <= tiny)
    order = np.concatenate([np.flatnonzero(osc)[np.argsort(s.imag[osc])], np.flatnonzero(real)])
    sv = np.concatenate([np.zeros(n_zero, complex), s[order]])
    shapes = np.hstack([basis @ null.astype(complex), basis @ v[:nf, order]])
    oscillating = np.concatenate([np.zeros(n_zero, bool), osc[order]])
    zero = np.arange(len(sv)) < n_zero
    return sv, shapes, oscillating, zero


def modal_modes(mats: dict) -> dict:
    """The modal analysis's modes: per undamped mode (ascending), its frequency, the damped
    frequency and damping ratio of the damped mode that matches it best, and its shape.

    Pairing: the damped mode of :func:`complex_modes` with the largest mass-weighted MAC against
    the undamped shape.  An oscillating one gives f_damped = Im s / 2 pi and zeta = -Re s / |s|;
    a zero-stiffness one (s = 0) f_damped = 0 and zeta = 0; a real root (overdamped) f_damped = 0
    and the modal damping ratio phi^T D_r phi / (2 w) (0 for w = 0).

    Returns
    -------
    dict
        ``f_undamped_hz``, ``f_damped_hz``, ``zeta`` (nf) and ``shapes`` (nq, nf): the undamped
        shapes in q, mass-normalised.  RunError for non-finite matrices, an unstable equilibrium
        or a singular M_r.
    """
    w2, z = undamped_modes(mats)
    try:
        sv, damped, oscillating, zero = complex_modes(mats)
    except np.linalg.LinAlgError as err:
        raise RunError(f"modal analysis: the linearised equations cannot be solved for their damped modes "
                       f"({err}: the reduced mass matrix is singular)") from err
    shapes = mats["basis"] @ z
    omega = np.sqrt(w2)
    best = np.argmax(mac(shapes.astype(complex), damped, mats["M"]), axis=1) if sv.size else np.zeros(0, int)
    s = sv[best]
    f_damped = np.where(oscillating[best], s.imag / (2.0 * np.pi), 0.0)
    size = np.abs(s)
    modal_ratio = np.sum(z * (mats["D_r"] @ z), axis=0) / (2.0 * np.where(omega > 0.0, omega, 1.0))
    zeta = np.where(oscillating[best], -s.real / np.where(size > 0.0, size, 1.0),
                    np.where(zero[best] | (omega == 0.0), 0.0, modal_ratio))
    return {"f_undamped_hz": omega / (2.0 * np.pi), "f_damped_hz": f_damped, "zeta": zeta, "shapes": shapes}
