"""The least damped Floquet modes from a subspace of the monodromy (issue 36, item 4).

The whole monodromy Phi (2 nf x 2 nf, :mod:`pydriver.analyses.floquet`) integrates 2 nf
sensitivity columns with the state: at n = 44 (2 nf ~ 250) one period took 113 s against
1-2 s without them, so the refined levels of a flight had no Floquet verdict.  Stability needs
only the multipliers above round-off, and for a damped cable they are few: a hover mode of
frequency f and damping ratio zeta has |rho| ~ exp(-zeta 2 pi f T), below 1e-20 from the fourth
mode of the main job on.  Those modes are close to the hover state's lowest modes, so

1. the start block X (k columns) is the hover state's lowest mode shapes, each as a
   displacement (u, 0) and as a velocity (0, Omega u) (:func:`hover_start_block`);
2. one period with k sensitivity columns gives Phi X (``CoreModel.monodromy_columns``, the
   same tangent integration as the whole matrix, the columns held to a tighter absolute
   tolerance than the state: a multiplier of 1e-7 is resolved only when the columns are
   integrated below it);
3. Rayleigh-Ritz on span(X): the eigenpairs (rho, y) of H = X^T Phi X (X orthonormal) with
   their residuals ||Phi X y - rho X y||; while a multiplier above the floor has a residual
   above RESIDUAL_SHARE |rho|, the directions of Phi X not yet in the span are added as a new
   block and integrated (a block Krylov space span(X, Phi X, ...); the images of a damped
   cable have few directions above round-off, so a new block is small)
   (:func:`subspace_multipliers`).

The coordinates are x = (a, b / Omega) (a in rad, b in rad/s, Omega = 2 pi / T): the
eigenvalues are those of Phi (a similarity), while orthogonality and residuals weigh a
displacement and a velocity of one radian per period alike.
"""

from __future__ import annotations

import time

import numpy as np

from pydriver.analyses.floquet import FLOOR_SHARE, floquet_summary, modes_of_multipliers

#: A Ritz pair is converged when ||Phi v - rho v|| <= RESIDUAL_SHARE |rho| (v of unit length):
#: for a simple, well separated multiplier the eigenvalue error is of the order of the
#: residual's square over the separation (Parlett, The Symmetric Eigenvalue Problem, sec. 11-7,
#: for the normal case; a backward error of RESIDUAL_SHARE in general).  Measured on the main job
#: at n = 44: the 1.15e-7 pair with a residual of 1.7e-3 |rho| after two blocks moved by 1.1e-4
#: relative with a third (which cost 3 s), and an error of 1e-2 in |rho| is one of 1e-2 / |ln rho|
#: in the exponent (6e-4 for that mode); the least damped mode's residual is 1e-8 |rho|.
RESIDUAL_SHARE = 1.0e-2
#: Blocks at most (the start block and its Krylov extensions).
MAX_BLOCKS = 4
#: The columns' absolute tolerance per unit of a start direction, as a share of the state's
#: relative tolerance: rtol x COLUMN_ATOL_SHARE, a hundredth of the floor for |rho|_max ~ 0.1
#: (the state keeps its own atol).  Measured on the main job at n = 11: 1e-6 instead changed the
#: 1.7e-7 multiplier by 1.5e-4 relative and took 15 % more steps.
COLUMN_ATOL_SHARE = 1.0e-3
#: Images of a new block below this share of the largest image are round-off, not a direction.
NEW_DIRECTION_SHARE = 1.0e-12
#: Hover modes in the start block beyond those whose hover multiplier is above the floor: a
#: start block closer to the Floquet modes saves a Krylov block (main job at n = 22: 4 extra
#: modes converged in 2 blocks, 1 extra mode needed 3).  A column once cost little beside the
#: steps; since the tangent system's steps got cheaper (issue 39: block solver, compiled vector
#: kernels) every column counts: the main job's largest start block at n = 44 took 3.1 s with 4
#: extra modes (14 columns) and 1.8 s with 2 (10 columns), both in 2 blocks at every level, the
#: least damped mode's damping ratio moved by 2.5e-8 (its error bar: 3.2e-5).
EXTRA_MODES = 2


def hover_multipliers(hover_summary: dict, period: float) -> np.ndarray:
    """|rho| a hover mode would have after one period, exp(Re(s) T) with s its slowest root:
    an oscillating mode's -zeta w_n, an overdamped one's -w_n (zeta - sqrt(zeta^2 - 1))."""
    f_n = np.asarray(hover_summary["frequencies_hz"], float)
    f_d = np.asarray(hover_summary["damped_frequencies_hz"], float)
    zeta = np.asarray(hover_summary["damping_ratios"], float)
    w_n = 2.0 * np.pi * f_n
    slow = np.where(f_d > 0.0, zeta, zeta - np.sqrt(np.maximum(zeta ** 2 - 1.0, 0.0)))
    return np.exp(-slow * w_n * period)


