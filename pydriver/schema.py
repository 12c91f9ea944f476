"""The deck schema: every namelist key of a rotorcable deck in one table.

Each :class:`Key` has its group, type, shape, unit, allowed range or choices, default and a
one-line doc.  This one table drives

* validation and the error messages (:mod:`pydriver.deckfile`: deck, group, key, reason),
* ``docs/deck_reference.md`` and ``rotorcable keys`` (:func:`reference_document`; the file is
  checked in CI to be current),
* the sweep's key handling (which keys are arrays, how a swept value is parsed).

Shapes: ``scalar``; ``vec3`` (exactly 3 values); ``body`` and ``joint`` (one value per body or
per joint, n = ``&chain n_bodies``; joint j connects body j-1, or the base for j = 1, to body j;
a single value is used for all of them); ``list`` (any number of values, a table or series).
Cross-key rules (exactly one of ``density``/``total_mass``/..., a tip force needs a free end, ...)
are in :mod:`pydriver.deck_rules`.
"""

from __future__ import annotations

import difflib
import math
from dataclasses import dataclass

from pydriver.analyses.registry import ANALYSES
from pydriver.design_measures import OBJECTIVES
from pydriver.mean_stress import METHODS as MEAN_STRESS_METHODS

INF = math.inf

#: The IDA linear solvers of the core, written here only: the core takes the deck's word
#: (``src_fortran/dae_integrator.f90``, settings_from_block) and ``&solver linear_solver`` is one
#: of them or ``'auto'`` (resolved by :func:`pydriver.model.resolve_linear_solver`).
LINEAR_SOLVERS = ("chain", "block", "dense")
#: The most regimes a usage spectrum may list (&spectrum regimes): each is a flight run at every
#: refinement level; a spectrum of 20 regimes is already a fine one.
MAX_REGIMES = 200
#: The rotor's speed profiles a deck may choose; pydriver.motions.ROTOR_PROFILES gives each its
#: parameters for the core, and tests/test_components.py holds the two to the same names.
ROTOR_PROFILE_NAMES = ("constant", "runup", "table")


@dataclass(frozen=True)
class Key:
    """One deck key."""

    group: str
    name: str
    type: str                     #: 'real' | 'int' | 'bool' | 'str'
    shape: str = "scalar"         #: 'scalar' | 'vec3' | 'body' | 'joint' | 'list'
    unit: str = "-"
    default: object = None        #: None = no default (required where a rule needs it)
    doc: str = ""
    low: float = -INF             #: allowed range [low, high]; open ends with low_open/high_open
    high: float = INF
    low_open: bool = False
    high_open: bool = False
    choices: tuple = ()           #: allowed values of a 'str' key
    broadcast: bool = True        #: a lone value on a 'body'/'joint' key sets every element
    tiny: float = 0.0             #: nonzero magnitudes below this are refused (0 = none, or >= tiny)
    note: str = ""                #: said with a range error: why the range is what it is
    #: the static and modal results are smooth functions of it, so &design parameters may name
    #: it (pydriver/design.py); keys that only start a run (shape, solver) or select a branch are not
    differentiable: bool = False
    #: the allowed values in words, for a key whose values a rule checks rather than a range
    #: (the names of &design parameters: pydriver/design.py)
    allowed: str = ""

    @property
    def is_array(self) -> bool:
        return self.shape != "scalar"

    def range_text(self) -> str:
        """The allowed values as a short text (for errors and the reference)."""
        if self.allowed:
            return self.allowed
        if self.choices:
            return " | ".join(f"'{c}'" for c in self.choices)
        if self.type not in ("real", "int"):
            return ""
        lo, hi = self.low, self.high
        if self.tiny:
            return f"0 or [{_num(self.tiny)}, {_num(hi)}]"
        if lo == -INF and hi == INF:
            return "finite"
        if hi == INF:
            return f"{'>' if self.low_open else '>='} {_num(lo)}"
        if lo == -INF:
            return f"{'<' if self.high_open else '<='} {_num(hi)}"
        return f"{'(' if self.low_open else '['}{_num(lo)}, {_num(hi)}{')' if self.high_open else ']'}"


def _num(x) -> str:
    return f"{x:g}"


POS = dict(low=0.0, low_open=True)        # > 0
#: Why start and rest angles stay within one turn (issue 20: beta = 372 deg, the shape of
#: 12 deg, gave 161.6 Hz and 19 kN against 26.25 Hz and 143 N).
ANGLE_NOTE = ("the joint springs act on the angle itself, so an angle one turn away is the same shape with "
              "a spring wound by a full turn; give the angle within -180 ... 180 deg")
NONNEG = dict(low=0.0)                    # >= 0


