"""A deck's chain as the independent reference model (tests/reference_maximal.py).

The deck is read for its numbers only (``pydriver.deckfile.Deck``: parsed values with the
schema's defaults filled in); every convention that turns those numbers into a model is
written here again from docs/model.md, without calling ``pydriver.assembly`` or
``pydriver.motions``, so that a wrong convention in either place shows as a disagreement:

* bodies: ``total_length`` cut into n equal bodies, radius = diameter / 2, ``total_mass``
  shared by length ("Per-body properties"); ``first_body = 'clamped'`` locks joint 1 at the
  start angles (gamma_1, beta_1) through Rz Ry whatever the joint ("Topology", "Cardan");
* springs: zy (c_gamma, c_beta) with the rest angles; xy (c_beta, c_beta); xyz (c_beta,
  c_beta, c_twist), dampers alike, rest 0 ("Cardan bending joint");
* support A at the deck origin with R_0 = Rz(gamma_A) Ry(beta_A) (&clamp_a); clamp B at
  ``position`` with R_B = Rz(gamma_B) Ry(beta_B) ("Topology");
* rotor about the deck z axis through ``&rotor centre`` (default -rotor_offset),
  counter-clockwise; run-up Omega0 -> Omega1 from t0 over T ("Rotor and hub frame");
  frame 'hub' is the reference's hub=True; frame 'inertial' carries both supports round
  the rotor axis, i.e. an outermost hinge about e_z through the centre turning by psi(t);
* blade: flap (outermost), lag, pitch hinges about their axes through their points (lag and
  pitch points default to the flap hinge), angles a0 + sum a_kc cos k psi_b + a_ks sin k psi_b
  in the blade azimuth psi_b = psi(t) + psi_b0, psi_b0 = azimuth of clamp B about the rotor
  axis measured from downstream (-x) in the sense of rotation, i.e. atan2(u_y, u_x) - pi
  ("Moving supports"), plus the lag's extra A sin(2 pi f t + phase);
* drag: V_inf = stream_velocity - forward_speed e_x in the inertial frame ("Aerodynamic drag").
"""

from __future__ import annotations

import numpy as np

import reference_maximal as ref

DEG = np.pi / 180.0
RPM = 2.0 * np.pi / 60.0


def _rz_ry(gamma_deg: float, beta_deg: float) -> np.ndarray:
    return ref.Rz(gamma_deg * DEG) @ ref.Ry(beta_deg * DEG)


def _per_joint(deck, key: str, n: int, default=0.0) -> np.ndarray:
    v = deck[key] if deck.has(key) else None
    if v is None:
        return np.full(n, float(default))
    return np.broadcast_to(np.asarray(v, float), (n,)).copy()


def _rotor(deck):
    """(RotorSpeed or None, centre, hub, body_couples) from &rotor / &loads rotor_rpm."""
    offset = np.asarray(deck["loads.rotor_offset"], float)
    centre = np.array([-offset[0], -offset[1], 0.0])
    if "rotor" not in deck.groups:
        rpm = deck["loads.rotor_rpm"] if deck.has("loads.rotor_rpm") else 0.0
        if not rpm:
            return None, centre, False, True
        return ref.RotorSpeed(omega=rpm * RPM), centre, True, True
    if deck.has("rotor.centre"):
        centre = np.asarray(deck["rotor.centre"], float)
    profile = deck["rotor.profile"]
    if profile == "constant":
        speed = ref.RotorSpeed(omega=deck["rotor.rpm"] * RPM)
    elif profile == "runup":
        speed = ref.RotorSpeed(omega=deck["rotor.rpm_start"] * RPM, omega_end=deck["rotor.rpm"] * RPM,
                               t_start=deck["rotor.runup_start"], duration=deck["rotor.runup_time"])
    else:
        raise NotImplementedError("table rotor profiles are not translated")
    return speed, centre, deck["rotor.frame"] == "hub", bool(deck["rotor.body_couples"])


def _blade_hinges(deck, azimuth0: float) -> list:
    if deck["blade.motion"] != "fourier":
        raise NotImplementedError("blade angle tables are not translated")
    flap_point = np.asarray(deck["blade.flap_hinge"], float)
    out = []
    for name in ("flap", "lag", "pitch"):
        point = (np.asarray(deck[f"blade.{name}_hinge"], float) if deck.has(f"blade.{name}_hinge")
                 else flap_point)
        coeffs = np.atleast_1d(np.asarray(deck[f"blade.{name}_deg"], float)) * DEG
        extra = {}
        if name == "lag":
            extra = dict(amplitude=deck["blade.lag_extra_deg"] * DEG,
                         frequency=2.0 * np.pi * deck["blade.lag_extra_hz"],
                         phase=deck["blade.lag_extra_phase_deg"] * DEG)
        angle = ref.AngleFunction("fourier", coefficients=tuple(coeffs), azimuth0=azimuth0, **extra)
        out.append(ref.Hinge(np.asarray(deck[f"blade.{name}_axis"], float), point, angle))
    return out


