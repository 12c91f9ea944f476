"""The rotor and the prescribed motions of the supports, from the deck to the core's parameter
blocks (src_fortran/motion/): speed profile, frame, and for each support the hinges that move
it (the rotor's own axis for a support carried round in the inertial frame; the blade's flap,
lead-lag and pitch hinges for a support on the blade).  The names the core reads are declared
here once (:data:`ROTOR_PROFILES`, :data:`HINGE`, :data:`ANGLES`); nothing is packed by position.

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

#: One degree [rad] and one revolution per minute [rad/s]: the decks' units of angles and rotor
#: speeds in SI, defined once (pydriver.assembly, components and the Campbell diagram import them).
DEG = np.pi / 180.0
RPM = 2.0 * np.pi / 60.0

#: The rotor's speed profiles and the parameters of each, by the names
#: ``src_fortran/motion/rotor.f90`` (rotor_from_block) reads: name -> unit.  Every rotor block
#: also has ``profile`` (the word), ``centre`` (3) [m], ``hub`` and ``body_couples`` (1/0; read
#: by ``model_builder.f90``, build_rotor).
ROTOR_PROFILES = {
    "constant": {"omega": "rad/s"},
    "runup": {"omega_start": "rad/s", "omega_end": "rad/s", "t_start": "s", "duration": "s"},
    "table": {"t": "s", "omega": "rad/s"},
}

#: One hinge of a prescribed motion (``src_fortran/motion/builder.f90``), under
#: ``motion.hinge<k>.``: name -> unit.  A motion also has ``motion.hinges``, their number.
HINGE = {"axis": "-", "point": "m", "angle": "word, a kind of ANGLES"}

#: The angle functions of a hinge and the parameters of each, by the names
#: ``src_fortran/motion/angle_function.f90`` (angle_from_block) reads: name -> unit.
ANGLES = {
    "constant": {"value": "rad"},
    "fourier": {"azimuth0": "rad", "extra_amplitude": "rad", "extra_frequency": "rad/s", "extra_phase": "rad",
                "coefficients": "rad: a_0, c_1, s_1, c_2, s_2, ..."},
    "table": {"t": "s", "theta": "rad"},
    "rotor": {"offset": "rad"},
}


def _declared(table: dict, kind: str, values: dict, what: str) -> dict:
    """``values`` as floats (arrays: float arrays), checked against the names ``table[kind]``
    declares, in their declared order."""
    if kind not in table or set(values) != set(table[kind]):
        raise ValueError(f"{what} {kind!r}: parameters {sorted(values)}, declared {sorted(table.get(kind, ()))}")
    return {name: float(values[name]) if np.ndim(values[name]) == 0 else np.asarray(values[name], float)
            for name in table[kind]}


def angle(kind: str, **values) -> dict:
    """A hinge's angle function of ``kind`` (:data:`ANGLES`) with its parameters by name."""
    return {"angle": kind, **_declared(ANGLES, kind, values, "angle")}


def motion_parameters(hinges: list, prefix: str = "motion.") -> dict:
    """The parameter block entries of a motion: ``hinges`` is a list of (axis, point, angle) with
    an :func:`angle` each, outermost first; no hinges: a support that does not move."""
    out = {prefix + "hinges": np.int32(len(hinges))}
    for k, (axis, point, ang) in enumerate(hinges, start=1):
        tag = f"{prefix}hinge{k}."
        out[tag + "axis"] = np.asarray(axis, float)
        out[tag + "point"] = np.asarray(point, float)
        out.update({tag + name: value for name, value in ang.items()})
    return out


def rotor_parameters(rot: dict) -> dict:
    """The rotor's parameter block (:func:`rotor`'s description) for the core."""
    return {"profile": rot["profile"], "centre": np.asarray(rot["centre"], float), "hub": np.int32(rot["hub"]),
            "body_couples": np.int32(rot["body_couples"]), **rot["speed"]}


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
        speed = _declared(ROTOR_PROFILES, "constant", {"omega": rpm * RPM}, "rotor profile")
        return {"profile": "constant", "centre": legacy_centre, "speed": speed, "hub": True,
                "body_couples": True, "omega_max": rpm * RPM}
    r = deck.values["rotor"]
    centre = np.asarray(r["centre"], float) if deck.has("rotor.centre") else legacy_centre
    if r["profile"] == "constant":
        speed = {"omega": r["rpm"] * RPM}
        omega_max = speed["omega"]
    elif r["profile"] == "runup":
        speed = {"omega_start": r["rpm_start"] * RPM, "omega_end": r["rpm"] * RPM, "t_start": r["runup_start"],
                 "duration": r["runup_time"]}
        omega_max = max(speed["omega_start"], speed["omega_end"])
    else:
        speed = {"t": list(r["table_t"]), "omega": [x * RPM for x in r["table_rpm"]]}
        omega_max = max(r["table_rpm"]) * RPM
    speed = _declared(ROTOR_PROFILES, r["profile"], speed, "rotor profile")
    return {"profile": r["profile"], "centre": centre, "speed": speed, "hub": r["frame"] == "hub",
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
            out.append((axis, point, angle("table", t=b["table_t"], theta=values * DEG)))
        else:
            extra = [0.0, 0.0, 0.0]
            if name == "lag":
                extra = [b["lag_extra_deg"] * DEG, 2.0 * np.pi * b["lag_extra_hz"], b["lag_extra_phase_deg"] * DEG]
            out.append((axis, point, angle("fourier", azimuth0=azimuth0, extra_amplitude=extra[0],
                                           extra_frequency=extra[1], extra_phase=extra[2],
                                           coefficients=np.asarray(b[f"{name}_deg"], float) * DEG)))
    return out


def support_motion(deck: Deck, rot: dict | None, which: str, clamp_position) -> dict:
    """The hinges that move support A ('clamp_a') or B (its deck group), as the parameter block
    entries of :func:`motion_parameters`: the rotor's carrying round in the inertial frame, and
    the blade's hinges for a group whose ``moves_with`` is 'blade' (a group without that key
    does not move with the blade)."""
    hinges = []
    if rot is not None and not rot["hub"]:
        # Inertial frame: the support is carried round by the rotor about its axis.
        hinges.append(((0.0, 0.0, 1.0), rot["centre"], angle("rotor", offset=0.0)))
    if lookup(which, "moves_with") is not None and deck[f"{which}.moves_with"] == "blade":
        azimuth0 = blade_azimuth0(deck, rot, clamp_position) if rot is not None else 0.0
        hinges += blade_hinges(deck, azimuth0)
    return motion_parameters(hinges)