def _keys() -> list[Key]:
    k = []
    add = k.append
    # &case --------------------------------------------------------------------------------
    add(Key("case", "name", "str", default="", doc="case name (summary, tables); default: the deck's file stem"))
    add(Key("case", "analysis", "str", choices=tuple(ANALYSES),
            doc="static equilibrium, dynamic run, modal analysis about the equilibrium, forward flight "
                "to a periodic steady state, Campbell diagram over rotor speed, or design optimisation "
                "(&design; docs/model.md, \"Design optimisation\")"))
    add(Key("case", "description", "str", default="", doc="free text"))
    add(Key("case", "start", "str", default="shape", choices=("shape", "equilibrium"),
            doc="dynamic start: the deck's shape (made consistent) or at rest in the static equilibrium"))
    # &chain -------------------------------------------------------------------------------
    add(Key("chain", "n_bodies", "int", low=1, high=2000, doc="number of rigid bodies"))
    add(Key("chain", "total_length", "real", unit="m", low=1.0e-6, high=1.0e3, doc="cable length, cut into equal bodies", differentiable=True))
    add(Key("chain", "body_length", "real", "body", "m", low=1.0e-6, high=1.0e3,
            doc="length of each body (instead of total_length)", differentiable=True))
    add(Key("chain", "diameter", "real", "body", "m", low=1.0e-6, high=10.0, doc="cable diameter (per body or one value)", differentiable=True))
    add(Key("chain", "density", "real", unit="kg/m^3", low=1.0, high=1.0e5, doc="material density (mass = rho pi d^2/4 L)", differentiable=True))
    add(Key("chain", "total_mass", "real", unit="kg", low=1.0e-9, high=1.0e6, doc="cable mass, shared by length", differentiable=True))
    add(Key("chain", "body_mass", "real", "body", "kg", low=1.0e-9, high=1.0e6, doc="mass of each body (connectors, sleeves)", differentiable=True))
    add(Key("chain", "first_body", "str", default="clamped", choices=("clamped", "pivot"),
            doc="clamped: joint 1 locked at the start angles (thesis); pivot: joint 1 free at A"))
    add(Key("chain", "joint", "str", default="zy", choices=("zy", "xy", "xyz"),
            doc="joint parametrisation: thesis gamma/beta (zy), Cardan bending (xy), Cardan bending + twist (xyz)"))
    # &shape -------------------------------------------------------------------------------
    add(Key("shape", "gamma_deg", "real", "body", "deg", low=-180.0, high=180.0, broadcast=False, note=ANGLE_NOTE, doc="start shape: thesis angle gamma of each body (with resample: of each joint of an m-body chain)"))
    add(Key("shape", "beta_deg", "real", "body", "deg", low=-180.0, high=180.0, broadcast=False, note=ANGLE_NOTE, doc="start shape: thesis angle beta of each body (with resample: of each joint of an m-body chain)"))
    add(Key("shape", "resample", "bool", default=False,
            doc="gamma_deg and beta_deg give the start shape as a chain of m bodies (m = the number of values, "
                "1 ... n_bodies), placed on the n bodies by arc length: a deck's shape for any n "
                "(docs/model.md, \"Start shape for any n\")"))
    add(Key("shape", "gamma_rate_deg", "real", "body", "deg/s", default=0.0, low=-1.0e6, high=1.0e6, broadcast=False, doc="start rate of gamma (zy only)"))
    add(Key("shape", "beta_rate_deg", "real", "body", "deg/s", default=0.0, low=-1.0e6, high=1.0e6, broadcast=False, doc="start rate of beta (zy only)"))
    # &springs -----------------------------------------------------------------------------
    add(Key("springs", "c_gamma", "real", "joint", "Nm/rad", 0.0, "torsion spring on gamma (zy)", **NONNEG, high=1.0e9, differentiable=True))
    add(Key("springs", "c_beta", "real", "joint", "Nm/rad", 0.0, "bending spring (beta; both Cardan angles)", **NONNEG, high=1.0e9, differentiable=True))
    add(Key("springs", "d_gamma", "real", "joint", "Nms/rad", 0.0, "damper on gamma (zy)", **NONNEG, high=1.0e9, differentiable=True))
    add(Key("springs", "d_beta", "real", "joint", "Nms/rad", 0.0, "bending damper", **NONNEG, high=1.0e9, differentiable=True))
    add(Key("springs", "c_twist", "real", "joint", "Nm/rad", None, "twist spring (xyz, required there)", **NONNEG, high=1.0e9, differentiable=True))
    add(Key("springs", "d_twist", "real", "joint", "Nms/rad", 0.0, "twist damper (xyz)", **NONNEG, high=1.0e9, differentiable=True))
    add(Key("springs", "rest_gamma_deg", "real", "joint", "deg", 0.0, "spring rest angle of gamma (zy)", low=-180.0, high=180.0, broadcast=False, note=ANGLE_NOTE, differentiable=True))
    add(Key("springs", "rest_beta_deg", "real", "joint", "deg", 0.0, "spring rest angle of beta (zy)", low=-180.0, high=180.0, broadcast=False, note=ANGLE_NOTE, differentiable=True))
    # &cable: physical parameters ----------------------------------------------------------
    add(Key("cable", "ei", "real", unit="N m^2", **POS, high=1.0e9,
            doc="bending stiffness EI; joint springs c = EI/l, 2 EI/l at a joint on a clamp", differentiable=True))
    add(Key("cable", "gj", "real", unit="N m^2", **POS, high=1.0e9, doc="torsional stiffness GJ (joint = 'xyz')", differentiable=True))
    add(Key("cable", "mass_per_length", "real", unit="kg/m", low=1.0e-9, high=1.0e4, doc="mass per length (instead of &chain masses)", differentiable=True))
    add(Key("cable", "spring_measure", "str", default="rotation_vector", choices=("rotation_vector", "joint_angles"),
            doc="joint = 'xyz': springs on the joint's rotation vector log R (converges at second order "
                "in 1/n) or on its Cardan angles (first order in three dimensions)"))
    add(Key("cable", "damping_time", "real", unit="s", default=0.0, **NONNEG, high=1.0e3,
            doc="structural damping, stiffness-proportional: d = damping_time * c at every joint", differentiable=True))
    # &clamp_a / &clamp_b ------------------------------------------------------------------
    add(Key("clamp_a", "gamma_deg", "real", unit="deg", default=0.0,
            low=-360.0, high=360.0, doc="orientation of support A's frame (base of joint 1): thesis gamma", differentiable=True))
    add(Key("clamp_a", "beta_deg", "real", unit="deg", default=0.0,
            low=-360.0, high=360.0, doc="orientation of support A's frame: thesis beta (90 = the clamp's axis along +x)", differentiable=True))
    add(Key("clamp_a", "moves_with", "str", default="hub", choices=("hub", "blade"),
            doc="support A is fixed on the hub, or moves with the blade (&blade)"))
    add(Key("clamp_b", "active", "bool", default=False, doc="clamp B holds the last body (6 constraint rows)"))
    add(Key("clamp_b", "from_start", "bool", default=False, doc="take B's pose from the start shape"))
    add(Key("clamp_b", "position", "real", "vec3", "m", low=-1.0e3, high=1.0e3, doc="clamp point p_B (end of the last body)", differentiable=True))
    add(Key("clamp_b", "gamma_deg", "real", unit="deg", low=-360.0, high=360.0, doc="orientation of the last body, thesis gamma", differentiable=True))
    add(Key("clamp_b", "beta_deg", "real", unit="deg", low=-360.0, high=360.0, doc="orientation of the last body, thesis beta", differentiable=True))
    add(Key("clamp_b", "moves_with", "str", default="hub", choices=("hub", "blade"),
            doc="clamp B is fixed on the hub, or moves with the blade (&blade)"))
    add(Key("ball_b", "active", "bool", default=False,
            doc="ball B holds the tip at a point, the last body free to turn (3 constraint rows; instead of clamp B)"))
    add(Key("ball_b", "position", "real", "vec3", "m", low=-1.0e3, high=1.0e3, doc="ball point p_B (the chain's tip)"))
    # &loads -------------------------------------------------------------------------------
    add(Key("loads", "gravity", "real", "vec3", "m/s^2", (0.0, 0.0, -9.81), "gravitational acceleration", low=-1.0e3, high=1.0e3, differentiable=True))
    add(Key("loads", "rotor_rpm", "real", unit="rpm", **NONNEG, high=1.0e5, tiny=1.0e-3,
            doc="rotor speed about the deck's z axis (same as &rotor rpm; hub-frame run)", differentiable=True))
    add(Key("loads", "rotor_offset", "real", "vec3", "m", (0.0, 0.0, 0.0), low=-1.0e3, high=1.0e3,
            doc="deck origin (clamp A) relative to the rotor centre (x, y used)", differentiable=True))
    add(Key("loads", "pulse_body", "int", default=0, low=0, high=2000, doc="body loaded by a force pulse (0 = none)"))
    add(Key("loads", "pulse_force", "real", "vec3", "N", (0.0, 0.0, 0.0), "pulse force at that body's CM", low=-1.0e9, high=1.0e9))
    add(Key("loads", "pulse_start", "real", unit="s", default=0.0, **NONNEG, high=1.0e7, doc="pulse start time"))
    add(Key("loads", "pulse_end", "real", unit="s", default=0.0, **NONNEG, high=1.0e7, doc="pulse end time"))
    add(Key("loads", "tip_force", "real", "vec3", "N", (0.0, 0.0, 0.0), "constant force at a free tip", low=-1.0e9, high=1.0e9, differentiable=True))
    # &rotor -------------------------------------------------------------------------------
    add(Key("rotor", "rpm", "real", unit="rpm", **NONNEG, high=1.0e5, tiny=1.0e-3,
            doc="rotor speed (constant profile), or the speed the run-up ends at", differentiable=True))
    add(Key("rotor", "profile", "str", default="constant", choices=ROTOR_PROFILE_NAMES,
            doc="speed profile: constant, a smooth run-up from rpm_start to rpm, or a table"))
    add(Key("rotor", "rpm_start", "real", unit="rpm", default=0.0, **NONNEG, high=1.0e5, doc="run-up: speed before it"))
    add(Key("rotor", "runup_start", "real", unit="s", default=0.0, **NONNEG, high=1.0e7, doc="run-up: start time"))
    add(Key("rotor", "runup_time", "real", unit="s", low=1.0e-6, high=1.0e7,
            doc="run-up: duration (Omega-dot = 0 at both ends: s(tau) = tau - sin(2 pi tau)/(2 pi))"))
    add(Key("rotor", "table_t", "real", "list", "s", **NONNEG, high=1.0e7, doc="speed table: times (from 0, increasing)"))
    add(Key("rotor", "table_rpm", "real", "list", "rpm", **NONNEG, high=1.0e5, doc="speed table: speeds (cubic spline, held after)"))
    add(Key("rotor", "centre", "real", "vec3", "m",
            low=-1.0e3, high=1.0e3, doc="rotor centre in the deck frame (axis = deck z); default: -rotor_offset of &loads", differentiable=True))
    add(Key("rotor", "frame", "str", default="hub", choices=("hub", "inertial"),
            doc="equations in the hub frame turning with the rotor, or in the inertial frame with the "
                "supports carried round"))
    add(Key("rotor", "body_couples", "bool", default=True,
            doc="the bodies' rotational inertia takes part in the frame terms (.false.: the thesis's "
                "point-mass centrifugal field)"))
    # &blade: the blade-side support's motion -------------------------------------------------
    add(Key("blade", "flap_hinge", "real", "vec3", "m", low=-1.0e3, high=1.0e3, doc="a point on the flap hinge axis (deck frame, t = 0)"))
    add(Key("blade", "flap_axis", "real", "vec3", default=(1.0, 0.0, 0.0), low=-1.0e3, high=1.0e3, doc="flap hinge axis (positive flap up)"))
    add(Key("blade", "lag_hinge", "real", "vec3", "m", low=-1.0e3, high=1.0e3, doc="a point on the lead-lag hinge axis (default: the flap hinge)"))
    add(Key("blade", "lag_axis", "real", "vec3", default=(0.0, 0.0, 1.0), low=-1.0e3, high=1.0e3, doc="lead-lag hinge axis"))
    add(Key("blade", "pitch_hinge", "real", "vec3", "m", low=-1.0e3, high=1.0e3, doc="a point on the pitch (feathering) axis (default: the flap hinge)"))
    add(Key("blade", "pitch_axis", "real", "vec3", default=(0.0, 1.0, 0.0), low=-1.0e3, high=1.0e3, doc="pitch axis (along the blade)"))
    add(Key("blade", "motion", "str", default="fourier", choices=("fourier", "table"),
            doc="hinge angles as Fourier series in the blade azimuth, or time tables"))
    add(Key("blade", "flap_deg", "real", "list", "deg", default=0.0,
            low=-90.0, high=90.0, doc="flap: a0, a1c, a1s, a2c, a2s, ... (coning and harmonics in the blade azimuth)"))
    add(Key("blade", "lag_deg", "real", "list", "deg", default=0.0, low=-90.0, high=90.0, doc="lead-lag: a0, a1c, a1s, ..."))
    add(Key("blade", "pitch_deg", "real", "list", "deg", default=0.0, low=-90.0, high=90.0, doc="pitch: a0, a1c, a1s, ..."))
    add(Key("blade", "lag_extra_deg", "real", unit="deg", default=0.0,
            low=-90.0, high=90.0, doc="an extra lead-lag oscillation at its own frequency: amplitude"))
    add(Key("blade", "lag_extra_hz", "real", unit="Hz", default=0.0, **NONNEG, high=1.0e4, doc="its frequency"))
    add(Key("blade", "lag_extra_phase_deg", "real", unit="deg", default=0.0, low=-360.0, high=360.0, doc="its phase"))
    add(Key("blade", "table_t", "real", "list", "s", **NONNEG, high=1.0e7, doc="angle tables: times"))
    add(Key("blade", "table_flap_deg", "real", "list", "deg", low=-90.0, high=90.0, doc="flap angle at the table times"))
    add(Key("blade", "table_lag_deg", "real", "list", "deg", low=-90.0, high=90.0, doc="lead-lag angle at the table times"))
    add(Key("blade", "table_pitch_deg", "real", "list", "deg", low=-90.0, high=90.0, doc="pitch angle at the table times"))
    add(Key("blade", "azimuth0_deg", "real", unit="deg",
            low=-360.0, high=360.0, doc="blade azimuth at t = 0 (0 = downstream, in the sense of rotation); default: that of the blade's "
                "pitch axis in the rotor plane, pointing away from the rotor centre"))
    # &campbell ----------------------------------------------------------------------------
    add(Key("campbell", "rpm_max", "real", unit="rpm", **POS,
            doc="highest rotor speed of the diagram; default: the deck's rotor speed"))
    add(Key("campbell", "n_speeds", "int", default=26, low=2, high=2000,
            doc="rotor speeds, evenly from 0 to rpm_max; at most 2000 (a step of 0.05 % of rpm_max, finer than "
                "a rotor holds its speed; each speed costs an equilibrium and an eigen-solution); the run warns "
                "and asks for more where the MAC of a mode between neighbouring speeds is below 0.9"))
    add(Key("campbell", "operating_rpm", "real", "list", "rpm", **NONNEG,
            doc="operating range (min, max) in which crossings are reported (given high to low: sorted, with a "
                "warning); one value v: one operating speed, crossings within v +- 5 % (a governed rotor holds "
                "its speed to a few percent); more than two values, or a speed above rpm_max (the diagram has "
                "no data there), are an error; default 0 ... rpm_max"))
    add(Key("campbell", "n_modes", "int", default=6, low=1, high=6000,
            doc="modes tracked across speeds (lowest first; zero-stiffness modes at 0 Hz); at most 6000, three "
                "coordinates per body at the 2000-body limit; the run checks the model's own number, its "
                "coordinates minus its constraints"))
    add(Key("campbell", "harmonics", "int", default=8, low=1, high=64,
            doc="rotor harmonics drawn and checked: 1/rev ... N/rev; at most 64 (rotor excitation comes at "
                "multiples of the blade count, at most 8 blades, and fades with the order; 64 lines already "
                "fill the diagram)"))
    add(Key("campbell", "lag_band_hz", "real", "list", "Hz", default=(1.1, 1.4), **NONNEG,
            doc="lead-lag mode band drawn in the diagram, two values (low, high; given high to low: sorted, "
                "with a warning) (thesis chapter 6: 1/4 to 1/3 of 4.33 Hz)"))
    # &resonance ---------------------------------------------------------------------------
    add(Key("resonance", "margin_percent", "real", unit="%", default=10.0, low=0.0, high=100.0,
            doc="required separation of every mode from every k/rev harmonic, in percent of the harmonic "
                "(10: a common rotorcraft rule of thumb; modal, Campbell and flight runs flag a mode closer)"))
    add(Key("resonance", "harmonics", "int", default=8, low=1, high=64,
            doc="the highest harmonic checked: 1/rev ... harmonics/rev (or its blade-passage multiples, "
                "excitation); modes above (harmonics + 1)/rev are not excited and not listed (64: beyond any "
                "rotor's excitation)"))
    add(Key("resonance", "excitation", "str", default="every", choices=("every", "blade_passage"),
            doc="which harmonics excite the cable: 'every' k/rev, k = 1 ... harmonics (a cable on the blade sees "
                "the blade's own motion, every harmonic of it), or 'blade_passage', the multiples of blades up to "
                "harmonics (a part in the fixed frame: the blades' other harmonics cancel at the hub); read by the "
                "resonance margins, the Campbell crossings and the design optimiser's frequency margin "
                "(docs/model.md, \"Resonance margins\")"))
    add(Key("resonance", "blades", "int", default=4, low=1, high=8,
            doc="the rotor's blade count, with excitation = 'blade_passage' (4: the UH-60)",
            note="helicopter rotors have 2 to 8 blades (the Mi-26: 8); 1 is a counterweighted single blade"))
    add(Key("resonance", "operating_rpm", "real", "list", "rpm", low=0.0, high=1.0e5,
            doc="operating speed(s) of the margins; default: the deck's rotor speed (flight, hub-frame "
                "modal) or &campbell operating_rpm"))
    # &drag --------------------------------------------------------------------------------
    add(Key("drag", "air_density", "real", unit="kg/m^3", default=1.225, low=1.0e-6, high=2.0e3,
            doc="air density (ISA sea level by default)", differentiable=True))
    add(Key("drag", "cd", "real", "body", default=1.2, **NONNEG, high=100.0,
            doc="cross-flow drag coefficient of the cylinder (1.2: subcritical Reynolds number)", differentiable=True))
    add(Key("drag", "stream_velocity", "real", "vec3", "m/s", (0.0, 0.0, 0.0), low=-1.0e3, high=1.0e3,
            doc="free-stream air velocity in the inertial frame", differentiable=True))
    add(Key("drag", "forward_speed", "real", unit="m/s", default=0.0, **NONNEG, high=1.0e3,
            doc="forward flight speed along the inertial +x axis (adds -V e_x to the stream)", differentiable=True))
    # &anchor: a spring from a joint point to a fixed point -------------------------------------
    add(Key("anchor", "joint", "int", low=1, high=2001,
            doc="joint point P_j the spring holds (1 = at support A, n_bodies + 1 = the tip)"))
    add(Key("anchor", "point", "real", "vec3", "m", low=-1.0e3, high=1.0e3,
            doc="anchor point, fixed in the frame of the equations (the hub frame of a rotor run)"))
    add(Key("anchor", "stiffness", "real", unit="N/m", **POS, high=1.0e9,
            doc="spring constant k: force -k (P_j - point), zero rest length"))
    # &fatigue ------------------------------------------------------------------------------
    add(Key("fatigue", "sn_quantity", "str", default="strain", choices=("strain", "bending"),
            doc="what the S-N curve is written on: jacket surface strain [-] or bending moment [Nm]"))
    add(Key("fatigue", "sn_exponent", "real", low=1.0, high=50.0,
            doc="Basquin exponent m of N = N_ref (S_a/S_ref)^-m; real materials: 3 (welded steel) to about 20 "
                "(smooth steels, polymer jackets)",
            note="Basquin exponents of real materials lie between 3 (welded steel joints) and about 20 (smooth "
                 "steels, thermoplastic elastomers); 1 ... 50 covers them with margin, and with the amplitude "
                 "bounds keeps the damage within the float range"))
    add(Key("fatigue", "sn_reference_amplitude", "real", unit="-, Nm", low=1.0e-6, high=1.0e6,
            doc="amplitude S_ref at which the S-N curve passes N_ref (unit of sn_quantity); 1e-6 ... 1e6 spans "
                "jacket strains and cable bending moments; loads over 1e6 S_ref (a unit mistake) give damage "
                "beyond the float range at m = 50 and are refused",
            note="jacket strain amplitudes (1e-4 ... 1e-1) and cable bending moments (1e-3 ... 1e3 Nm) lie well "
                 "inside it; an S_ref a million times off the loads is a unit mistake, and raised to m = 50 it "
                 "puts the damage beyond the float range (1e308)"))
    add(Key("fatigue", "sn_reference_cycles", "real", low=0.5, high=1.0e12,
            doc="cycles to failure N_ref at S_ref; 0.5 (one reversal, where Basquin's coefficient is given) ... "
                "1e12 (beyond the gigacycle range)",
            note="Basquin's fatigue strength coefficient is defined at one reversal (N = 0.5 cycles), and test "
                 "data end in the gigacycle range (1e9 ... 1e10); the bound also keeps log N_ref, which the "
                 "damage is computed with, far from the float limits"))
    add(Key("fatigue", "sn_endurance_amplitude", "real", unit="-, Nm", default=0.0, **NONNEG,
            doc="amplitudes at or below this do no damage (0: no cut-off)"))
    add(Key("fatigue", "circumferential_points", "int", default=24, low=4, high=360,
            doc="points around the jacket at which each joint's cycles are counted (critical plane); at 360 "
                "(1 deg apart) the worst point's amplitude is within cos 0.5 deg = 0.99996 of the true worst",
            note="360 points (1 deg apart) put the counted worst point within 0.5 deg of the true worst direction "
                 "(amplitude within 4e-5, damage within 0.2 % at m = 50); more change nothing measurable and "
                 "cost rainflow passes in proportion"))
    add(Key("fatigue", "hotspots", "int", default=5, low=1, high=2000,
            doc="joints listed in the hotspot table (at most every joint: 2000, the largest n_bodies)"))
    add(Key("fatigue", "sn_file", "str",
            doc="the S-N curve as a table instead of Basquin's parameters: a CSV file (path relative to the deck) "
                "with columns amplitude (unit of sn_quantity) and cycles (to failure), at least 2 rows, the amplitude "
                "falling as the cycles rise; log-log interpolated, the end segments extended, sn_endurance_amplitude "
                "the cut-off; sn_exponent (optional) is then the DELs' exponent, default the table's log-log slope "
                "(docs/model.md, \"Fatigue\")"))
    add(Key("fatigue", "mean_stress", "str", default="none", choices=MEAN_STRESS_METHODS,
            doc="mean-stress correction of every counted cycle: none; Goodman S_a/(1 - S_m/S_u); Gerber "
                "S_a/(1 - (S_m/S_u)^2) (both: a compressive mean taken as 0); Walker S_max^(1-gamma) S_a^gamma "
                "(Dowling, Mechanical Behavior of Materials, 4th ed., ch. 9-10; docs/model.md, \"Fatigue\")"))
    add(Key("fatigue", "ultimate", "real", unit="-, Nm", low=1.0e-6, high=1.0e6,
            doc="the ultimate value S_u of the counted quantity for Goodman and Gerber: the jacket's strain at break "
                "(sn_quantity = 'strain') or the bending moment that breaks the cable (Nm)",
            note="jacket strains at break (1e-3 ... 10) and breaking moments (1e-3 ... 1e3 Nm) lie well inside it"))
    add(Key("fatigue", "walker_gamma", "real", default=0.5, low=0.0, high=1.0,
            doc="Walker's exponent gamma (0.5: Smith-Watson-Topper; Dowling reports 0.4 ... 0.8 for steels and "
                "aluminium alloys); 1 ignores the mean",
            note="gamma = 1 is no mean-stress effect and gamma = 0 the maximum alone: the relation is defined "
                 "between them"))
    # &limits ------------------------------------------------------------------------------
    add(Key("limits", "jacket_strain", "real", unit="-", low=1.0e-6, high=1.0,
            doc="largest allowed jacket strain (0.01 = 1 %): a run whose largest |strain| exceeds it is flagged "
                "in the summary and report.html; default: none (the value is shown as not judged)",
            note="a strain limit below 1e-6 is below any strain gauge's resolution, and above 1 (100 %) no "
                 "cable material holds together"))
    add(Key("limits", "fatigue_life_hours", "real", unit="h", low=1.0e-3, high=1.0e9,
            doc="required fatigue life in flight hours: a hotspot with a shorter life (&fatigue) is flagged in "
                "the summary and report.html; default: none (the life is shown as not judged)",
            note="1e-3 h is 3.6 s, shorter than one recorded run; 1e9 h is 100 000 years"))
    # &design ------------------------------------------------------------------------------
    add(Key("design", "parameters", "str", "list",
            doc="deck keys to differentiate the results by: 'group.key' (a scalar, or every element of a "
                "per-body or per-joint key moved together) or 'group.key(i)' (element i); any key this "
                "reference marks differentiable, at most 64; static runs write d(reactions and joint loads)/"
                "d(parameter), modal runs d(frequency)/d(parameter), flight and dynamic runs d(reaction extremes, "
                "peak and amplitude joint loads, damage per hour and DELs)/d(parameter) of the periodic "
                "revolution (at fixed blade azimuth) or the whole record to sensitivities.csv (docs/model.md, "
                "\"Design sensitivities\")",
            allowed="1 ... 64 names of differentiable keys",
            note="a name is a key of this reference marked differentiable, as group.key or group.key(i)"))
    # The optimiser (analysis = 'design'; pydriver/design_problem.py, docs/model.md "Design optimisation").
    add(Key("design", "objective", "str", choices=tuple(OBJECTIVES),
            doc="analysis = 'design': what is minimised (the registry pydriver/design_measures.py): "
                + "; ".join(f"'{m.name}' [{m.unit}], {m.doc}" for m in OBJECTIVES.values())))
    add(Key("design", "lower", "real", "list", "*", low=-1.0e9, high=1.0e9,
            doc="analysis = 'design': lower bound of each parameter, in the order of parameters and in its unit "
                "(degrees for an angle); the deck's value must lie within the bounds"))
    add(Key("design", "upper", "real", "list", "*", low=-1.0e9, high=1.0e9,
            doc="analysis = 'design': upper bound of each parameter (above its lower bound)"))
    add(Key("design", "frequency_margin_percent", "real", unit="%", low=0.0, high=100.0, low_open=True,
            high_open=True,
            doc="analysis = 'design': constraint: every mode whose damped frequency at the start lies below "
                "(&resonance harmonics + 1)/rev keeps this margin from every excited k/rev (&resonance harmonics, "
                "excitation) at the operating speed (&resonance operating_rpm or the deck's rotor speed), within "
                "the gap between harmonics where it starts; the margin of the resonance check; default: none"))
    add(Key("design", "starts", "int", default=3, low=1, high=3,
            doc="analysis = 'design': the optimiser's starts, each a local optimisation: 1, the deck's values; 2, "
                "also every parameter at its lower bound; 3, also every parameter at its upper bound.  The best "
                "converged start that holds the frequency margin wins; every start is in the summary (a gradient "
                "method finds a local optimum: with a frequency margin each start stays in the gap between "
                "harmonics where it begins)",
            note="the starts are the deck's values and the box's two corners; more starts are more deck runs"))
    add(Key("design", "frequency_levels", "int", default=1, low=1, high=3,
            doc="analysis = 'design' with frequency_margin_percent: the refinement levels of the frequencies the "
                "margin judges: 1, those at the deck's n; 2 or 3, the Richardson value over n, 2n (, 4n) (the "
                "cable's &cable parameters), as each mode's shift f(converged) - f(n) taken at each start and again "
                "at its optimum, from where the optimiser runs once more",
            note="three levels give the extrapolation an observed order; a fourth costs a modal run at 8n"))
    add(Key("design", "method", "str", default="slsqp", choices=("slsqp", "trust-constr"),
            doc="analysis = 'design': scipy.optimize.minimize method (SLSQP, Kraft 1988; or trust-constr)"))
    add(Key("design", "max_iterations", "int", default=100, low=1, high=10000,
            doc="analysis = 'design': iteration limit; a run that reaches it reports converged = false"))
    add(Key("design", "tolerance", "real", default=1.0e-6, low=1.0e-12, high=0.1,
            doc="analysis = 'design': convergence tolerance on the scaled problem (parameters mapped to "
                "[0, 1], objective divided by its start value): SLSQP ftol, trust-constr gtol and xtol",
            note="below 1e-12 the scaled objective is at round-off; above 0.1 nothing is optimised"))
    # &spectrum: a usage spectrum (analysis = 'spectrum'; docs/model.md, "Usage spectrum") ------
    add(Key("spectrum", "regimes", "str", "list",
            doc="the flight regimes of the usage spectrum, one name each (letters, digits, _ and -; at most "
                f"{MAX_REGIMES}); each is a flight run of this deck with the regime's changes",
            allowed=f"1 ... {MAX_REGIMES} distinct names of letters, digits, _ and -"))
    add(Key("spectrum", "share", "real", "list", low=0.0, high=1.0,
            doc="each regime's share of the flight time (0 ... 1, one per regime, summing to 1 within 1e-6)",
            note="a share is a fraction of the flight time"))
    add(Key("spectrum", "forward_speed", "real", "list", "m/s", low=0.0, high=1.0e3,
            doc="each regime's forward speed (&drag forward_speed); default: the deck's for every regime"))
    add(Key("spectrum", "rpm", "real", "list", "rpm", low=1.0e-3, high=1.0e5,
            doc="each regime's rotor speed (&rotor rpm); default: the deck's for every regime"))
    add(Key("spectrum", "load_factor", "real", "list", low=-10.0, high=10.0,
            doc="each regime's load factor n: gravity times n (a steady turn at bank angle phi: n = 1/cos phi; a "
                "pull-up: n > 1), along the deck's gravity; default 1",
            note="helicopter structures are designed for load factors of about -1 ... 3.5; 10 in magnitude is "
                 "beyond any manoeuvre"))
    add(Key("spectrum", "air_density", "real", "list", "kg/m^3", low=1.0e-6, high=2.0e3,
            doc="each regime's air density (&drag air_density: altitude, temperature); default: the deck's"))
    add(Key("spectrum", "blade_file", "str", "list",
            doc="each regime's blade motion from data: a CSV file (path relative to the deck; '' for the deck's own "
                "&blade series) with columns azimuth_deg and any of flap_deg, lag_deg, pitch_deg (the blade's "
                "angles against its azimuth, as a rotor code or a flight test gives them), fitted by least squares "
                "with blade_harmonics harmonics; the fit residual is reported (docs/model.md, \"Blade motion from "
                "data\")"))
    add(Key("spectrum", "changes", "str", "list",
            doc="each regime's further changes of the deck ('' for none): 'group.key = value; group.key(i) = value' "
                "with the values in deck syntax, e.g. 'blade.flap_deg = 4.0, -1.5, 0.5; solver.periodic_tol = 1e-5'; "
                "not of &case, &chain, &refinement, &fatigue, &spectrum or &design"))
    add(Key("spectrum", "blade_harmonics", "int", default=4, low=1, high=36,
            doc="harmonics of a blade_file fit: a0 and 1/rev ... this /rev (the table needs at least 2 h + 1 "
                "azimuths)",
            note="36/rev resolves a 10 deg feature of the blade's motion, beyond what a rotor code's blade "
                 "modes give"))
    add(Key("spectrum", "blade_fit_tolerance_deg", "real", unit="deg", default=0.1, low=1.0e-9, high=10.0,
            doc="largest residual of a blade_file fit at any azimuth: a fit that misses the data by more is refused "
                "(more harmonics, or smoother data)",
            note="below 1e-9 deg the fit's round-off counts; above 10 deg the fit is not the data"))
    add(Key("spectrum", "flights_per_hour", "real", unit="1/h", low=0.0, high=100.0,
            doc="flights per flight hour: each flight is one ground-air-ground cycle (0: none; e.g. 1 for one-hour "
                "sorties)",
            note="100 flights per flight hour are 36 s flights, beyond any mission"))
    add(Key("spectrum", "start_stops_per_flight", "real", default=1.0, low=1.0, high=100.0,
            doc="rotor start-stops per flight (>= 1): each is a run-up and a run-down; those beyond the first add "
                "a ground cycle from rest to ground idle and back"))
    add(Key("spectrum", "runup_time", "real", unit="s", default=8.0, low=1.0e-2, high=1.0e3,
            doc="duration of the rotor run-up from rest to the deck's rotor speed (the run-up record; assumed 8 s, "
                "as inputs/uh60_part2_runup.nml; a real one takes tens of seconds)"))
    add(Key("spectrum", "scatter_factor", "real", default=1.0, low=1.0, high=100.0,
            doc="the safe life is the life divided by this (1: the S-N curve is taken as the working curve; "
                "docs/model.md, \"Usage spectrum\")",
            note="a factor below 1 would lengthen the life; 100 is far beyond any authority's"))
    # &refinement ---------------------------------------------------------------------------
    add(Key("refinement", "levels", "int", default=1, low=1, high=4,
            doc="run n, 2n, 4n ... (levels runs, physical cable parameters) and extrapolate; 1 = off"))
    add(Key("refinement", "expected_order", "real", default=2.0, low=0.5, high=8.0,
            doc="order of the discretisation error in 1/n (Hencky chain: 2; Cardan-angle springs in 3-D: 1)",
            note="this model's discretisation orders are 1 and 2 (docs/model.md); below 0.5 the correction "
                 "(fine - medium)/(2^p - 1) exceeds 2.4 times the last change, above 8 it is below 1/255 of it"))
    # &output -----------------------------------------------------------------------------------
    add(Key("output", "table_language", "str", default="en", choices=("en", "de"),
            doc="table.txt in English, or in German with decimal commas as in the thesis's appendix A"))
    # &solver ------------------------------------------------------------------------------
    add(Key("solver", "t_end", "real", unit="s", default=1.0, low=1.0e-9, high=1.0e7, doc="end time of a dynamic run"))
    add(Key("solver", "dt_out", "real", unit="s", default=1.0e-2, low=1.0e-12, high=1.0e7, doc="output interval"))
    # The range IDA honours on these chains (issue 35): at rtol 1e-2 the six-link reaction was 9 %
    # off, at 1e-3 0.03 %; below rtol = 1e-12 the index-2 corrector's round-off exceeds the
    # Newton test at the first steps (docs/model.md, "Tolerances and the run's own error"); a
    # chain without constraint rows takes atol down to 1e-14 (tests/test_rotation_springs.py).
    add(Key("solver", "rtol", "real", default=1.0e-8, low=1.0e-12, high=1.0e-3, low_open=False,
            doc="relative tolerance (IDA); every dynamic and flight run estimates its own integration error "
                "(integration_error in summary.json, error_estimate)"))
    add(Key("solver", "atol", "real", default=1.0e-10, low=1.0e-14, high=1.0e-3, low_open=False,
            doc="absolute tolerance on q [rad], v [rad/s]"))
    add(Key("solver", "error_estimate", "bool", default=True,
            doc="dynamic, flight: repeat the run (flight: its last revolution) at rtol/100 and report how much "
                "the headline loads moved (summary integration_error; a warning above 0.1 %)"))
    add(Key("solver", "atol_multiplier", "real", unit="N, Nm", default=1.0e4, low=1.0e-12, high=1.0e12,
            doc="absolute tolerance on the multipliers (Newton test only)"))
    add(Key("solver", "h_max", "real", unit="s", default=0.0, **NONNEG, high=1.0e7, tiny=1.0e-12,
            doc="maximum step (0 = none)"))
    add(Key("solver", "max_steps", "int", default=500000, low=1, high=1_000_000_000, doc="step budget of the whole run"))
    add(Key("solver", "newton_tol", "real", unit="Nm", default=1.0e-10, low=1.0e-20, high=1.0e3,
            doc="static equilibrium: max |generalized force|"))
    add(Key("solver", "newton_max_iter", "int", default=200, low=1, high=10_000, doc="static equilibrium: Newton iterations"))
    add(Key("solver", "static_method", "str", default="newton", choices=("newton", "settle"),
            doc="equilibrium by Newton, or by damped dynamic settling (thesis 5.3)"))
    add(Key("solver", "settle_tol", "real", unit="rad/s", default=1.0e-8, low=1.0e-16, high=1.0e3,
            doc="settled when max |qdot| < settle_tol"))
    add(Key("solver", "linear_solver", "str", default="auto", choices=("auto", *LINEAR_SOLVERS),
            doc="IDA linear solver: 'chain', an O(n) articulated-body solve of an approximate iteration "
                "matrix (mass, joint springs and dampers, constraints; no Jacobian formed); 'block', "
                "Schur-complement blocks of the full iteration matrix (O(n^3)); 'dense', SUNDIALS's "
                "dense LU of it; 'auto': block below 32 coordinates, chain from 32 on (docs/jacobian.md)"))
    add(Key("solver", "jacobian", "str", default="analytic", choices=("analytic", "finite_difference"),
            doc="physics columns of the iteration matrix (dF/dq, dF/dv; 'block' and 'dense'): tangent "
                "sweeps of the residual, exact and O(n^2), or central differences (the check)"))
    add(Key("solver", "jacobian_max_age", "int", default=100, low=1, high=100_000,
            doc="steps over which the physics part of the Jacobian is kept (and the chain solver's "
                "factors at most)"))
    add(Key("solver", "vector_kernels", "str", default="compiled", choices=("compiled", "sundials"),
            doc="IDA's N_Vector operations: compiled loops or the library's own"))
    add(Key("solver", "checkpoint_interval", "real", unit="s", default=0.0, low=0.0, high=1.0e7, tiny=1.0e-9,
            doc="dynamic: IDA starts afresh every this many seconds (a multiple of dt_out; 0: never), so that "
                "a continuation (run --restart DIR) of a run whose t_end is a multiple of it reproduces the "
                "uninterrupted run exactly"))
    add(Key("solver", "periodic_method", "str", default="marching", choices=("marching", "shooting"),
            doc="flight: the periodic steady state by marching whole revolutions until two agree, or by "
                "shooting (Newton-Picard on x(T) - x(0): Newton on the slowly decaying hover modes' "
                "subspace, with sensitivity columns of one revolution, plain revolutions on the rest)"))
    add(Key("solver", "floquet", "bool", default=False,
            doc="flight: Floquet stability of the periodic motion from its monodromy matrix (floquet.csv); "
                "refined runs take the least damped modes at every n from a subspace of it and extrapolate them"))
    add(Key("solver", "periodic_tol", "real", unit="m", default=1.0e-6, low=1.0e-14, high=1.0,
            doc="flight: two successive revolutions differ by less than this (max CM distance)"))
    add(Key("solver", "max_revolutions", "int", default=60, low=2, high=10_000, doc="flight: revolution budget"))
    add(Key("solver", "samples_per_rev", "int", default=360, low=8, high=36_000, doc="flight: output samples per revolution"))
    add(Key("solver", "output_format", "str", default="auto", choices=("auto", "csv", "hdf5"),
            doc="time series file: timeseries.csv, timeseries.h5 (HDF5), or CSV up to 5e6 values, HDF5 beyond"))
    return k