def hover_start_block(shapes: np.ndarray, hover_summary: dict, period: float, floor: float) -> tuple[int, np.ndarray,
                                                                                                        np.ndarray]:
    """The start perturbations (dq, dv) (nq, 2 m) of the subspace: the hover modes whose hover
    multiplier is above ``floor`` and EXTRA_MODES more (the next ones, in case the flight damps a
    mode less than the hover), each as (u, 0) and (0, Omega u).  Returns (m, dq, dv)."""
    rho = hover_multipliers(hover_summary, period)
    above = np.flatnonzero(rho >= floor)
    count = (int(above.max()) + 1 if above.size else 1) + EXTRA_MODES
    count = min(count, shapes.shape[1])
    u = np.asarray(shapes[:, :count], float)
    omega = 2.0 * np.pi / period
    zero = np.zeros_like(u)
    return count, np.hstack([u, zero]), np.hstack([zero, omega * u])


def subspace_multipliers(apply, x0: np.ndarray, images0: np.ndarray, floor,
                         max_blocks: int | None = None) -> dict:
    """Multipliers of the largest modulus of a matrix known only through products (Rayleigh-Ritz
    on a block Krylov space).

    Parameters
    ----------
    apply : callable
        ``apply(V)`` returns Phi V for an (m, j) block of orthonormal directions.
    x0, images0 : (m, k) arrays
        The start block and Phi x0 (already integrated).
    floor : callable
        ``floor(|rho|_max)``: multipliers below it are round-off and need no converged Ritz pair.
    max_blocks : int
        Blocks at most, the start block included (default MAX_BLOCKS).

    Returns
    -------
    dict
        ``multipliers`` (complex, largest modulus first), ``floor`` (its value), their ``residuals``
        ||Phi v - rho v|| (v of unit length), ``vectors`` (m, j) the Ritz vectors, ``blocks``
        the blocks integrated and ``columns`` the directions integrated in all.
    """
    max_blocks = MAX_BLOCKS if max_blocks is None else max_blocks
    # Orthonormal start: Phi Q = images0 R^-1 (no new integration).
    q, r = np.linalg.qr(np.asarray(x0, float))
    keep = np.abs(np.diag(r)) > NEW_DIRECTION_SHARE * np.max(np.abs(np.diag(r)))
    v = q[:, keep]
    w = np.linalg.solve(r.T, np.asarray(images0, float).T).T[:, keep]
    blocks = 1
    while True:
        h = v.T @ w
        rho, y = np.linalg.eig(h)
        ritz = v @ y
        residual = np.linalg.norm(w @ y - ritz * rho, axis=0) / np.linalg.norm(ritz, axis=0)
        order = np.argsort(-np.abs(rho))
        rho, residual, ritz = rho[order], residual[order], ritz[:, order]
        level = floor(float(np.max(np.abs(rho), initial=0.0)))
        open_ = (np.abs(rho) >= level) & (residual > RESIDUAL_SHARE * np.abs(rho))
        if not np.any(open_) or blocks >= max_blocks or v.shape[1] >= v.shape[0]:
            break
        # The images' directions not yet in the span: the next Krylov block.
        rest = w - v @ (v.T @ w)
        rest -= v @ (v.T @ rest)                      # twice is enough (Giraud et al. 2005)
        u, s, _ = np.linalg.svd(rest, full_matrices=False)
        # A direction whose image is below the floor carries only multipliers below it.
        cut = max(NEW_DIRECTION_SHARE * float(np.linalg.norm(w, 2)), 0.1 * level, np.finfo(float).tiny)
        new = u[:, s > cut]
        new = new[:, :v.shape[0] - v.shape[1]]
        if new.shape[1] == 0:
            break
        v, w = np.hstack([v, new]), np.hstack([w, apply(new)])
        blocks += 1
    return {"multipliers": rho, "floor": level, "residuals": residual, "vectors": ritz, "blocks": blocks,
            "columns": v.shape[1]}


