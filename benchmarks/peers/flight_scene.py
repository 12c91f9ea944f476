"""The forward-flight scene for the benchmarks, without Exudyn (importing Exudyn slows the
Fortran core in the same process, work_precision.peer_modules): the deck refined to n bodies
and rotorcable's consistent flight start."""

from __future__ import annotations

import numpy as np

import pydriver
from pydriver.analyses.statics import equilibrium


def flight_model(deck_path, n_bodies: int | None = None, sets: dict | None = None) -> pydriver.Model:
    """The forward-flight deck as a Model, optionally refined to ``n_bodies`` at equal bending
    and twist stiffness per length (per-joint springs and dampers scale with n/n0, the start
    shape keeps its total bend; pydriver.study.refined_changes) and with ``sets`` applied."""
    m = pydriver.Model.from_deck(deck_path)
    changes = {}
    n0 = m.n_bodies
    if n_bodies and n_bodies != n0:
        d = m.deck
        r = n_bodies / n0
        beta = np.asarray(d["shape.beta_deg"], float)
        bend = float(beta[1:].sum()) / (n_bodies - 1)
        gamma = np.asarray(d["shape.gamma_deg"], float)
        changes.update({"chain.n_bodies": n_bodies,
                        "shape.gamma_deg": f"{gamma[0]}, {gamma[1]}, {n_bodies - 2}*{gamma[2]}",
                        "shape.beta_deg": f"{beta[0]}, {n_bodies - 1}*{bend!r}"})
        for key in ("c_beta", "d_beta", "c_twist", "d_twist"):
            changes[f"springs.{key}"] = repr(float(np.asarray(d[f"springs.{key}"], float)[0] * r))
    changes.update(sets or {})
    return m.with_changes(changes) if changes else m


def flight_start(model):
    """rotorcable's start of a flight run: equilibrium of the loads at t = 0 relative to the hub,
    made consistent with the moving clamp by the core (as pydriver.analyses.flight does)."""
    q0, _, _ = equilibrium(model, t=0.0)
    session = model.core.start(model.solver_settings(), 0.0, q0, np.zeros_like(q0))
    q, v = np.array(session.q0, float), np.array(session.v0, float)
    session.close()
    return q, v
