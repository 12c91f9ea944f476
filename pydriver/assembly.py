"""From a validated deck to the model in the core: bodies, joint constants, loads, supports
and the rotor, in SI units and radians (docs/model.md states every choice made here).

The joint constants come either from the deck's direct ``&springs`` (the thesis's c_y, c_z) or
from physical cable parameters ``&cable`` (EI, GJ, mass per length, structural damping), which
hold for any n: a Hencky bar chain (H. Hencky, Der Eisenbau 11, 1920), where a joint stands for the cable between the midpoints of its two bodies,
c_j = EI / l_j with l_j that length, so 2 EI / l for a joint on a clamp (half an element), and
a body held by clamp B is a half element whose joint stands for the whole of it and half the
previous body.  This converges at O(1/n^2) (tests/test_cable_parameters.py).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pydriver.components import add_loads, support_motion_parameters, support_of
from pydriver.core import CoreModel
from pydriver.deckfile import Deck
from pydriver.motions import DEG, blade_azimuth0, rot_y, rot_z, rotor, rotor_parameters, support_motion
from pydriver.shape_resample import chain_lengths


@dataclass
class Bodies:
    """Per-body geometry and inertia of the chain (SI)."""

    lengths: np.ndarray
    radii: np.ndarray
    masses: np.ndarray
    locked: np.ndarray            #: joint j locked (bool)
    physical: bool                #: joint constants from &cable


def bodies(deck: Deck) -> Bodies:
    """Lengths, radii, masses and locked joints of the deck's chain."""
    n = deck.n_bodies
    physical = deck.has("cable.ei")
    if deck.has("chain.body_length"):
        lengths = np.asarray(deck["chain.body_length"], float)
    else:
        # With clamp B the body it holds is a half element (module docstring).
        lengths = chain_lengths(n, deck["chain.total_length"], physical and bool(deck["clamp_b.active"]))
    radii = 0.5 * np.asarray(deck["chain.diameter"], float)
    if deck.has("chain.density"):
        masses = deck["chain.density"] * np.pi * radii**2 * lengths          # eq. 4.51
    elif deck.has("chain.total_mass"):
        masses = deck["chain.total_mass"] * lengths / lengths.sum()
    elif deck.has("chain.body_mass"):
        masses = np.asarray(deck["chain.body_mass"], float)
    else:
        masses = deck["cable.mass_per_length"] * lengths
    locked = np.zeros(n, bool)
    # Thesis reading: a clamped first body is a locked joint 1.  With physical parameters the
    # clamp holds the cable end through joint 1 and its 2 EI / l spring (a half element).
    locked[0] = deck["chain.first_body"] == "clamped" and not physical
    return Bodies(lengths, radii, masses, locked, physical)


def represented_lengths(deck: Deck, b: Bodies) -> np.ndarray:
    """The cable length each joint stands for (module docstring): half of each adjacent
    body, a whole clamped last body, half the first body for a joint on clamp A."""
    n = len(b.lengths)
    ell = np.empty(n)
    ell[0] = 0.5 * b.lengths[0]
    ell[1:] = 0.5 * (b.lengths[:-1] + b.lengths[1:])
    if deck["clamp_b.active"] and n > 1:
        ell[-1] = 0.5 * b.lengths[-2] + b.lengths[-1]
    return ell


def joint_constants(deck: Deck, b: Bodies) -> tuple:
    """Stiffness, damping and rest angle per coordinate (eq. 4.78-4.86)."""
    joint = deck["chain.joint"]
    n = deck.n_bodies
    per_joint = {"zy": 2, "xy": 2, "xyz": 3}[joint]
    c_rows, d_rows, rest_rows = [], [], []
    if b.physical:
        ell = represented_lengths(deck, b)
        c_bend = deck["cable.ei"] / ell
        c_twist = deck["cable.gj"] / ell if deck.has("cable.gj") else np.zeros(n)
        if deck["chain.first_body"] == "pivot":
            c_bend[0] = c_twist[0] = 0.0
        tau = deck["cable.damping_time"]
        # Every spring rests straight; joint 1's relative to the frame of clamp A (&clamp_a),
        # whose axis is the direction in which the clamp holds the cable.
        for j in range(n):
            c_rows.append([c_bend[j], c_bend[j], c_twist[j]][:per_joint])
            d_rows.append([tau * c_bend[j], tau * c_bend[j], tau * c_twist[j]][:per_joint])
            rest_rows.append([0.0] * per_joint)
    else:
        s = {k: deck[f"springs.{k}"] for k in ("c_gamma", "c_beta", "d_gamma", "d_beta", "d_twist")}
        c_tw = deck["springs.c_twist"] if deck["springs.c_twist"] is not None else np.zeros(n)
        for j in range(n):
            if joint == "zy":
                c_rows.append([s["c_gamma"][j], s["c_beta"][j]])
                d_rows.append([s["d_gamma"][j], s["d_beta"][j]])
                rest_rows.append([deck["springs.rest_gamma_deg"][j] * DEG, deck["springs.rest_beta_deg"][j] * DEG])
            else:
                c_rows.append([s["c_beta"][j], s["c_beta"][j], c_tw[j]][:per_joint])
                d_rows.append([s["d_beta"][j], s["d_beta"][j], s["d_twist"][j]][:per_joint])
                rest_rows.append([0.0] * per_joint)
    free = [j for j in range(n) if not b.locked[j]]
    c = np.array([x for j in free for x in c_rows[j]])
    d = np.array([x for j in free for x in d_rows[j]])
    rest = np.array([x for j in free for x in rest_rows[j]])
    return c, d, rest


