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
  the damped eigenvalue of :func:`complex_modes` whose shape matches it best (mass-weighted MAC,
  :func:`damped_partners`, the pairing the damped frequencies' sensitivities use too), its damped
  frequency and damping ratio.

The modal analysis, the hover modes of a flight run, the resonance margins and the Campbell
diagram all take their modes from here; the Campbell diagram's first frequency at 0 rpm is the
modal analysis's first damped frequency (tests/test_campbell.py).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

from pydriver.errors import RunError

#: The round-off of the tangent stiffness, as a multiple of eps times its largest entry: the
#: analytic tangent (src_fortran/kinematics_tangent.f90 ...) sums terms of at most the size of its
#: largest entry with a few hundred operations each; tests/test_modal_matrices.py finds it within
#: ~1e-12 of the largest entry against differences (whose own error dominates there).
STIFFNESS_ROUNDOFF_EPS = 1.0e4


#: A root with |Im s| at most this share of |s| does not oscillate (complex_modes).
CRITICAL_SHARE = 1.0e-4


def stiffness_floor(k: np.ndarray, shapes: np.ndarray) -> np.ndarray:
    """Per shape x (a column of ``shapes``, M_r-orthonormal), how large x^T K x can come out of
    round-off alone: |x^T dK x| <= |dK| |x|^2 with |dK| = STIFFNESS_ROUNDOFF_EPS eps max|K|.

    This is the zero-stiffness test (issue 35): a mode's stiffness follows its own size, not
    the stiffest mode's.  The earlier rule, w^2 below 1e-9 of the largest w^2, set a swing of
    the whole cable on a soft spring (w = 5e-3 rad/s, c = 1e-6 Nm/rad) to 0 Hz because a 1.7 kHz
    twist mode sat in the same spectrum; an exactly zero stiffness (a free pivot) comes out
    ~1e-20 below this floor and a spring of 1e-10 Nm/rad 1e5 above it (measured on the
    cantilever and three-body decks)."""
    scale = STIFFNESS_ROUNDOFF_EPS * np.finfo(float).eps * float(np.max(np.abs(k), initial=0.0))
    return scale * np.sum(np.abs(shapes) ** 2, axis=0)


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


def stiffness_spectrum(mats: dict) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """w^2 (ascending), the M_r-orthonormal shapes Z (nf, nf) of sym(K_r) phi = w^2 M_r phi and
    each one's round-off floor (:func:`stiffness_floor`); nothing is judged or zeroed here.

    The symmetric part only: the circulatory skew part of K_r (the drag of the still air through
    which a turning cable moves) enters the damped system, as the gyroscopic part of D_r does.
    dsygv's eigenvalues carry an absolute error of ~eps times the largest one, so a small one
    (below sqrt(eps) of the largest) is taken again as its Rayleigh quotient phi^T sym(K_r) phi,
    which is as accurate as the entries of K_r allow (the shape's error enters squared)."""
    _check_finite(mats)
    k_s = 0.5 * (mats["K_r"] + mats["K_r"].T)
    w2, z = symmetric_modes(k_s, mats["M_r"])
    small = np.abs(w2) <= np.sqrt(np.finfo(float).eps) * float(np.max(np.abs(w2), initial=0.0))
    if np.any(small):
        w2 = w2.copy()
        w2[small] = np.einsum("ij,ij->j", z[:, small], k_s @ z[:, small])
        order = np.argsort(w2, kind="stable")
        w2, z = w2[order], z[:, order]
    return w2, z, stiffness_floor(k_s, z)


def undamped_modes(mats: dict) -> tuple[np.ndarray, np.ndarray]:
    """w^2 (ascending; zero-stiffness ones set to 0) and the M_r-orthonormal shapes Z (nf, nf)
    of sym(K_r) phi = w^2 M_r phi (:func:`stiffness_spectrum`).  A w^2 within its round-off floor
    of 0 is zero stiffness (0); one below minus that floor is an unstable equilibrium: RunError."""
    w2, z, floor = stiffness_spectrum(mats)
    if w2.size and np.any(w2 < -floor):
        worst = int(np.argmin(w2 + floor))
        raise RunError(f"modal analysis: the equilibrium is unstable (negative stiffness: w^2 = {w2[worst]:.3e} "
                       f"1/s^2 below its round-off floor {floor[worst]:.1e})")
    return np.where(np.abs(w2) <= floor, 0.0, w2), z


def zero_stiffness_basis(m_r: np.ndarray, k_r: np.ndarray, count: int) -> np.ndarray:
    """An M_r-orthonormal basis (nf, count) of the coordinates K_r does not resist: the ``count``
    zero-stiffness modes of :func:`undamped_modes` (count may be 0).

    With M_r = L L^T, K_r x = 0 is (L^-1 K_r L^-T) y = 0 for y = L^T x; the singular vectors of
    that matrix with the smallest singular values are orthonormal, so x = L^-T y is
    M_r-orthonormal.  The SVD needs no symmetry (a follower load makes K_r unsymmetric); how many
    are zero is the undamped modes' decision, so the damped and the undamped modes agree on it."""
    if count == 0:
        return np.zeros((m_r.shape[0], 0))
    chol = np.linalg.cholesky(m_r)
    scaled = np.linalg.solve(chol, np.linalg.solve(chol, k_r.T).T)
    _, _, vh = np.linalg.svd(scaled)
    return np.linalg.solve(chol.T, vh[-count:].conj().T)


def complex_modes(mats: dict, n_zero: int | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
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
    if n_zero is None:
        w2, _, floor = stiffness_spectrum(mats)
        n_zero = int(np.count_nonzero(np.abs(w2) <= floor))
    null = zero_stiffness_basis(m, k, n_zero)
    keep = np.ones(len(s), bool)
    if n_zero:
        # The null space has between n_zero (damped) and 2 n_zero (undamped: Jordan pairs) roots
        # at 0; eig scatters a Jordan pair by ~sqrt(round-off), hence the loose 1e-4.
        smallest = np.argsort(np.abs(s))
        near = int(np.count_nonzero(np.abs(s) <= 1e-4 * max(1.0, np.max(np.abs(s)))))
        keep[smallest[:min(max(near, n_zero), 2 * n_zero)]] = False
    # A root oscillates when its imaginary part is more than round-off of the spectrum AND more than
    # 1e-4 of its own size (damping ratio below 1 - 5e-9): a nearly critically damped pair splits
    # into Im s ~ sqrt(perturbation) and at n = 44 came out as a "1 mHz mode" (zeta = 1 - 2.5e-11)
    # that the Campbell diagram then tracked as modes 1 and 2 (issue 35).
    tiny = np.maximum(1e-9 * max(1.0, np.max(np.abs(s))), CRITICAL_SHARE * np.abs(s))
    osc = keep & (s.imag > tiny)
    real = keep & (np.abs(s.imag) <= tiny)
    order = np.concatenate([np.flatnonzero(osc)[np.argsort(s.imag[osc])], np.flatnonzero(real)])
    sv = np.concatenate([np.zeros(n_zero, complex), s[order]])
    shapes = np.hstack([basis @ null.astype(complex), basis @ v[:nf, order]])
    oscillating = np.concatenate([np.zeros(n_zero, bool), osc[order]])
    zero = np.arange(len(sv)) < n_zero
    return sv, shapes, oscillating, zero


def damped_partners(undamped_shapes: np.ndarray, damped_shapes: np.ndarray, m_full: np.ndarray) -> np.ndarray:
    """Per undamped mode (a column of ``undamped_shapes``, in q), the index of its damped mode
    among the columns of ``damped_shapes`` (:func:`complex_modes`): the largest mass-weighted MAC.

    The one pairing of the two kinds of mode: the modal analysis's damped frequency of mode k
    (:func:`modal_modes`) and the damped frequency whose sensitivity the design optimiser takes
    (:func:`pydriver.analyses.sensitivities.modal_sensitivities`) are the same root."""
    if not damped_shapes.shape[1]:
        return np.zeros(0, int)
    return np.argmax(mac(undamped_shapes.astype(complex), damped_shapes, m_full), axis=1)


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
        shapes in q, mass-normalised; ``damped_root`` (nf, complex) the eigenvalue s of each
        mode's damped partner and ``oscillating`` (nf) whether it oscillates (a pair, not a
        zero-stiffness or real root).  RunError for non-finite matrices, an unstable equilibrium
        or a singular M_r.
    """
    w2, z = undamped_modes(mats)
    try:
        sv, damped, oscillating, zero = complex_modes(mats, int(np.count_nonzero(w2 == 0.0)))
    except np.linalg.LinAlgError as err:
        raise RunError(f"modal analysis: the linearised equations cannot be solved for their damped modes "
                       f"({err}: the reduced mass matrix is singular)") from err
    shapes = mats["basis"] @ z
    omega = np.sqrt(w2)
    best = damped_partners(shapes, damped, mats["M"])
    s = sv[best]
    f_damped = np.where(oscillating[best], s.imag / (2.0 * np.pi), 0.0)
    size = np.abs(s)
    modal_ratio = np.sum(z * (mats["D_r"] @ z), axis=0) / (2.0 * np.where(omega > 0.0, omega, 1.0))
    zeta = np.where(oscillating[best], -s.real / np.where(size > 0.0, size, 1.0),
                    np.where(zero[best] | (omega == 0.0), 0.0, modal_ratio))
    return {"f_undamped_hz": omega / (2.0 * np.pi), "f_damped_hz": f_damped, "zeta": zeta, "shapes": shapes,
            "damped_root": s, "oscillating": oscillating[best]}
