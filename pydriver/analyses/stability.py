"""Whether an equilibrium is stable, and how far it lies from the start shape (issue 35).

Every equilibrium the static solver finds (:func:`pydriver.analyses.statics.equilibrium`) is
judged here before anything is built on it, so the static, modal, design, dynamic (a start at
rest) and flight runs all inherit the verdict.  On the constraint manifold q = q* + N z (N an
orthonormal basis of the null space of G, ``CoreModel.modal_matrices``) the linearised
equations are M_r zdd + D_r zd + K_r z = 0 with K_r = N^T K N, K the tangent stiffness at fixed
multipliers (it carries the constraints' curvature weighted by lambda).  Then:

* the smallest eigenvalue of sym(K_r) [Nm/rad] (N orthonormal, so its unit is that of K) and
  the smallest w^2 of sym(K_r) phi = w^2 M_r phi with its round-off floor
  (:func:`pydriver.analyses.linear_modes.stiffness_spectrum`): below minus the floor the
  equilibrium is a saddle or a maximum of the potential ("unstable"), within the floor of 0 a
  mode without stiffness ("neutral": the equilibrium is not unique along it);
* the largest growth rate Re s of the damped linear system: with a load that is not conservative
  at rest (drag in a stream or in a turning frame) a positive one (beyond eig's round-off) is a
  divergence or a flutter that the stiffness alone does not show.

An unstable equilibrium is an error that says what to try (:func:`require_stable`); a neutral one
is a warning in the summary.  The distance from the start shape closed onto the constraints
(the joint points' largest displacement and the joint angles' largest change) is reported too,
and a warning says when the solver went far (more than :data:`FAR_FRACTION` of the cable's
length): a deck may admit several equilibria, and the one found is the one the solver's descent
reaches from the start (docs/model.md, "Which equilibrium").
"""

from __future__ import annotations

import numpy as np

from pydriver.analyses.common import straight_zy_warnings
from pydriver.analyses.linear_modes import stiffness_spectrum
from pydriver.errors import RunError

#: A joint point that moved more than this fraction of the cable's length from the closed start
#: shape to the equilibrium is "far": the start shape did not describe the equilibrium found.
#: The shipped decks move at most 0.11 L (the flight decks' hover shapes from their installed
#: start) where their start shape is the intended one; the three-body pendulum released 27 deg
#: from hanging falls by 0.46 L (tests/test_equilibrium_stability.py).
FAR_FRACTION = 0.25


def _growth_rate(mats: dict) -> float:
    """Largest Re s of the damped linear system M_r s^2 + D_r s + K_r = 0 (eig of the first-order
    form), its zero-stiffness roots included (they sit at 0 within round-off)."""
    m, k, d = mats["M_r"], mats["K_r"], mats["D_r"]
    nf = m.shape[0]
    if nf == 0:
        return 0.0
    minv = np.linalg.inv(m)
    a = np.block([[np.zeros((nf, nf)), np.eye(nf)], [-minv @ k, -minv @ d]])
    return float(np.max(np.linalg.eigvals(a).real))


def equilibrium_stability(model, q, lam, t: float = 0.0) -> dict:
    """The stability of the equilibrium (q, lambda) of ``model`` at time t (module doc).

    Returns
    -------
    dict
        ``verdict`` ('stable', 'neutral' or 'unstable'), ``smallest_stiffness_eigenvalue_Nm_per_rad``,
        ``lowest_omega_squared_per_s2`` (the smallest w^2, 0 for zero stiffness),
        ``zero_stiffness_modes`` (how many), ``largest_growth_rate_per_s`` (Re s) and, for an
        unstable one, ``unstable_shape`` (the shape in q of the least stable mode) and ``q``, for
        the message (not for the summary).
    """
    mats = model.core.modal_matrices(q, lam, t)
    nf = mats["M_r"].shape[0]
    if nf == 0:                                    # a chain held in every coordinate
        return {"verdict": "stable", "smallest_stiffness_eigenvalue_Nm_per_rad": 0.0,
                "lowest_omega_squared_per_s2": 0.0, "zero_stiffness_modes": 0}
    k_s = 0.5 * (mats["K_r"] + mats["K_r"].T)
    w2, z, floor = stiffness_spectrum(mats)
    zero = np.abs(w2) <= floor
    negative = w2 < -floor
    out = {"smallest_stiffness_eigenvalue_Nm_per_rad": float(np.linalg.eigvalsh(k_s)[0]),
           "lowest_omega_squared_per_s2": float(0.0 if zero[0] else w2[0]),
           "zero_stiffness_modes": int(np.count_nonzero(zero))}
    verdict = "unstable" if np.any(negative) else "neutral" if np.any(zero) else "stable"
    rate = _growth_rate(mats)
    out["largest_growth_rate_per_s"] = rate
    # eig's absolute round-off on the first-order form is ~eps times its norm; 1e3 times that.
    scale = np.sqrt(float(np.max(np.abs(w2)))) + float(np.max(np.abs(mats["D_r"]), initial=0.0))
    if verdict == "stable" and rate > 1.0e3 * np.finfo(float).eps * max(scale, 1.0):
        verdict = "unstable"
    out["verdict"] = verdict
    if verdict == "unstable":
        out["unstable_shape"] = mats["basis"] @ z[:, int(np.argmin(w2 + floor))]
        out["q"] = np.asarray(q, float)
    return out


