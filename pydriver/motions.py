"""The rotor and the prescribed motions of the supports, from the deck to the core's flat
description (src_fortran/motion/builder.f90): speed profile, frame, and for each support the
hinges that move it (the rotor's own axis for a support carried round in the inertial frame;
the blade's flap, lead-lag and pitch hinges for a support on the blade).

Conventions (docs/model.md, "Rotor and blade motion"): the rotor turns about the deck's z axis
through its centre, counter-clockwise seen from above (Omega > 0), the hub frame coincides with
the inertial frame at t = 0, the helicopter flies along +x (the free stream is -V e_x).  The
blade azimuth psi_b is measured from downstream (-x) in the sense of rotation: psi_b = psi(t) +
azimuth_0, with azimuth_0 that of clamp B at t = 0 unless the deck gives it.
"""

from __future__ import annotations

import numpy as np

from pydriver.deckfile import Deck
from pydriver.schema import lookup

DEG = np.pi / 180.0
RPM = 2.0 * np.pi / 60.0
ANGLE_CONSTANT, ANGLE_FOURIER, ANGLE_TABLE, ANGLE_ROTOR = 0, 1, 2, 3


def rot_z(a: float) -> np.ndarray:
    """Rotation by a [rad] about z (the thesis's gamma)."""
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def rot_y(b: float) -> np.ndarray:
    """Rotation by b [rad] about y (the thesis's beta)."""
    c, s = np.cos(b), np.sin(b)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def rotor(deck: Deck) -> dict | None:
    """Speed profile, centre and frame of the deck's rotor; None for a still rotor."""
    offset = np.asarray(deck["loads.rotor_offset"], float)
    legacy_centre = np.array([-offset[0], -offset[1], 0.0])      # offset = deck origin - rotor centre
    if "rotor" not in deck.groups:
        rpm = deck["loads.rotor_rpm"] if deck.has("loads.rotor_rpm") else 0.0
        if rpm == 0.0:
            return None
        return {"profile": "constant", "centre": legacy_centre, "params": [rpm * RPM], "hub": True,
                "body_couples": True, "omega_max": rpm * RPM}
    r = deck.values["rotor"]
    centre = np.asarray(r["centre"], float) if deck.has("rotor.centre") else legacy_centre
    if r["profile"] == "constant":
        params = [r["rpm"] * RPM]
        omega_max = params[0]
    elif r["profile"] == "runup":
        params = [r["rpm_start"] * RPM, r["rpm"] * RPM, r["runup_start"], r["runup_time"]]
        omega_max = max(params[:2])
    else:
        params = list(r["table_t"]) + [x * RPM for x in r["table_rpm"]]
        omega_max = max(r["table_rpm"]) * RPM
    return {"profile": r["profile"], "centre": centre, "params": params, "hub": r["frame"] == "hub",
            "body_couples": bool(r["body_couples"]), "omega_max": omega_max}


def blade_azimuth0(deck: Deck, rot: dict, clamp_position) -> float:
    """Blade azimuth at t = 0 [rad], measured from downstream (-x) in the sense of rotation.

    The deck's ``azimuth0_deg``; else the direction of the blade's pitch (feathering) axis in
    the rotor plane, pointing away from the rotor centre (the blade's own azimuth: the harmonics
    of the flap, lag and pitch series are those of the blade, issue 21 item 5); else, for a
    pitch axis along the rotor axis, the azimuth of clamp B about the rotor axis (the earlier
    default, 8.9 deg off the blade's azimuth in the main job).
    """
    if deck.has("blade.azimuth0_deg"):
        return deck["blade.azimuth0_deg"] * DEG
    centre = np.asarray(rot["centre"], float)
    if "blade" in deck.groups:
        axis = np.asarray(deck["blade.pitch_axis"], float)[:2]
        hinge = deck["blade.pitch_hinge"] if deck.has("blade.pitch_hinge") else deck["blade.flap_hinge"]
        outward = np.asarray(hinge, float)[:2] - centre[:2]
        if np.linalg.norm(axis) > 1e-9 * np.linalg.norm(deck["blade.pitch_axis"]):
            if np.dot(axis, outward) < 0.0:
                axis = -axis
            return float(np.mod(np.arctan2(axis[1], axis[0]) - np.pi, 2.0 * np.pi))
    u = np.asarray(clamp_position, float) - centre
    return float(np.mod(np.arctan2(u[1], u[0]) - np.pi, 2.0 * np.pi))


def _hinges_flat(hinges: list) -> tuple[list, list]:
    """(ints, reals) of a list of (axis, point, kind, params) in the builder's layout."""
    ints, reals = [len(hinges)], []
    for axis, point, kind, params in hinges:
        ints += [kind, len(params)]
        reals += list(np.asarray(axis, float)) + list(np.asarray(point, float)) + list(params)
    return ints, reals


def blade_hinges(deck: Deck, azimuth0: float) -> list:
    """The blade's flap, lead-lag and pitch hinges, outermost first (flap carries the others)."""
    b = deck.values["blade"]
    flap_point = np.asarray(b["flap_hinge"], float)
    lag_point = np.asarray(b["lag_hinge"], float) if deck.has("blade.lag_hinge") else flap_point
    pitch_point = np.asarray(b["pitch_hinge"], float) if deck.has("blade.pitch_hinge") else flap_point
    out = []
    for name, axis, point in (("flap", b["flap_axis"], flap_point), ("lag", b["lag_axis"], lag_point),
                              ("pitch", b["pitch_axis"], pitch_point)):
        if b["motion"] == "table":
            values = b[f"table_{name}_deg"]
            values = np.zeros(len(b["table_t"])) if values is None else np.asarray(values, float)
            out.append((axis, point, ANGLE_TABLE, list(b["table_t"]) + list(values * DEG)))
        else:
            extra = [0.0, 0.0, 0.0]
            if name == "lag":
                extra = [b["lag_extra_deg"] * DEG, 2.0 * np.pi * b["lag_extra_hz"], b["lag_extra_phase_deg"] * DEG]
            coefficients = list(np.asarray(b[f"{name}_deg"], float) * DEG)
            out.append((axis, point, ANGLE_FOURIER, [azimuth0] + extra + coefficients))
    return out


def support_motion(deck: Deck, rot: dict | None, which: str, clamp_position) -> tuple[list, list]:
    """The hinges that move support A ('clamp_a') or B (its deck group), as (ints, reals): the
    rotor's carrying round in the inertial frame, and the blade's hinges for a group whose
    ``moves_with`` is 'blade' (a group without that key does not move with the blade)."""
    hinges = []
    if rot is not None and not rot["hub"]:
        # Inertial frame: the support is carried round by the rotor about its axis.
        hinges.append(((0.0, 0.0, 1.0), rot["centre"], ANGLE_ROTOR, [0.0]))
    if lookup(which, "moves_with") is not None and deck[f"{which}.moves_with"] == "blade":
        azimuth0 = blade_azimuth0(deck, rot, clamp_position) if rot is not None else 0.0
        hinges += blade_hinges(deck, azimuth0)
    return _hinges_flat(hinges) if hinges else ([], [])