KEYS: list[Key] = _keys()
GROUPS: dict[str, dict[str, Key]] = {}
for _k in KEYS:
    GROUPS.setdefault(_k.group, {})[_k.name] = _k

#: Groups a deck must have; the others are optional.
REQUIRED_GROUPS = ("case", "chain", "shape")

GROUP_DOCS = {
    "case": "what to run",
    "chain": "the bodies and joints",
    "shape": "start shape (thesis angles of every body) and rates",
    "springs": "joint springs and dampers, the thesis's direct constants",
    "cable": "physical cable parameters; the joint constants are derived for any n",
    "clamp_a": "support A at the start of the chain (the deck origin); joint 1 turns relative to its frame",
    "clamp_b": "support B holding the last body",
    "ball_b": "support B as a ball joint: the tip held at a point, the last body free to turn",
    "loads": "gravity, rotor speed (legacy), force pulse, tip force",
    "rotor": "the rotor: speed profile, centre, and the frame the equations are written in",
    "blade": "the blade's flap, lead-lag and pitch motion, carried by a support that moves with the blade",
    "campbell": "Campbell diagram: rotor speeds, operating range, tracked modes, harmonics",
    "resonance": "resonance margins: the separation of every mode from the rotor harmonics at the operating speed",
    "drag": "aerodynamic drag by the cross-flow principle",
    "anchor": "a linear spring from one joint point of the chain to a fixed point (a tether)",
    "fatigue": "fatigue per joint: S-N (Basquin) curve, rainflow around the jacket, hotspots",
    "limits": "limits the results are judged against (flagged in the summary and report.html)",
    "design": "design sensitivities (the deck keys the results are differentiated by) and the optimiser of analysis = 'design'",
    "spectrum": "a usage spectrum (analysis = 'spectrum'): flight regimes with their shares of the flight time, "
                "flights and rotor start-stops per flight hour; life over the spectrum by Miner's rule",
    "refinement": "converged numbers: the same cable at n, 2n, 4n bodies and Richardson extrapolation",
    "output": "how the result files are written",
    "solver": "time integration, statics and output settings",
}