def reference_model(deck) -> ref.ChainModel:
    """The reference ChainModel of a validated deck (``pydriver.deckfile.Deck``).

    Parameters
    ----------
    deck : pydriver.deckfile.Deck
        Validated deck (only its numbers are used).

    Returns
    -------
    reference_maximal.ChainModel
    """
    if deck.has("cable.ei") or deck.has("chain.body_length") or not deck.has("chain.total_mass"):
        raise NotImplementedError("only total_length / total_mass / &springs decks are translated")
    n = deck.n_bodies
    joint = deck["chain.joint"]
    L = np.full(n, deck["chain.total_length"] / n)
    R = 0.5 * np.broadcast_to(np.asarray(deck["chain.diameter"], float), (n,))
    m = deck["chain.total_mass"] * L / L.sum()
    locked = np.zeros(n, bool)
    locked[0] = deck["chain.first_body"] == "clamped"
    locked_angles = np.column_stack([np.asarray(deck["shape.gamma_deg"], float),
                                     np.asarray(deck["shape.beta_deg"], float)]) * DEG
    cb, db = _per_joint(deck, "springs.c_beta", n), _per_joint(deck, "springs.d_beta", n)
    if joint == "zy":
        c = np.column_stack([_per_joint(deck, "springs.c_gamma", n), cb])
        d = np.column_stack([_per_joint(deck, "springs.d_gamma", n), db])
        rest = np.column_stack([_per_joint(deck, "springs.rest_gamma_deg", n),
                                _per_joint(deck, "springs.rest_beta_deg", n)]) * DEG
    elif joint == "xy":
        c, d, rest = np.column_stack([cb, cb]), np.column_stack([db, db]), np.zeros((n, 2))
    else:
        c = np.column_stack([cb, cb, _per_joint(deck, "springs.c_twist", n)])
        d = np.column_stack([db, db, _per_joint(deck, "springs.d_twist", n)])
        rest = np.zeros((n, 3))

    speed, centre, hub, body_couples = _rotor(deck)
    clamp = bool(deck["clamp_b.active"])
    if clamp and deck["clamp_b.from_start"]:
        raise NotImplementedError("clamp_b from_start is not translated")
    p_B = np.asarray(deck["clamp_b.position"], float) if clamp else None
    R_B = _rz_ry(deck["clamp_b.gamma_deg"], deck["clamp_b.beta_deg"]) if clamp else None

    def hinges(which: str) -> list:
        out = []
        if speed is not None and not hub:
            out.append(ref.Hinge(ref.E_Z, centre, ref.AngleFunction("rotor")))
        if deck[f"{which}.moves_with"] == "blade":
            if deck.has("blade.azimuth0_deg"):
                az0 = deck["blade.azimuth0_deg"] * DEG
            else:
                # docs/model.md: the blade's azimuth is that of its pitch axis in the rotor plane,
                # oriented away from the rotor centre.
                e = np.asarray(deck["blade.pitch_axis"], float)
                h = deck["blade.pitch_hinge"] if deck.has("blade.pitch_hinge") else deck["blade.flap_hinge"]
                radial = np.asarray(h, float) - centre
                e_plane = e - e[2] * ref.E_Z
                if e_plane @ radial < 0:
                    e_plane = -e_plane
                az0 = float(np.mod(np.arctan2(e_plane[1], e_plane[0]) + np.pi, 2.0 * np.pi))
            out += _blade_hinges(deck, az0)
        return out

    drag = None
    if "drag" in deck.groups:
        stream = np.asarray(deck["drag.stream_velocity"], float) - deck["drag.forward_speed"] * ref.E_X
        drag = ref.Drag(rho=deck["drag.air_density"],
                        cd=np.broadcast_to(np.asarray(deck["drag.cd"], float), (n,)), V_inf=stream)
    pulse = None
    if deck["loads.pulse_body"] > 0:
        pulse = ref.Pulse(deck["loads.pulse_body"], deck["loads.pulse_force"], deck["loads.pulse_start"],
                          deck["loads.pulse_end"])
    return ref.ChainModel(
        L=L, R=R, m=m, locked=locked, locked_angles=locked_angles, c=c, d=d, rest=rest,
        g_vec=np.asarray(deck["loads.gravity"], float), r_A=np.zeros(3), clamp_B=clamp, joint=joint,
        hub=hub and speed is not None, rotor=speed, rotor_centre=centre, body_couples=body_couples,
        base_rotation=_rz_ry(deck["clamp_a.gamma_deg"], deck["clamp_a.beta_deg"]),
        base_hinges=hinges("clamp_a"), clamp_position=p_B, clamp_rotation=R_B,
        clamp_hinges=hinges("clamp_b") if clamp else [], drag=drag, pulse=pulse,
        tip_force=np.asarray(deck["loads.tip_force"], float))
