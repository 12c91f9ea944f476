"""The columns of a run's record (``timeseries.csv``/``.h5``) and how one chunk of samples fills
them: the dynamic and flight runs write them, a continuation reads them back
(:mod:`pydriver.checkpoint`), and the integration error check and the flight sensitivities
compare against them."""

from __future__ import annotations

import numpy as np

from pydriver.analyses.common import RAD2DEG, REACTION_NAMES, SUPPORT_LOAD_NAMES, joint_columns


#: Names of a joint's coordinates, in their order in q (docs/model.md: thesis gamma/beta, or
#: the Cardan bending angles about the joint's x and y axes, and the twist).
COORDINATE_NAMES = {"zy": ("gamma", "beta"), "xy": ("cardan_x", "cardan_y"),
                    "xyz": ("cardan_x", "cardan_y", "twist")}


def coordinate_columns(model) -> list[tuple[str, str, int]]:
    """(coordinate column, rate column, 0-based index in q) of every joint coordinate: the
    coordinates the springs act on, unwrapped (gamma{j}_deg wraps to +-180), and their rates."""
    names = COORDINATE_NAMES[model.deck["chain.joint"]]
    out = []
    for j, first in enumerate(model.description["first_coord"]):
        if first == 0:                      # a locked joint (a clamped first body) has none
            continue
        for k, name in enumerate(names):
            out.append((f"{name}{j + 1}_coord_deg", f"{name}{j + 1}_rate_degps", int(first) - 1 + k))
    return out


def column_names(model) -> list[str]:
    """The time-series columns of a dynamic run of this model."""
    nb = model.n_bodies
    names = ["t"]
    if model.description["rotor"] is not None:
        names += ["psi_deg", "azimuth_deg"]
    names += [f"{c}{j + 1}" for j in range(nb) for c in "xyz"]
    names += [f"{a}{j + 1}_deg" for j in range(nb) for a in ("gamma", "beta")]
    names += REACTION_NAMES if model.nc > 0 else REACTION_NAMES[:6]
    names += SUPPORT_LOAD_NAMES if model.nc > 0 else SUPPORT_LOAD_NAMES[:6]
    names += ["tip_x", "tip_y", "tip_z", "E_kin_J", "E_pot_J", "g_max_m"]
    names += [f"{q}{j + 1}_{u}" for j in range(nb) for q, u in
              (("axial", "N"), ("shear", "N"), ("bending", "Nm"), ("torsion", "Nm"), ("curvature", "1pm"))]
    names += [f"strain{j + 1}" for j in range(nb)]
    names += [f"{q}{j + 1}_{u}" for j in range(nb) for q, u in
              (("moment_x", "Nm"), ("moment_y", "Nm"), ("kappa_x", "1pm"), ("kappa_y", "1pm"))]
    coords = coordinate_columns(model)
    names += [c for c, _, _ in coords] + [r for _, r, _ in coords]
    return names


def chunk_columns(model, t, sample, q, v) -> dict:
    """One chunk's time-series columns from the core's samples and the coordinates q, v
    (nq, len(t)) they were taken at."""
    nb = model.n_bodies
    cols = {"t": np.asarray(t, float)}
    rot = model.description["rotor"]
    if rot is not None:
        cols["psi_deg"] = np.mod(sample.psi * RAD2DEG, 360.0)
        cols["azimuth_deg"] = np.mod((sample.psi + rot["azimuth0"]) * RAD2DEG, 360.0)
    for j in range(nb):
        for c, name in enumerate("xyz"):
            cols[f"{name}{j + 1}"] = sample.cm[c, j]
    for j in range(nb):
        cols[f"gamma{j + 1}_deg"] = sample.angles[0, j] * RAD2DEG
        cols[f"beta{j + 1}_deg"] = sample.angles[1, j] * RAD2DEG
    wrenches = sample.wrenches.as_flat()       # in the order of REACTION_NAMES
    for i, name in enumerate(REACTION_NAMES[:12 if model.nc > 0 else 6]):
        cols[name] = wrenches[:, i]
    for i, name in enumerate(SUPPORT_LOAD_NAMES[:12 if model.nc > 0 else 6]):
        cols[name] = -wrenches[:, i]
    for c, name in enumerate(("tip_x", "tip_y", "tip_z")):
        cols[name] = sample.joints[c, -1]
    cols["E_kin_J"] = sample.kinetic
    cols["E_pot_J"] = sample.potential
    cols["g_max_m"] = sample.g_max
    cols.update(joint_columns(model, sample))
    coords = coordinate_columns(model)
    for name, _, i in coords:
        cols[name] = np.asarray(q, float)[i] * RAD2DEG
    for _, name, i in coords:
        cols[name] = np.asarray(v, float)[i] * RAD2DEG
    return cols