def floquet_subspace(model, q0, v0, period: float, hover_summary: dict, hover_shapes: np.ndarray) -> dict:
    """The least damped Floquet multipliers of the periodic motion through (q0, v0) at t = 0.

    Parameters
    ----------
    model : pydriver.model.Model
        The flight's model (its solver settings: rtol sets the floor and the columns' atol).
    q0, v0 : (nq,) arrays
        A start on the periodic orbit at t = 0.
    period : float
        The period T [s].
    hover_summary : dict
        ``frequencies_hz``, ``damped_frequencies_hz`` and ``damping_ratios`` of the hover modes.
    hover_shapes : (nq, nf) array
        Their undamped shapes in q (the modal analysis's ``mode_shapes_q``).

    Returns
    -------
    dict
        :func:`subspace_multipliers`' dict with ``floor`` (the multipliers below it are
        round-off: FLOOR_SHARE rtol |rho|_max, and no less than ten times the columns' absolute
        tolerance), ``resolved`` (above the floor with a converged Ritz pair), ``start_modes``
        (hover modes in the start block), ``column_atol`` and the solver statistics of every
        block (``stats``).
    """
    settings = model.solver_settings()
    rtol = float(settings["rtol"])
    column_atol = rtol * COLUMN_ATOL_SHARE
    # Before any integration the hover modes say how large the largest multiplier is.
    guess = FLOOR_SHARE * rtol * float(np.max(hover_multipliers(hover_summary, period), initial=1.0))
    count, dq, dv = hover_start_block(hover_shapes, hover_summary, period, max(guess, 10.0 * column_atol))
    omega = 2.0 * np.pi / period
    first = model.core.monodromy_columns(settings, 0.0, q0, v0, [period], dq, dv, column_atol)
    basis, nf = first["basis"], first["basis"].shape[1]
    scale = np.concatenate([np.ones(nf), np.full(nf, 1.0 / omega)])   # x = (a, b / Omega)
    stats = [first["stats"]]

    def apply(directions):
        x = directions / scale[:, None]
        out = model.core.monodromy_columns(settings, 0.0, first["q0"], first["v0"], [period], basis @ x[:nf],
                                           basis @ x[nf:], column_atol)
        stats.append(out["stats"])
        return out["images"] * scale[:, None]

    x0 = np.vstack([basis.T @ dq, basis.T @ dv]) * scale[:, None]
    out = subspace_multipliers(apply, x0, first["images"] * scale[:, None],
                               lambda rho_max: max(FLOOR_SHARE * rtol * rho_max, 10.0 * column_atol))
    size = np.abs(out["multipliers"])
    resolved = (size >= out["floor"]) & (out["residuals"] <= RESIDUAL_SHARE * size)
    return {**out, "resolved": resolved, "start_modes": count, "column_atol": column_atol, "stats": stats}


def add_floquet_subspace(model, result) -> None:
    """Put the Floquet modes of a flight result's periodic motion, from :func:`floquet_subspace`
    at its start ``result.extra['orbit']``, into its summary (``summary['floquet']``, with the
    number of bodies, the method and its largest relative Ritz residual) and ``floquet.csv``
    (with a column ``n_bodies``); its integration steps and wall time are in the summary.  Needs
    the hover modes of the result (:func:`pydriver.analyses.hover_modes.add_hover_modes`)."""
    orbit, s = result.extra["orbit"], result.summary
    period = float(orbit["period_s"])
    hover = {k: s[k] for k in ("frequencies_hz", "damped_frequencies_hz", "damping_ratios")}
    t_wall = time.perf_counter()
    out = floquet_subspace(model, orbit["q0"], orbit["v0"], period, hover, result.extra["hover_mode_shapes_q"])
    t_wall = time.perf_counter() - t_wall
    cols = modes_of_multipliers(out["multipliers"], period, hover["damped_frequencies_hz"], hover["damping_ratios"],
                                out["resolved"])
    cols["n_bodies"] = np.full(len(cols["mode"]), model.n_bodies)
    size = np.abs(out["multipliers"])
    above = size >= out["floor"]
    summary = floquet_summary(cols, period)
    summary.update(n_bodies=model.n_bodies, method="subspace",
                   method_words=f"Rayleigh-Ritz on {out['columns']} directions ({out['blocks']} Krylov blocks from "
                                f"{out['start_modes']} hover modes)",
                   round_off_floor=float(out["floor"]),
                   max_relative_residual=float(np.max(out["residuals"][above] / size[above], initial=0.0)),
                   unresolved_above_floor=int(np.count_nonzero(above & ~out["resolved"])),
                   steps=int(sum(st["steps"] for st in out["stats"])), wall_time_s=t_wall)
    s["floquet"] = summary
    result.extra.setdefault("tables", {})["floquet.csv"] = cols
    if not summary["stable"]:
        s.setdefault("warnings", []).append(
            f"the periodic motion is unstable: a Floquet multiplier has |rho| = "
            f"{summary['max_multiplier_abs']:.6g} > 1 at n = {model.n_bodies} (floquet.csv)")
    if summary["unresolved_above_floor"]:
        s.setdefault("warnings", []).append(
            f"Floquet: {summary['unresolved_above_floor']} multiplier(s) above round-off ({out['floor']:.2g}) kept a "
            f"Ritz residual above {RESIDUAL_SHARE:g} |rho| after {out['blocks']} blocks at n = {model.n_bodies} "
            "(floquet.csv 'resolved' = 0)")
