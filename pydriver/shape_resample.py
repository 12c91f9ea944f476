"""A start shape given once for any n: ``&shape resample = .true.`` (docs/model.md, "Start shape
for any n").

The deck's ``gamma_deg`` and ``beta_deg`` then hold the start shape of the same cable as a chain
of m bodies, m the number of values given (any 1 <= m <= n): joint i of that m-body polygon
turns by gamma_i and bends by beta_i.  The chain of n bodies takes each of those joints at its
own joint nearest in arc length, and leaves the others straight (0, 0): the deck's polygon, on
the n-body chain.  At n = m every joint lands on itself, so the shape is the per-body one,
value for value.  At n = k m on a chain of equal bodies it is what refinement does (each body
split into k continuing it straight, :func:`pydriver.analyses.refinement.refined_deck`).

Arc lengths follow the bodies' lengths (:func:`chain_lengths`): equal bodies, or with the
physical cable parameters and clamp B the Hencky chain's half element at clamp B.
"""

from __future__ import annotations

import numpy as np


def chain_lengths(n: int, total_length: float, half_last: bool) -> np.ndarray:
    """Body lengths of a uniform chain of n bodies and length ``total_length`` [m]; with
    ``half_last`` (physical cable parameters, clamp B active) the body clamp B holds is a half
    element: L = (n - 1/2) l (docs/model.md, "Per-body properties and physical cable
    parameters")."""
    if half_last and n > 1:
        ell = total_length / (n - 0.5)
        lengths = np.full(n, ell)
        lengths[-1] = 0.5 * ell
        return lengths
    return np.full(n, total_length / n)


def joint_positions(lengths: np.ndarray) -> np.ndarray:
    """Arc-length fraction of every joint (joint j at the start of body j): 0 for joint 1."""
    return np.concatenate([[0.0], np.cumsum(lengths)[:-1]]) / np.sum(lengths)


def target_joints(m: int, n: int, total_length: float, half_last: bool) -> np.ndarray:
    """0-based joint of the n-body chain that takes each joint of the m-body polygon: the nearest
    in arc length (the lower one on a tie).  Raises ValueError if two land on one joint."""
    coarse = joint_positions(chain_lengths(m, total_length, half_last))
    fine = joint_positions(chain_lengths(n, total_length, half_last))
    # Nearest: the lower joint unless the upper is strictly nearer.
    upper = np.clip(np.searchsorted(fine, coarse), 0, n - 1)
    lower = np.maximum(upper - 1, 0)
    nearer_upper = np.abs(fine[upper] - coarse) < np.abs(coarse - fine[lower])
    target = np.where(nearer_upper, upper, lower)
    if np.any(np.diff(target) <= 0):
        i = int(np.argmax(np.diff(target) <= 0))
        raise ValueError(f"joints {i + 1} and {i + 2} of the {m}-value shape fall on the same joint "
                         f"{target[i] + 1} of the {n}-body chain")
    return target


def resample(values: np.ndarray, n: int, total_length: float, half_last: bool) -> np.ndarray:
    """The per-joint angles of the n-body chain from the m values of the m-body polygon (module
    docstring); exactly ``values`` when n = m."""
    values = np.asarray(values, float)
    m = len(values)
    if m == n:
        return values.copy()
    out = np.zeros(n)
    out[target_joints(m, n, total_length, half_last)] = values
    return out
