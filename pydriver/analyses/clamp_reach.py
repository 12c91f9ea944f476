"""Whether clamp B is within reach of the chain while the supports move, and the error that
says so when a run fails because it is not.

A support carried by the blade (``moves_with = 'blade'``) follows the prescribed flap, lead-lag
and pitch motion, which a deck can make larger than the cable allows.  The core checks the
reach at t = 0 only (``&clamp_b position``, src_fortran/model_builder.f90); later the integrator
meets a constraint it cannot satisfy and stops with SUNDIALS's bare message.  This module finds
the instant and says it in the deck's terms.

The reach test is the core's (src_fortran/projection.f90, ``clamp_reach``): the free part of the
chain starts at joint point 1 (joint point 2 after a clamped first body) and must reach the
start of the last body, whose pose clamp B imposes entirely (6 rows), so

    span = | p_B - l_n R_B e_z - start |  <=  reach = sum of the free bodies' lengths.

The clamp's pose at any time comes from the core's own constraint residual (clamp.f90:
``g_pos = tip - p_B``, ``g_rot = vee(E - E^T)/2`` with ``E = R_n R_B^T``) evaluated at a state
near the constraint, so no motion formula is written twice.
"""

from __future__ import annotations

import re

import numpy as np

from pydriver.errors import RunError

#: At a failure, a span above this fraction of the reach is reported as the cause: the chain is
#: then nearly a straight bar between the clamps, its axial force is undetermined (the
#: constraint Jacobian loses rank at full reach) and the corrector's Newton iteration diverges.
TAUT_FRACTION = 0.99
#: Instants scanned (before bisection) between the last good state and the end of the failed
#: interval; one constraint residual and one shape (two core calls) each.
SCAN_POINTS = 400


def _rotation(w) -> np.ndarray:
    """exp([w]x) (Rodrigues)."""
    a = float(np.linalg.norm(w))
    if a == 0.0:
        return np.eye(3)
    k = np.asarray(w, float) / a
    kx = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + np.sin(a) * kx + (1.0 - np.cos(a)) * kx @ kx


def clamp_b_pose(model, q, t: float) -> tuple[np.ndarray, np.ndarray, dict]:
    """Clamp B's position p_B [m] and rotation R_B at time ``t`` [s], and the chain's shape at q.

    From the clamp's constraint residual at (q, t): p_B = tip - g_pos, and with
    g_rot = sin(a) u the orientation error E = R_n R_B^T = exp(a [u]x), so R_B = E^T R_n.  Exact
    while the last body at q is within 90 deg of the clamp's orientation (a in [0, 90 deg)),
    which holds for q of any state the run reached shortly before t.
    """
    g = model.core.constraint_residual(q, float(t))
    shape = model.core.shape(q, float(t))
    p_b = np.asarray(shape["joints"][-1], float) - g[:3]
    s = g[3:6]
    sn = float(np.linalg.norm(s))
    w = np.arcsin(min(sn, 1.0)) * s / sn if sn > 0.0 else np.zeros(3)
    return p_b, _rotation(w).T @ shape["last_rotation"], shape


def reach_at(model, q, t: float) -> dict:
    """The reach test at time ``t`` (module docstring), with q a state near the constraint.

    Returns
    -------
    dict
        ``span`` and ``reach`` [m], ``ratio`` = span / reach, ``distance_ab`` (clamp A's point to
        clamp B's) and ``cable`` (all bodies) [m], ``first_free`` (1-based body the free part
        starts with) and ``n_bodies``.
    """
    b = model.description["bodies"]
    lengths = b.lengths
    n = len(lengths)
    p_b, r_b, shape = clamp_b_pose(model, q, t)
    joints = shape["joints"]
    first = 1 if b.locked[0] else 0
    reach = float(np.sum(lengths[first:n - 1]))
    span = float(np.linalg.norm(p_b - lengths[-1] * r_b[:, 2] - joints[first]))
    return {"span": span, "reach": reach, "ratio": span / reach if reach > 0.0 else np.inf,
            "distance_ab": float(np.linalg.norm(p_b - joints[0])), "cable": float(np.sum(lengths)),
            "first_free": first + 1, "n_bodies": n}


def supports_move(model) -> bool:
    """Whether a support follows the blade; otherwise clamp B keeps its distance from A (both
    fixed, or both carried round together by the rotor) and the core's check at t = 0 holds."""
    d = model.deck
    return bool(d["clamp_b.active"]) and "blade" in d.groups and \
        "blade" in (d["clamp_a.moves_with"], d["clamp_b.moves_with"])


def failure_time(exc: Exception) -> float | None:
    """The time IDA reached, from its message ("At t = 0.0302 and h = ..."), if it says."""
    m = re.search(r"\bt\s*=\s*([-+]?[0-9.]+(?:[eE][-+]?[0-9]+)?)", str(exc))
    return float(m.group(1)) if m else None