def rotation_vector_springs(deck: Deck, b: Bodies) -> bool:
    """Whether the joint springs act on the rotation vector of each joint (loads/
    rotation_springs.f90): the physical cable parameters with the bending + twist joint."""
    return b.physical and deck["chain.joint"] == "xyz" and deck["cable.spring_measure"] == "rotation_vector"


def build(deck: Deck) -> tuple[CoreModel, dict]:
    """Build the deck's model in the core.

    Returns
    -------
    core : CoreModel
    description : dict
        What was built, as plain numbers: ``bodies``, ``first_coord``, the joint constants
        ``stiffness``/``damping``/``rest`` per coordinate, ``base_rotation`` and ``base_moves``
        (support A carried by the rotor or the blade), ``loads`` (``{kind: {name: value}}``,
        every load added, by its registry declaration), ``support`` (the kind of support B or
        None) and ``support_parameters`` (its block by name, motion included), ``clamp``
        (position, rotation of a support that holds both, or None), ``rotor`` (or None), the
        deck's start state ``q0``, ``v0`` [rad, rad/s], ``joint_lengths`` (the cable length each
        joint stands for, :func:`represented_lengths`) and ``cable`` (the physical cable
        parameters ``ei``, ``gj``, ``mass_per_length``, ``damping_time`` given, or None for the
        thesis's per-joint constants).  Analyses read the model's geometry from here, never from
        the deck again (issue 36).
    """
    b = bodies(deck)
    gamma = np.asarray(deck["shape.gamma_deg"], float) * DEG
    beta = np.asarray(deck["shape.beta_deg"], float) * DEG
    core = CoreModel(deck.name, b.lengths, b.radii, b.masses, deck["chain.joint"], b.locked,
                     np.vstack([gamma, beta]))
    base_rotation = rot_z(deck["clamp_a.gamma_deg"] * DEG) @ rot_y(deck["clamp_a.beta_deg"] * DEG)
    core.set_base(np.zeros(3), base_rotation)      # fixed for now: kinematics of the start shape
    core.finish()
    q0, v0 = core.thesis_coordinates(gamma, beta, np.asarray(deck["shape.gamma_rate_deg"]) * DEG,
                                     np.asarray(deck["shape.beta_rate_deg"]) * DEG)
    first_coord = _first_coords(b.locked, {"zy": 2, "xy": 2, "xyz": 3}[deck["chain.joint"]])
    c, d, rest = joint_constants(deck, b)
    # Every load from its declaration in the component registry (pydriver/components.py).
    loads = add_loads(core, deck, {"stiffness": c, "damping": d, "rest": rest,
                                   "rotation_vector": rotation_vector_springs(deck, b)})
    rot = rotor(deck)
    if rot is not None:
        core.set_rotor(rotor_parameters(rot))
    # Support B from its declaration in the registry; its position places the blade and moves A.
    support = support_of(deck)
    params = support.pack(deck, {"start_shape": core.shape(q0)}) if support is not None else {}
    b_position = params.get("position", np.zeros(3))
    if rot is not None:
        rot["azimuth0"] = blade_azimuth0(deck, rot, b_position)
    motion_a = support_motion(deck, rot, "clamp_a", b_position)
    if motion_a["motion.hinges"]:
        core.set_base(np.zeros(3), base_rotation, motion_a)
    if support is not None:
        params.update(support_motion_parameters(support, deck, rot, b_position))
        core.add_support(support.kind, params, context=support.context, deck_keys=support.deck_keys)
    core.finish()
    # The pose of a support that holds the orientation too (clamp B), for pydriver.scene.
    clamp = (params["position"], params["rotation"].reshape(3, 3, order="F")) if "rotation" in params else None
    return core, {"bodies": b, "first_coord": first_coord, "stiffness": c, "damping": d, "rest": rest,
                  "base_rotation": base_rotation, "base_moves": bool(motion_a["motion.hinges"]), "loads": loads,
                  "support": support.kind if support is not None else None, "support_parameters": params,
                  "clamp": clamp, "rotor": rot, "q0": q0, "v0": v0,
                  "joint_lengths": represented_lengths(deck, b), "cable": _cable(deck)}


def _cable(deck: Deck) -> dict | None:
    """The physical cable parameters the deck gives (&cable), or None."""
    if not deck.has("cable.ei"):
        return None
    return {k: float(deck[f"cable.{k}"]) for k in ("ei", "gj", "mass_per_length", "damping_time")
            if deck[f"cable.{k}"] is not None}


def _first_coords(locked: np.ndarray, per_joint: int) -> np.ndarray:
    """1-based index of every joint's first coordinate (0 for a locked joint)."""
    out = np.zeros(len(locked), int)
    k = 1
    for j, lk in enumerate(locked):
        if not lk:
            out[j] = k
            k += per_joint
    return out