def lookup(group: str, name: str) -> Key | None:
    """The schema entry of ``group.name`` (lower case), or None if there is none."""
    return GROUPS.get(group.lower(), {}).get(name.lower())


def groups_of(name: str) -> list[str]:
    """The groups that have a key ``name``, in the schema's order."""
    return [g for g, keys in GROUPS.items() if name.lower() in keys]


def unknown_key_reason(group: str, name: str) -> str:
    """Why ``&group name`` is refused and where the key belongs: the group(s) that have it
    (``t_end`` in ``&chain`` belongs to ``&solver``), else the closest names, else the
    group's keys."""
    group, name = group.lower(), name.lower()
    owners = groups_of(name)
    if owners:
        where = " and ".join(", ".join("&" + g for g in owners).rsplit(", ", 1))
        move = f"move it into &{owners[0]}" if len(owners) == 1 else "move it into the group it is meant for"
        return (f"unknown key in &{group}: {name} is a key of {where}; {move} "
                f"(rotorcable keys {owners[0]}.{name})")
    close = difflib.get_close_matches(name, list(GROUPS.get(group, {})), n=3, cutoff=0.6)
    if close:
        return (f"unknown key; did you mean {' or '.join(close)}? &{group} has: " + ", ".join(GROUPS[group]))
    elsewhere = difflib.get_close_matches(name, [k.name for k in KEYS], n=3, cutoff=0.75)
    if elsewhere:
        names = ", ".join(f"&{g} {k}" for k in dict.fromkeys(elsewhere) for g in groups_of(k))
        return f"unknown key; did you mean {names}? &{group} has: " + ", ".join(GROUPS.get(group, {}))
    return f"unknown key; &{group} has: " + ", ".join(GROUPS.get(group, {}))