def _first_exceeding(model, q, t_lo: float, t_hi: float) -> float:
    """Bisection for the instant in (t_lo, t_hi] at which span / reach passes 1."""
    for _ in range(40):
        t_mid = 0.5 * (t_lo + t_hi)
        if reach_at(model, q, t_mid)["ratio"] > 1.0:
            t_hi = t_mid
        else:
            t_lo = t_mid
    return t_hi


def _azimuth_text(model, q, t: float) -> str:
    rot = model.description["rotor"]
    if rot is None:
        return ""
    psi = float(model.core.sample([t], q[:, None], np.zeros((model.nq, 1))).psi[0])
    return f" (blade azimuth {np.degrees(psi + rot['azimuth0']) % 360.0:.1f} deg)"


def _keys_to_check(model) -> str:
    d = model.deck
    movers = [w for w in ("clamp_a", "clamp_b") if "blade" in d.groups and d[f"{w}.moves_with"] == "blade"]
    text = "check "
    if movers:
        angles = "table_flap_deg, table_lag_deg, table_pitch_deg" if d["blade.motion"] == "table" \
            else "flap_deg, lag_deg, pitch_deg"
        text += f"the blade motion that carries {' and '.join('&' + m for m in movers)} (&blade {angles}), "
    return text + "&clamp_b position and the cable length (&chain total_length or body_length)"


def _free_part_text(r: dict) -> str:
    first = r["first_free"]
    start = "clamp A" if first == 1 else "the end of the clamped body 1"
    return (f"the free part of the chain (bodies {first}-{r['n_bodies'] - 1}, from {start} to the last body, "
            f"which clamp B holds) is {r['reach']:.4g} m long")


def _solver_text(exc: Exception) -> str:
    """The solver's message without the deck name it repeats."""
    return re.sub(r"^deck '[^']*':\s*", "", str(exc))


def reach_error(model, q_good, t_good: float, t_end: float, exc: Exception) -> Exception:
    """The error to raise for an integration that failed between t_good and t_end.

    If clamp B leaves the chain's reach in [t_good, t_end], or the chain was taut where the
    integrator stopped, a :class:`RunError` that says so in the deck's terms (with the solver's
    message at the end); otherwise ``exc`` itself.

    Parameters
    ----------
    model : pydriver.model.Model
    q_good : numpy.ndarray
        The last state the run reached (near the constraint), at ``t_good`` [s].
    t_good, t_end : float
        The interval the failed call integrated [s].
    exc : Exception
        The solver's error.
    """
    if not supports_move(model) or model.nc != 6:
        return exc
    q_good = np.asarray(q_good, float)
    t_fail = failure_time(exc)
    try:
        times = np.linspace(t_good, t_end, SCAN_POINTS)
        if t_fail is not None and t_good < t_fail < t_end:
            times = np.sort(np.append(times, t_fail))
        ratios = np.array([reach_at(model, q_good, t)["ratio"] for t in times])
        over = np.nonzero(ratios > 1.0)[0]
        if over.size:
            k = int(over[0])
            t_out = times[0] if k == 0 else _first_exceeding(model, q_good, times[k - 1], times[k])
            k_worst = int(np.argmax(ratios))
            worst = reach_at(model, q_good, times[k_worst])
            return RunError(f"deck '{model.name}': clamp B moves out of reach of the chain at t = {t_out:.6g} s"
                            f"{_azimuth_text(model, q_good, t_out)}: {_free_part_text(worst)}, but it would "
                            f"have to span up to {worst['span']:.4g} m (at t = {times[k_worst]:.6g} s, where the "
                            f"distance from A to B is {worst['distance_ab']:.4g} m; the cable is "
                            f"{worst['cable']:.4g} m long); {_keys_to_check(model)} [{_solver_text(exc)}]")
        if t_fail is not None:
            r = reach_at(model, q_good, t_fail)
            if r["ratio"] > TAUT_FRACTION:
                return RunError(f"deck '{model.name}': clamp B pulled the chain taut at t = {t_fail:.6g} s"
                                f"{_azimuth_text(model, q_good, t_fail)}, where the integrator stopped: "
                                f"{_free_part_text(r)} and had to span {r['span']:.4g} m "
                                f"({100.0 * r['ratio']:.2f} % of it; the distance from A to B is "
                                f"{r['distance_ab']:.4g} m, the cable is {r['cable']:.4g} m long), and a straight "
                                f"chain's axial force is undetermined; give the cable slack: "
                                f"{_keys_to_check(model)} [{_solver_text(exc)}]")
    except RunError:
        # The diagnosis needs the core at states near the failure; if that fails too, the
        # solver's own message is the best there is.
        return exc
    return exc
