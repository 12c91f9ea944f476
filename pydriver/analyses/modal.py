"""Modal analysis about the static equilibrium (docs/model.md, "Modal analysis")."""

from __future__ import annotations

import time

import numpy as np

from pydriver.analyses.common import base_summary, equilibrium_table, reactions, straight_zy_warnings
from pydriver.analyses.linear_modes import modal_modes
from pydriver.analyses.singularity import equilibrium_report
from pydriver.analyses.stability import stability_summary
from pydriver.analyses.statics import equilibrium, unforced, unforced_note
from pydriver.errors import RunError
from pydriver.run_result import Result


def cm_mode_shapes(model, q, shapes, h: float = 1.0e-6) -> np.ndarray:
    """CM displacement per unit modal coordinate (3 n, n_modes), by central differences of the
    kinematics along each mode."""
    out = np.empty((3 * model.n_bodies, shapes.shape[1]))
    for i in range(shapes.shape[1]):
        cp = model.core.shape(q + h * shapes[:, i])["cm"]
        cm = model.core.shape(q - h * shapes[:, i])["cm"]
        out[:, i] = ((cp - cm) / (2.0 * h)).reshape(-1)
    return out


def modes_about(model, q, lam) -> dict:
    """The modal analysis's modes about the equilibrium (q, lambda): the core's linearised
    equations solved by :func:`pydriver.analyses.linear_modes.modal_modes`; its RunError names
    the deck."""
    mats = model.core.modal_matrices(q, lam)
    try:
        return modal_modes(mats)
    except RunError as err:
        raise RunError(f"deck '{model.name}': {err}") from err


def modal_analysis(model, run_dir=None) -> Result:
    """Frequencies, damping ratios and mode shapes about the equilibrium (``run_dir``: unused,
    the registry's signature)."""
    t0 = time.perf_counter()
    notes = unforced_note(model)
    with unforced(model):
        q, lam, stats = equilibrium(model)
        modes = modes_about(model, q, lam)
        zero = np.zeros((model.nq, 1))
        sample = model.core.sample([0.0], q[:, None], zero)
        cm_shapes = cm_mode_shapes(model, q, modes["shapes"])
        stability, stability_warnings = stability_summary(model, q, lam)
    wall = time.perf_counter() - t0
    nf = model.nq - model.nc
    fu, fd, zeta = modes["f_undamped_hz"], modes["f_damped_hz"], modes["zeta"]
    summary = base_summary(model, "modal", wall)
    summary.update(solver=stats, equilibrium_stability=stability, max_constraint_violation_m=float(sample.g_max[0]),
                   reactions=reactions(sample.wrenches.at(0), model.nc > 0),
                   tip_m=[float(x) for x in sample.joints[:, -1, 0]],
                   frequencies_hz=[float(x) for x in fu], damped_frequencies_hz=[float(x) for x in fd],
                   damping_ratios=[float(x) for x in zeta],
                   n_zero_stiffness_modes=int(np.count_nonzero(fu == 0.0)),
                   zero_stiffness_modes=[int(k) + 1 for k in np.flatnonzero(fu == 0.0)])
    # Mode shapes as CM displacements, each scaled to a largest component of 1.
    scale = np.max(np.abs(cm_shapes), axis=0)
    scale[scale == 0] = 1.0
    table_modes = {"mode": np.arange(1, nf + 1), "f_undamped_hz": fu, "f_damped_hz": fd, "zeta": zeta}
    for j in range(model.n_bodies):
        for c, name in enumerate("xyz"):
            table_modes[f"d{name}{j + 1}"] = cm_shapes[3 * j + c] / scale
    table = equilibrium_table(model, sample)
    near, near_warnings = equilibrium_report(model, q)
    if near is not None:
        summary["cardan_singularity"] = near
    warnings = notes + straight_zy_warnings(model, table["beta_deg"]) + near_warnings + [
        w for w in stability_warnings if not w.startswith("the equilibrium is neutral")]
    if summary["n_zero_stiffness_modes"]:
        # Zero within the round-off of their own stiffness (linear_modes.stiffness_floor), not of the
        # stiffest mode's: a soft spring keeps its small frequency.
        which = ", ".join(str(k) for k in summary["zero_stiffness_modes"])
        warnings.append(f"{summary['n_zero_stiffness_modes']} zero-stiffness (rigid-body) mode(s), set to 0 Hz: "
                        f"mode {which} (a coordinate without a spring and without gravity across it; the "
                        "equilibrium is not unique along it)")
    if warnings:
        summary["warnings"] = warnings
    return Result(summary=summary, table=table,
                  extra={"q": q, "lambda": lam, "modes": table_modes, "mode_shapes_q": modes["shapes"]})
