"""Pieces every analysis reports: reactions, the equilibrium table, per-joint loads, the
summary's common part and its warnings."""

from __future__ import annotations

import numpy as np

from pydriver.core import Sample, Wrenches
from pydriver.errors import DeckError

RAD2DEG = 180.0 / np.pi
REACTION_NAMES = ["FA_x", "FA_y", "FA_z", "MA_x", "MA_y", "MA_z", "FB_x", "FB_y", "FB_z", "MB_x", "MB_y", "MB_z"]
#: The loads the cable puts on its supports, each the reaction's opposite (what a clamp is sized
#: for; issue 37: structural engineers read this sign), in the order of REACTION_NAMES.
SUPPORT_LOAD_NAMES = [f"{n[:2]}_on_support_{n[3]}" for n in REACTION_NAMES]


def reactions(w: Wrenches, has_b: bool) -> dict:
    """Support-on-chain wrenches in the model frame (of one sample): {"A": {"F", "M"}, "B": ...}."""
    out = {"A": {"F": [float(x) for x in w.force_a], "M": [float(x) for x in w.moment_a]}}
    if has_b:
        out["B"] = {"F": [float(x) for x in w.force_b], "M": [float(x) for x in w.moment_b]}
    return out


def loads_on_supports(reactions_block: dict) -> dict:
    """The loads the cable puts on its supports (cable on support, what a clamp carries): each
    reaction of :func:`reactions` with its sign turned, in the same frame, the moment about the
    same clamp point (Newton's third law)."""
    return {side: {k: [-x for x in v] for k, v in w.items()} for side, w in reactions_block.items()}


def joint_geometry(model) -> dict:
    """Per joint: the cable length it stands for and the diameter there (for curvature and
    jacket strain: kappa = bend angle / length, eps = kappa d / 2)."""
    b = model.description["bodies"]
    ell = model.description["joint_lengths"]
    d = 2.0 * b.radii
    d_joint = d.copy()
    d_joint[1:] = 0.5 * (d[:-1] + d[1:])
    return {"length": ell, "diameter": d_joint}


def joint_columns(model, sample: Sample, k=slice(None)) -> dict:
    """Per-joint loads of samples k as columns: axial and shear force, bending and torsional
    moment, curvature and jacket strain (docs/model.md, "Internal loads")."""
    geo = joint_geometry(model)
    out = {}
    kappa = sample.bend_angle[k] / geo["length"]
    for j in range(model.n_bodies):
        n = j + 1
        out[f"axial{n}_N"] = sample.axial[k, j]
        out[f"shear{n}_N"] = sample.shear[k, j]
        out[f"bending{n}_Nm"] = sample.bending[k, j]
        out[f"torsion{n}_Nm"] = sample.torsion[k, j]
        out[f"curvature{n}_1pm"] = kappa[..., j]
        out[f"strain{n}"] = 0.5 * geo["diameter"][j] * kappa[..., j]
    # Signed components in the child's body axes (fatigue counts them around the jacket).
    for j in range(model.n_bodies):
        n = j + 1
        out[f"moment_x{n}_Nm"] = sample.moment_xy[k, 0, j]
        out[f"moment_y{n}_Nm"] = sample.moment_xy[k, 1, j]
        out[f"kappa_x{n}_1pm"] = sample.bend_xy[k, 0, j] / geo["length"][j]
        out[f"kappa_y{n}_1pm"] = sample.bend_xy[k, 1, j] / geo["length"][j]
    return out