def reference_document(name: str = "", acts=None):
    """The deck reference as a :class:`pydriver.document.Document`: the schema as tables, one
    per group (``docs/deck_reference.md``, ``rotorcable keys``).

    ``name`` narrows it: a group (``chain``, ``&chain``), a key of any group (``t_end``: every
    group that has it) or one key (``solver.t_end``, ``&solver t_end``).  ``acts(group, key)``
    says where a key acts when not everywhere (:func:`pydriver.key_scope.describe`, given by the
    callers: the scope table reads this schema, so the schema does not import it).

    Raises
    ------
    ValueError
        ``name`` is no group and no key; the message names the closest ones.
    """
    from pydriver.document import Document, Section, Table

    doc = Document("Deck reference", source_note=(
        "Generated from `pydriver/schema.py` by `python -m pydriver.deck_reference`; do not edit by hand "
        "(CI checks that this file is current).  The installed program prints the same reference: "
        "`rotorcable keys [GROUP or KEY]`."))
    doc.paragraphs.append(
        "A deck is a Fortran namelist file: groups `&name ... /`, keys `key = value`, arrays as "
        "`key = v1, v2, 3*v3` or element by element `key(2) = v`, comments after `!`.  "
        "SI units; angles in degrees; a decimal point, never a comma (`0,590` is two values).  "
        "Shapes: `body`/`joint` take one value per body or joint "
        "(n = `n_bodies`) or a single value for all; `vec3` exactly three; `list` any number.  "
        "Start shapes, start rates and rest angles (shape `body*`/`joint*`) do not broadcast a "
        "single nonzero value: a Fortran namelist read would set element 1 only, so write "
        "`n*value` (e.g. `11*12.0`).  Repeat counts are at most 20000, and numbers are plain "
        "Fortran reals (`1.2.3` and the letterless exponent `1-70` are refused).  "
        f"Required groups: {', '.join('&' + g for g in REQUIRED_GROUPS)}.")
    if acts is not None:
        doc.paragraphs[-1] += ("  Where a key does not act everywhere its meaning says so (*Acts in ... only*, "
                               "from `pydriver/key_scope.py`); a run that sets it where it does not act warns.")
    if name.strip():                               # one group or key: its table is the answer
        doc.paragraphs.clear()
    for group, keys in _selected_keys(name).items():
        table = Table(("key", "type", "shape", "unit", "allowed", "default", "meaning"))
        for key in keys:
            default = "—" if key.default is None else _default_text(key.default)
            allowed = key.range_text().replace("|", "or")        # a bare | would split a Markdown cell
            shape = key.shape + ("*" if not key.broadcast and key.shape in ("body", "joint") else "")
            doc_text = key.doc + (". *Differentiable* (`&design parameters`)." if key.differentiable else "")
            where = acts(group, key.name).replace("|", "or") if acts is not None else ""
            doc_text += f" *{where}*" if where else ""
            table.rows.append((f"`{key.name}`", key.type, shape, key.unit, allowed, default, doc_text))
        doc.sections.append(Section(f"&{group}", [GROUP_DOCS.get(group, "")], table))
    return doc