def distance_from_start(model, q, t: float = 0.0) -> dict:
    """How far the equilibrium q lies from the deck's start shape closed onto the constraints:
    the joint points' largest displacement [m] (and as a share of the cable's length) and the
    joint angles' largest change [deg]."""
    start = model.core.consistent_start(model.q0, np.zeros_like(model.q0), t)["q"]
    moved = np.linalg.norm(model.core.shape(q, t)["joints"] - model.core.shape(start, t)["joints"], axis=1)
    length = float(np.sum(model.description["bodies"].lengths))
    return {"largest_point_displacement_m": float(np.max(moved)),
            "largest_point_displacement_share_of_length": float(np.max(moved) / length),
            "largest_angle_change_deg": float(np.degrees(np.max(np.abs(q - start), initial=0.0)))}


def far_warning(distance: dict) -> list[str]:
    """The warning that the equilibrium lies far from the start shape (empty when it does not)."""
    share = distance["largest_point_displacement_share_of_length"]
    if share <= FAR_FRACTION:
        return []
    return [f"the equilibrium lies far from the start shape: a joint point moved "
            f"{distance['largest_point_displacement_m']:.3g} m ({100 * share:.0f} % of the cable's length) from "
            "the start closed onto the supports; a deck may admit several equilibria, and the solver finds the one "
            "its energy descent reaches from the start (docs/model.md, \"Which equilibrium\"): if this is not the "
            "intended one, give a start shape nearer it (&shape)"]


def require_stable(model, stability: dict, t: float = 0.0) -> None:
    """RunError for an unstable equilibrium, saying where it gives way and what to try."""
    if stability["verdict"] != "unstable":
        return
    shape = np.abs(stability["unstable_shape"])
    # description['first_coord']: each joint's first coordinate, counted from 1.
    joint_of = np.searchsorted(np.asarray(model.description["first_coord"]), np.arange(1, shape.size + 1),
                               side="right")
    worst = sorted(set(int(j) for j in joint_of[np.argsort(shape)[::-1][:3]]))
    where = f" (the least stable mode turns joints {', '.join(map(str, worst))} most)"
    w2 = stability["lowest_omega_squared_per_s2"]
    what = (f"its stiffness has a negative eigenvalue (w^2 = {w2:.3g} 1/s^2)" if w2 < 0.0 else
            f"its damped motion grows (growth rate {stability.get('largest_growth_rate_per_s', 0.0):.3g} 1/s)")
    straight = straight_zy_warnings(model, np.degrees(model.core.shape(stability["q"], t)["angles"][:, 1]))
    if straight:
        # A straight zy joint has lost a bending direction: the equilibrium there is an artefact
        # of the parametrisation (the load does no work at first order), not of the cable.
        advice = f"{straight[0]}.  This equilibrium is an artefact of that singularity"
    else:
        advice = ("The solver went from the start shape to a saddle of the potential; try a start shape nearer the "
                  "expected equilibrium (&shape), &solver static_method = 'settle' (damped settling, which comes "
                  "to rest in a stable equilibrium), or check the loads and springs")
    raise RunError(f"deck '{model.name}': the static equilibrium found at t = {t:g} s is unstable: {what}{where}.  "
                   f"{advice}")



def stability_summary(model, q, lam, t: float = 0.0) -> tuple[dict, list[str]]:
    """The summary's ``equilibrium_stability`` (the verdict, its eigenvalues and the distance from
    the start shape) and its warnings (a neutral equilibrium, one far from the start)."""
    stability = equilibrium_stability(model, q, lam, t)
    stability.pop("unstable_shape", None)
    stability.pop("q", None)
    stability["distance_from_start"] = distance_from_start(model, q, t)
    warnings = far_warning(stability["distance_from_start"])
    if stability["verdict"] == "neutral":
        warnings.append(f"the equilibrium is neutral: {stability['zero_stiffness_modes']} mode(s) without stiffness "
                        "(no spring and no load across them), so it is not unique along them; a spring on the free "
                        "coordinate (&springs) makes it unique")
    return stability, warnings