def equilibrium_table(model, sample: Sample) -> dict:
    """The thesis's table columns (body, gamma, beta, CM) plus joint loads and joint points."""
    nb = model.n_bodies
    ang = sample.angles[:, :, 0]
    cm = sample.cm[:, :, 0]
    joints = sample.joints[:, :, 0]
    geo = joint_geometry(model)
    kappa = sample.bend_angle[0] / geo["length"]
    return {"body": np.arange(1, nb + 1), "gamma_deg": ang[0] * RAD2DEG, "beta_deg": ang[1] * RAD2DEG,
            "x_m": cm[0], "y_m": cm[1], "z_m": cm[2],
            "joint_x_m": joints[0, :nb], "joint_y_m": joints[1, :nb], "joint_z_m": joints[2, :nb],
            "axial_N": sample.axial[0], "shear_N": sample.shear[0], "bending_Nm": sample.bending[0],
            "torsion_Nm": sample.torsion[0], "curvature_1pm": kappa,
            "strain": 0.5 * geo["diameter"] * kappa}


def base_summary(model, analysis: str, wall: float) -> dict:
    """The summary's common part."""
    d = model.deck
    springs = d.values["springs"]["c_beta"]
    free = [j for j in range(model.n_bodies) if not (j == 0 and d["chain.first_body"] == "clamped")]
    c_beta = float(np.median(springs[free])) if free else 0.0
    cable = model.description["cable"]
    if cable is not None:
        # Physical cable: the bending spring of an interior joint, EI / l (docs/model.md);
        # &springs c_beta is unused (it had been reported as 0).
        c_beta = cable["ei"] / float(np.median(model.description["bodies"].lengths))
    out = {"case": model.case, "deck": model.name, "analysis": analysis, "wall_time_s": wall,
           **({"description": d["case.description"]} if d["case.description"] else {}),
           "n_bodies": model.n_bodies, "n_coords": model.nq, "n_constraints": model.nc,
           "c_beta_Nm_per_rad": c_beta}
    rot = model.description["rotor"]
    out["frame"] = "hub" if rot is not None and rot["hub"] else "inertial"
    if rot is not None:
        out["rotor"] = {"profile": rot["profile"], "rpm_max": rot["omega_max"] * 30.0 / np.pi,
                        "centre_m": [float(x) for x in rot["centre"]],
                        "blade_azimuth0_deg": float(np.degrees(rot["azimuth0"]))}
    if cable is not None:
        out["cable"] = dict(cable)
    return out


def straight_zy_warnings(model, beta_deg) -> list:
    """Warn where the thesis's zy joint sits at beta = 0 in a result.

    There gamma is a twist, so the joint has lost one bending direction: a load across it
    does no work on any coordinate at first order and is silently carried as if the cable
    were rigid sideways (docs/model.md, tests/test_hard_cases.py).  ``&chain joint = 'xy'``
    has no such point.
    """
    if model.deck["chain.joint"] != "zy":
        return []
    locked_first = model.deck["chain.first_body"] == "clamped"
    straight = [j + 1 for j in range(model.n_bodies)
                if not (j == 0 and locked_first) and abs(np.sin(np.radians(beta_deg[j]))) < 1e-6]
    if not straight:
        return []
    return [f"joints {straight} of the thesis's zy parametrisation are straight (beta = 0), where "
            "gamma is a twist and the joint cannot bend sideways: loads across those joints are "
            "carried as if the cable were rigid there; use &chain joint = 'xy' (Cardan bending)"]


def rotor_period(model) -> float:
    """The revolution period 2 pi / Omega [s] of the deck's constant rotor speed.

    The schema refuses speeds that are not 0 or at least 1e-3 rpm, but a speed that reaches
    here as 0 (a denormal rpm times pi/30 underflows) must not divide by zero: a DeckError
    naming the speed key instead.
    """
    # The built model's speed (CoreModel.update may have changed it since the description was made).
    omega = float(model.core.parameter("rotor.omega")[0])
    period = 2.0 * np.pi / omega if omega > 0.0 else np.inf
    if not np.isfinite(period):
        group, key = ("rotor", "rpm") if "rotor" in model.deck.groups else ("loads", "rotor_rpm")
        raise DeckError(model.name, group, key, f"a flight run needs a rotor speed with a finite revolution period, "
                                                f"got Omega = {omega:g} rad/s")
    return period