def _selected_keys(name: str) -> dict[str, list[Key]]:
    """{group: keys} of a reference narrowed by ``name`` (see :func:`reference_document`)."""
    words = name.replace("&", " ").replace(".", " ").lower().split()
    if not words:
        return {g: list(keys.values()) for g, keys in GROUPS.items()}
    if len(words) == 1 and words[0] in GROUPS:
        return {words[0]: list(GROUPS[words[0]].values())}
    if len(words) == 1 and groups_of(words[0]):
        return {g: [GROUPS[g][words[0]]] for g in groups_of(words[0])}
    if len(words) == 2 and lookup(*words) is not None:
        return {words[0]: [lookup(*words)]}
    names = list(GROUPS) + [k.name for k in KEYS] + [f"{k.group}.{k.name}" for k in KEYS]
    close = list(dict.fromkeys(difflib.get_close_matches(".".join(words), names, n=4, cutoff=0.6)))
    raise ValueError(f"'{name}' is no group and no key of a deck"
                     + (f"; did you mean {' or '.join(close)}?" if close else "")
                     + " The groups: " + ", ".join(GROUPS))


def _default_text(v) -> str:
    if isinstance(v, bool):
        return ".true." if v else ".false."
    if isinstance(v, str):
        return f"'{v}'"
    if isinstance(v, (tuple, list)):
        return ", ".join(_num(x) for x in v)
    return _num(v)

