"""Every deck key acts or the run says that it does not apply (issue 35).

The class: for every key of the schema (pydriver/schema.py, one table of all keys) and every
analysis, a deck that sets the key to a value other than its default either

* is refused, by a DeckError naming that key, or
* runs with a warning naming that key (``pydriver.key_scope``: "&solver floquet applies to
  flight runs only: ignored in this static run"), or
* runs to a different result (summary, tables, time series or written files).

:data:`VALUES` gives every key such a value, with the other keys it needs to be valid (a twist
spring needs the twist joint, a pulse force a pulsed body).  A key missing from it fails
``test_every_key_has_a_value``: a new key is not silently ignored.

The first tests read decks only (no run): every key under every analysis lands in one of the
three cases, errors and warnings name the key.  The runs then check the table against the
computation on a 5-body chain, for every (key, analysis) pair that is not refused: a key said
to act changes the result, and a key said to be ignored does not (a wrong warning is a bug
too).  The runs are short (0.05 s of dynamics, 16 samples per revolution, 3 Campbell speeds,
3 optimiser iterations): about 30 s for the whole table.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import pydriver
from pydriver import key_scope
from pydriver.analyses.registry import ANALYSES as REGISTERED
from pydriver.deckfile import deck_from_text, validate
from pydriver.errors import DeckError, RunError
from pydriver.model import Model
from pydriver.schema import GROUPS, KEYS

REMOVE = object()                  #: in a context: drop the key from the deck

BASE = """&case analysis = '{analysis}' /
&chain n_bodies = 5, total_length = 0.6, diameter = 0.015, total_mass = 0.3, joint = 'xy',
  first_body = 'clamped' /
&clamp_a beta_deg = 90.0 /
&shape gamma_deg = 5*0.0, beta_deg = 0.0, 4*40.0 /
&springs c_beta = 10.0, d_beta = 0.001 /
&loads gravity = 0.0, 0.0, -9.81 /
&rotor rpm = 120.0, centre = 0.0, -0.5, 0.0 /
{extra}"""

#: What each analysis needs besides the common deck (short runs: a dynamic run of 0.05 s, a
#: flight of 16 samples per revolution, a Campbell diagram of 3 speeds, a design of 3 iterations).
EXTRA = {
    "static": "",
    "modal": "",
    "dynamic": "&solver t_end = 0.05, dt_out = 0.01, rtol = 1.0e-6, atol = 1.0e-8 /\n",
    # Clamp B on the blade, which flaps at 1/rev: a periodic motion that takes a few revolutions.
    "flight": "&solver samples_per_rev = 16, periodic_tol = 1.0e-4, rtol = 1.0e-6, atol = 1.0e-8 /\n"
              "&clamp_b active = .true., from_start = .true., moves_with = 'blade' /\n"
              "&blade flap_hinge = 0.0, -0.3, 0.0, flap_deg = 2.0, 1.0, 0.5 /\n",
    "campbell": "&campbell n_speeds = 3, n_modes = 1 /\n",
    "design": "&design parameters = 'clamp_a.gamma_deg', objective = 'max_joint_moment', lower = -30.0, "
              "upper = 30.0, max_iterations = 3 /\n",
    # The flight's deck with two regimes, an S-N curve and no flights (no run-up: short).
    "spectrum": "&solver samples_per_rev = 16, periodic_tol = 1.0e-4, rtol = 1.0e-6, atol = 1.0e-8 /\n"
                "&clamp_b active = .true., from_start = .true., moves_with = 'blade' /\n"
                "&blade flap_hinge = 0.0, -0.3, 0.0, flap_deg = 2.0, 1.0, 0.5 /\n"
                "&fatigue sn_exponent = 5.0, sn_reference_amplitude = 1.0e-3, sn_reference_cycles = 1.0e6 /\n"
                "&spectrum regimes = 'a', 'b', share = 0.5, 0.5, flights_per_hour = 0.0 /\n",
}

CABLE = {"springs.c_beta": REMOVE, "springs.d_beta": REMOVE, "chain.total_mass": REMOVE,
         "cable.ei": 1.9, "cable.mass_per_length": 0.5, "cable.damping_time": 1.0e-3}
ZY = {"chain.joint": "zy", "shape.gamma_deg": [90.0, 0.0, 0.0, 0.0, 0.0], "shape.beta_deg": [40.0, 20.0, 20.0, 20.0, 20.0]}
XYZ = {"chain.joint": "xyz", "springs.c_twist": 5.0}
CLAMP_B = {"clamp_b.active": True, "clamp_b.from_start": True}
BLADE = {**CLAMP_B, "clamp_b.moves_with": "blade", "blade.flap_hinge": [0.0, -0.3, 0.0],
         "blade.flap_deg": [2.0, 1.0, 0.5]}
PULSE = {"loads.pulse_body": 3, "loads.pulse_force": [0.0, 0.0, 5.0], "loads.pulse_end": 0.02}
FATIGUE = {"fatigue.sn_exponent": 5.0, "fatigue.sn_reference_amplitude": 1.0e-3, "fatigue.sn_reference_cycles": 1.0e6}
RUNUP = {"rotor.profile": "runup", "rotor.runup_time": 0.03, "rotor.rpm_start": 60.0}
TABLE = {"rotor.profile": "table", "rotor.rpm": REMOVE, "rotor.table_t": [0.0, 0.02, 0.04],
         "rotor.table_rpm": [120.0, 100.0, 80.0]}
BLADE_TABLE = {**BLADE, "blade.motion": "table", "blade.flap_deg": REMOVE, "blade.table_t": [0.0, 0.5, 1.0],
               "blade.table_flap_deg": [0.0, 0.5, 1.0]}
EXTRA_LAG = {**BLADE, "blade.lag_extra_deg": 2.0, "blade.lag_extra_hz": 30.0, "blade.lag_extra_phase_deg": 30.0}
SETTLE = {"solver.static_method": "settle", "solver.t_end": 3.0, "solver.settle_tol": 1.0e-3,
          "springs.d_beta": 0.5}
EQUILIBRIUM_START = {"case.start": "equilibrium"}
TIP = "tip"                       #: placeholder: the base deck's start tip point (a point the chain reaches)
DATA = Path(__file__).parent / "data"
BLADE_FILE = str(DATA / "blade_flap.csv")          #: a blade table (flap = 2 + cos psi + 0.5 sin psi + 0.01 cos 3 psi)
FLIGHTS = {"spectrum.flights_per_hour": 1.0, "spectrum.runup_time": 0.5}

def base_deck(analysis: str):
    return deck_from_text(BASE.format(analysis=analysis, extra=EXTRA[analysis]), f"{analysis}.nml")


def start_tip() -> tuple[list, float, float]:
    """The base chain's tip at its start shape, a point clamp B, ball B or an anchor can hold,
    and the last body's thesis angles gamma, beta there [deg] (R = R_z(gamma) R_y(beta))."""
    model = Model(base_deck("static"))
    shape = model.core.shape(model.q0)
    r = np.asarray(shape["last_rotation"], float)
    return ([float(x) for x in shape["joints"][-1]], float(np.degrees(np.arctan2(r[1, 2], r[0, 2]))),
            float(np.degrees(np.arccos(r[2, 2]))))


TIP_POINT, TIP_GAMMA, TIP_BETA = start_tip()
TIP_NEAR = [0.98 * x for x in TIP_POINT]          #: a point the tip reaches too, 2 % nearer clamp A


#: Per key: (a value other than the default, the other keys it needs; either may depend on the
#: analysis, as a function of it).  Values are chosen to
#: change the result where the key acts: a budget small enough to be hit, a limit low enough to
#: be exceeded.
VALUES = {
    "case.name": ("other", {}),
    # From a design deck: without the optimiser's keys, which only a design run takes.
    "case.analysis": (lambda analysis: "static" if analysis != "static" else "modal",
                      {f"design.{k}": REMOVE for k in ("objective", "lower", "upper", "max_iterations")}),
    "case.description": ("a cable", {}),
    "case.start": ("equilibrium", {}),
    "chain.n_bodies": (6, {"shape.gamma_deg": [0.0] * 6, "shape.beta_deg": [0.0] + [40.0] * 5}),
    "chain.total_length": (0.7, {}),
    "chain.body_length": ([0.1, 0.1, 0.1, 0.1, 0.2], {"chain.total_length": REMOVE}),
    "chain.diameter": (0.02, {}),
    "chain.density": (1500.0, {"chain.total_mass": REMOVE}),
    "chain.total_mass": (0.4, {}),
    "chain.body_mass": ([0.05, 0.05, 0.05, 0.05, 0.1], {"chain.total_mass": REMOVE}),
    "chain.first_body": ("pivot", {}),
    "chain.joint": ("xyz", {"springs.c_twist": 5.0}),
    "shape.gamma_deg": ([0.0, 10.0, 10.0, 10.0, 10.0], {}),
    "shape.beta_deg": ([0.0, 30.0, 30.0, 30.0, 30.0], {}),
    "shape.resample": (True, {"shape.gamma_deg": [0.0, 0.0], "shape.beta_deg": [0.0, 30.0]}),
    "shape.gamma_rate_deg": ([0.0] + [5.0] * 4, ZY),
    "shape.beta_rate_deg": ([0.0] + [5.0] * 4, ZY),
    "springs.c_gamma": (3.0, ZY),
    "springs.c_beta": (20.0, {}),
    "springs.d_gamma": (0.3, ZY),
    "springs.d_beta": (0.3, {}),
    "springs.c_twist": (8.0, XYZ),
    "springs.d_twist": (0.3, XYZ),
    "springs.rest_gamma_deg": ([0.0] + [5.0] * 4, {**ZY, "springs.c_gamma": 3.0}),
    "springs.rest_beta_deg": ([0.0] + [5.0] * 4, ZY),
    "cable.ei": (2.5, CABLE),
    "cable.gj": (1.5, {**CABLE, "chain.joint": "xyz"}),
    "cable.mass_per_length": (0.6, CABLE),
    "cable.spring_measure": ("joint_angles", {**CABLE, "chain.joint": "xyz", "cable.gj": 1.5}),
    "cable.damping_time": (0.01, CABLE),
    "clamp_a.gamma_deg": (20.0, {}),
    "clamp_a.beta_deg": (20.0, {}),
    "clamp_a.moves_with": ("blade", {**BLADE, "clamp_b.moves_with": REMOVE}),
    "clamp_b.active": (True, {"clamp_b.from_start": True}),
    "clamp_b.from_start": (True, {"clamp_b.active": True}),
    "clamp_b.position": (TIP, {"clamp_b.active": True, "clamp_b.gamma_deg": TIP_GAMMA, "clamp_b.beta_deg": TIP_BETA}),
    "clamp_b.gamma_deg": (TIP_GAMMA + 5.0, {"clamp_b.active": True, "clamp_b.position": TIP,
                                            "clamp_b.beta_deg": TIP_BETA}),
    "clamp_b.beta_deg": (TIP_BETA + 5.0, {"clamp_b.active": True, "clamp_b.position": TIP,
                                          "clamp_b.gamma_deg": TIP_GAMMA}),
    "clamp_b.moves_with": ("blade", BLADE),
    "ball_b.active": (True, {"ball_b.position": TIP}),
    "ball_b.position": (TIP_NEAR, {"ball_b.active": True, "ball_b.position": TIP}),
    "loads.gravity": ([0.0, 0.0, -5.0], {}),
    "loads.rotor_rpm": (100.0, {}),
    "loads.rotor_offset": ([0.0, 0.3, 0.0], {"rotor.centre": REMOVE}),
    "loads.pulse_body": (2, {"loads.pulse_force": [0.0, 0.0, 5.0], "loads.pulse_end": 0.02}),
    "loads.pulse_force": ([0.0, 5.0, 5.0], PULSE),
    "loads.pulse_start": (0.01, PULSE),
    "loads.pulse_end": (0.03, PULSE),
    "loads.tip_force": ([0.0, 0.0, 1.0], {}),
    "rotor.rpm": (150.0, {}),
    "rotor.profile": ("runup", {"rotor.runup_time": 0.03, "rotor.rpm_start": 60.0}),
    "rotor.rpm_start": (30.0, RUNUP),
    "rotor.runup_start": (0.01, RUNUP),
    "rotor.runup_time": (0.02, RUNUP),
    "rotor.table_t": ([0.0, 0.01, 0.04], TABLE),
    "rotor.table_rpm": ([100.0, 90.0, 80.0], TABLE),
    "rotor.centre": ([0.0, -0.6, 0.0], {}),
    "rotor.frame": ("inertial", {}),
    "rotor.body_couples": (False, {}),
    "blade.flap_hinge": ([0.0, -0.25, 0.0], BLADE),
    "blade.flap_axis": ([1.0, 0.2, 0.0], BLADE),
    "blade.lag_hinge": ([0.0, -0.25, 0.0], {**BLADE, "blade.lag_deg": [1.0, 2.0]}),
    "blade.lag_axis": ([0.2, 0.0, 1.0], {**BLADE, "blade.lag_deg": [1.0, 2.0]}),
    "blade.pitch_hinge": ([0.05, -0.3, 0.0], {**BLADE, "blade.pitch_deg": [1.0, 2.0]}),
    "blade.pitch_axis": ([0.2, 1.0, 0.0], {**BLADE, "blade.pitch_deg": [1.0, 2.0]}),
    "blade.motion": ("table", {**BLADE, "blade.flap_deg": REMOVE, "blade.table_t": [0.0, 0.5, 1.0],
                               "blade.table_flap_deg": [1.0, 1.5, 2.0]}),
    "blade.flap_deg": ([3.0, 1.0, 0.5], BLADE),
    "blade.lag_deg": ([1.0, 2.0], BLADE),
    "blade.pitch_deg": ([1.0, 2.0], BLADE),
    "blade.lag_extra_deg": (3.0, EXTRA_LAG),
    "blade.lag_extra_hz": (40.0, EXTRA_LAG),
    "blade.lag_extra_phase_deg": (60.0, EXTRA_LAG),
    "blade.table_t": ([0.0, 0.2, 1.0], BLADE_TABLE),
    "blade.table_flap_deg": ([1.0, 1.5, 2.0], BLADE_TABLE),
    "blade.table_lag_deg": ([1.0, 1.5, 2.0], BLADE_TABLE),
    "blade.table_pitch_deg": ([1.0, 1.5, 2.0], BLADE_TABLE),
    "blade.azimuth0_deg": (40.0, BLADE),
    "campbell.rpm_max": (90.0, {}),
    "campbell.n_speeds": (4, {}),
    "campbell.operating_rpm": ([60.0, 100.0], {}),
    "campbell.n_modes": (2, {}),
    "campbell.harmonics": (2, {"campbell.operating_rpm": [0.0, 120.0]}),
    "campbell.lag_band_hz": ([1.0, 2.0], {}),
    "resonance.margin_percent": (90.0, {}),
    "resonance.harmonics": (2, {}),
    "resonance.operating_rpm": (90.0, {}),
    "resonance.excitation": ("blade_passage", {}),
    "resonance.blades": (2, {"resonance.excitation": "blade_passage"}),
    "drag.air_density": (2.0, {"drag.forward_speed": 10.0}),
    "drag.cd": (2.0, {"drag.forward_speed": 10.0}),
    "drag.stream_velocity": ([5.0, 0.0, 0.0], {}),
    "drag.forward_speed": (10.0, {}),
    "anchor.joint": (6, {"anchor.point": TIP, "anchor.stiffness": 100.0}),
    "anchor.point": ([0.1, 0.1, 0.0], {"anchor.joint": 6, "anchor.stiffness": 100.0}),
    "anchor.stiffness": (200.0, {"anchor.joint": 6, "anchor.point": [0.1, 0.1, 0.0]}),
    "fatigue.sn_quantity": ("bending", {**FATIGUE, "fatigue.sn_reference_amplitude": 1.0}),
    "fatigue.sn_exponent": (8.0, FATIGUE),
    "fatigue.sn_reference_amplitude": (2.0e-3, FATIGUE),
    "fatigue.sn_reference_cycles": (2.0e6, FATIGUE),
    "fatigue.sn_endurance_amplitude": (1.0, FATIGUE),
    "fatigue.circumferential_points": (8, FATIGUE),
    "fatigue.hotspots": (1, FATIGUE),
    "fatigue.sn_file": (str(DATA / "sn_table.csv"), {**FATIGUE, "fatigue.sn_reference_amplitude": REMOVE,
                                                     "fatigue.sn_reference_cycles": REMOVE}),
    "fatigue.mean_stress": ("goodman", {**FATIGUE, "fatigue.ultimate": 0.02}),
    "fatigue.ultimate": (0.01, {**FATIGUE, "fatigue.mean_stress": "goodman", "fatigue.ultimate": 0.02}),
    "fatigue.walker_gamma": (0.8, {**FATIGUE, "fatigue.mean_stress": "walker"}),
    "spectrum.regimes": (["a", "c"], {}),
    "spectrum.share": ([0.25, 0.75], {}),
    "spectrum.forward_speed": ([5.0, 10.0], {}),
    "spectrum.rpm": ([100.0, 140.0], {}),
    "spectrum.load_factor": ([1.0, 1.5], {}),
    "spectrum.air_density": ([1.0, 1.2], {"spectrum.forward_speed": [5.0, 10.0]}),
    "spectrum.blade_file": ([BLADE_FILE, ""], {}),
    "spectrum.changes": (["loads.gravity = 0.0, 0.0, -5.0", ""], {}),
    "spectrum.blade_harmonics": (2, {"spectrum.blade_file": [BLADE_FILE, ""]}),
    # Two harmonics miss the table's 3/rev by 0.01 deg: refused below that.
    "spectrum.blade_fit_tolerance_deg": (1.0e-3, {"spectrum.blade_file": [BLADE_FILE, ""],
                                                  "spectrum.blade_harmonics": 2}),
    "spectrum.flights_per_hour": (1.0, {"spectrum.runup_time": 0.5}),
    "spectrum.start_stops_per_flight": (2.0, FLIGHTS),
    "spectrum.runup_time": (0.3, FLIGHTS),
    "spectrum.scatter_factor": (3.0, {}),
    "limits.jacket_strain": (1.0e-6, {}),
    "limits.fatigue_life_hours": (1.0e9, FATIGUE),
    "design.parameters": (["clamp_a.gamma_deg", "chain.total_length"],
                          lambda analysis: {"design.lower": [-30.0, 0.5], "design.upper": [30.0, 0.7]}
                          if analysis == "design" else {}),
    "design.objective": ("max_reaction_force", {}),
    "design.lower": ([-10.0], {}),
    "design.upper": ([10.0], {}),
    "design.frequency_margin_percent": (5.0, {}),
    "design.starts": (1, {}),
    # The margin on converged frequencies: refined over n, 2n, which needs the cable's parameters.
    "design.frequency_levels": (2, {**CABLE, "design.frequency_margin_percent": 5.0}),
    "design.method": ("trust-constr", {}),
    "design.max_iterations": (1, {}),
    "design.tolerance": (0.05, {}),
    "refinement.levels": (2, CABLE),
    "refinement.expected_order": (1.0, {**CABLE, "refinement.levels": 2}),
    "output.table_language": ("de", {}),
    "solver.t_end": (0.04, {}),
    "solver.dt_out": (0.02, {}),
    "solver.rtol": (1.0e-3, {}),
    "solver.atol": (1.0e-3, {}),
    "solver.atol_multiplier": (1.0e-6, CLAMP_B),       # tight enough for the Newton test to notice
    "solver.h_max": (1.0e-4, {}),
    "solver.max_steps": (3, {}),
    "solver.newton_tol": (1.0e-2, {}),
    "solver.newton_max_iter": (1, {}),
    "solver.static_method": ("settle", {"solver.t_end": 3.0, "solver.settle_tol": 1.0e-3, "springs.d_beta": 0.5}),
    # Not at rest at t_end: refused.  In flight, settling needs a blade at rest (the base's flaps
    # at 1/rev: nothing comes to rest in the hub frame), so a constant flap angle there.
    "solver.settle_tol": (1.0e-12, lambda analysis: {**SETTLE, **({"blade.flap_deg": [2.0]}
                                                                 if analysis == "flight" else {})}),
    "solver.linear_solver": ("dense", {}),
    "solver.jacobian": ("finite_difference", {}),
    "solver.jacobian_max_age": (1, {}),
    "solver.vector_kernels": ("sundials", {}),
    "solver.checkpoint_interval": (0.02, {}),
    "solver.error_estimate": (False, {}),
    "solver.periodic_method": ("shooting", {}),
    "solver.floquet": (True, {}),
    "solver.periodic_tol": (1.0e-2, {}),
    "solver.max_revolutions": (2, {}),
    "solver.samples_per_rev": (12, {}),
    "solver.output_format": ("hdf5", {}),
}

ANALYSES = key_scope.ANALYSES
def variant(deck, changes: dict):
    """The deck with ``changes`` (``{"group.key": value or REMOVE}``) applied, validated."""
    raw = {g: dict(v) for g, v in deck.raw.items()}
    starts = {g: dict(v) for g, v in deck.starts.items()}
    for dotted, value in changes.items():
        group, key = dotted.split(".")
        if value is REMOVE:
            raw.get(group, {}).pop(key, None)
            if group in raw and not raw[group]:
                del raw[group]
            continue
        if isinstance(value, str) and value == TIP:
            value = TIP_POINT
        raw.setdefault(group, {})[key] = list(value) if isinstance(value, (list, tuple)) else value
        starts.get(group, {}).pop(key, None)
    return validate(raw, starts, deck.name)


def changed(analysis: str, dotted: str):
    """(base deck, deck with the key's value and its context, and that context's own refusal or
    None) of one analysis.  The base is the plain deck with the key's context where the context
    alone is a valid deck (a pulse force's pulsed body), else the plain deck (four start angles
    fit only four bodies)."""
    value, context = VALUES[dotted]
    if callable(value):
        value = value(analysis)
    if callable(context):
        context = context(analysis)
    plain = base_deck(analysis)
    refusal, base = None, None
    # The base: the plain deck with the whole context (the key at the context's own value), else
    # with the context and the key at its default, else the plain deck with the key at its
    # default, else the plain deck (a required key).
    others = {n: v for n, v in context.items() if n != dotted}
    for k, candidate in enumerate((context, {**others, dotted: REMOVE}, {dotted: REMOVE}, {})):
        if k == 0 and (dotted not in context or context[dotted] == value):
            continue                               # the context does not set the key to another value
        try:
            base = variant(plain, candidate)
            Model(base)
            break
        except DeckError as err:
            refusal = err if refusal is None else refusal
            base = None
    return base, variant(base, {**context, dotted: value}), refusal


def outcome(deck, dotted: str, context_refusal) -> str:
    """'refused' (a DeckError naming the key), 'context refused' (the key's context is refused
    in this analysis, as by itself), 'warned' (a key_scope warning naming it) or 'acts' (neither:
    the run must change).  A DeckError naming another key fails the test."""
    group, key = dotted.split(".")
    try:
        model = Model(deck)
    except DeckError as err:
        if (err.group, err.key) == (group, key):
            return "refused"
        assert context_refusal is not None and (err.group, err.key) == (context_refusal.group, context_refusal.key), \
            f"{dotted}: refused naming &{err.group} {err.key}: {err}"
        return "context refused"
    for ignored in key_scope.ignored_keys(model.deck):
        if ignored.group == group and (key in ignored.keys or not ignored.keys):
            message = ignored.message()
            assert f"&{group}" in message and (key in message or not ignored.keys)
            return "warned"
    return "acts"


def outcomes() -> dict:
    """{(analysis, key): outcome} over every key and analysis, by deck checking alone."""
    out = {}
    for analysis in ANALYSES:
        for key in KEYS:
            dotted = f"{key.group}.{key.name}"
            try:
                _, deck, refusal = changed(analysis, dotted)
            except DeckError as err:               # the value itself is refused by the schema
                assert (err.group, err.key) == (key.group, key.name), f"{dotted}: {err}"
                out[(analysis, dotted)] = "refused"
                continue
            out[(analysis, dotted)] = outcome(deck, dotted, refusal)
    return out


OUTCOMES = outcomes()


def test_every_key_has_a_value():
    """A key without an entry here is a key nobody decided the scope of."""
    assert sorted(VALUES) == sorted(f"{k.group}.{k.name}" for k in KEYS)


def test_every_value_differs_from_the_default():
    from pydriver.deckfile import default_value
    for key in KEYS:
        dotted = f"{key.group}.{key.name}"
        value = VALUES[dotted][0]
        if callable(value):
            value = value("design")
        if isinstance(value, str) and value == TIP:
            continue
        default = default_value(key, 5)
        assert default is None or not np.array_equal(np.asarray(value, dtype=object),
                                                     np.asarray(default, dtype=object)), dotted


def test_each_key_is_refused_warned_or_acting_under_every_analysis():
    """By deck checking alone: every (analysis, key) has an outcome, errors and warnings name
    the key (checked in outcome()), and the known cases of the issue are warned."""
    assert len(OUTCOMES) == len(ANALYSES) * len(KEYS)
    for analysis in ("static", "dynamic", "modal", "campbell"):
        assert OUTCOMES[(analysis, "solver.floquet")] == "warned"
        assert OUTCOMES[(analysis, "solver.periodic_method")] == "warned"
    assert OUTCOMES[("flight", "solver.floquet")] == "acts"
    # Every analysis takes most keys; a table that warned about everything would pass the
    # runs below trivially.
    for analysis in ANALYSES:
        acting = sum(1 for (a, _), o in OUTCOMES.items() if a == analysis and o == "acts")
        assert acting >= 40, (analysis, acting)


def test_the_warning_reads_as_the_issue_asks():
    deck = variant(base_deck("static"), {"solver.floquet": True, "solver.periodic_method": "shooting"})
    result = pydriver.run_deck(Model(deck))
    assert "&solver periodic_method, floquet apply to flight runs only: ignored in this static run" \
        in result.summary["warnings"]


def test_a_key_at_its_default_or_an_acting_key_says_nothing():
    deck = variant(base_deck("modal"), {"solver.floquet": False, "springs.c_beta": 12.0})
    assert key_scope.warnings(Model(deck).deck) == []


# -- the runs ------------------------------------------------------------------------------------

VOLATILE = ("wall_time", "warnings")
#: Parts of the summary that restate the deck (the cable's parameters, the rotor's speed and
#: blade azimuth), not results.
ECHO = ("cable", "rotor")


def _strip(x, top=True):
    if isinstance(x, dict):
        return {k: _strip(v, False) for k, v in x.items()
                if not any(v_ in k for v_ in VOLATILE) and not (top and k in ECHO)}
    if isinstance(x, (list, tuple)):
        return [_strip(v, False) for v in x]
    return x


def _file_text(path) -> str:
    if path.suffix == ".npz":                   # the checkpoint: its state, not the deck it records
        with np.load(path) as npz:
            return repr({k: npz[k].tolist() for k in npz.files if k != "deck"})
    return path.read_bytes().hex()


def fingerprint(deck, tmp_path) -> str:
    """What a run produced, as one text: its summary without wall times and warnings, and every
    file it wrote but summary.json (its time series, tables, modes); a failed run: its error."""
    out = tmp_path / f"run{len(list(tmp_path.iterdir()))}"
    try:
        result = pydriver.run_deck(Model(deck), out=out)
    except (RunError, DeckError) as err:
        return f"error: {type(err).__name__}: {err}"
    # optimum.nml (a design run) restates every key of the deck, whether it acted or not.
    files = {p.name: _file_text(p) for p in sorted(out.iterdir())
             if p.is_file() and p.name not in ("summary.json", ".rotorcable-run.json", "optimum.nml")}
    return json.dumps([_strip(result.summary), files], sort_keys=True, default=str)


def _pairs(analyses, keys=None):
    return [(a, k) for (a, k), o in OUTCOMES.items() if a in analyses and o in ("acts", "warned")
            and (keys is None or k in keys)]


def test_a_moving_blade_table_runs_and_clamp_b_follows_it(tmp_path):
    """A blade angle table that moves at t = 0 once stopped IDA there: the spline was held at its
    first time (rate 0) and took its slope just after, a jump of clamp B's velocity.  The table's
    ends now belong to the spline, so the start is consistent with the blade's rate at t = 0.  The
    check is the constraint: clamp B's violation stays within what the integrator's tolerance
    allows (1e-6 m: rtol 1e-6 on positions of ~1 m), over a run through the table's knots."""
    base, _, _ = changed("dynamic", "blade.table_t")
    deck = variant(base, {"blade.table_flap_deg": [0.0, 0.5, 1.0], "solver.t_end": 0.3})
    result = pydriver.run_deck(Model(deck), out=tmp_path / "o")
    assert result.summary["solver"]["steps"] > 0
    assert float(np.max(result.timeseries["g_max_m"])) < 1e-6


def test_a_blade_table_that_ends_while_moving_before_t_end_is_refused():
    """After its last time the table's angle is held: a table still moving there jumps clamp B's
    velocity (IDA fails at that time), so a dynamic run past it is refused, naming the key."""
    base, _, _ = changed("dynamic", "blade.table_t")
    deck = variant(base, {"blade.table_flap_deg": [0.0, 0.5, 1.0], "solver.t_end": 1.2})
    with pytest.raises(DeckError, match="angle table ends at 1 s") as err:
        Model(deck)
    assert (err.value.group, err.value.key) == ("blade", "table_t")
    Model(variant(base, {"blade.table_flap_deg": [0.5, 0.5, 0.5], "solver.t_end": 1.2}))   # a held table runs on


def _same(a, b) -> bool:
    return all(np.array_equal(np.asarray(a.values[g][k], dtype=object), np.asarray(b.values[g][k], dtype=object))
               for g in GROUPS for k in GROUPS[g]) and a.groups == b.groups


def _check(analysis, dotted, tmp_path):
    base, deck, _ = changed(analysis, dotted)
    if _same(base, deck):
        return                                  # the base has the value already (flight: clamp B)
    before, after = fingerprint(base, tmp_path), fingerprint(deck, tmp_path)
    if OUTCOMES[(analysis, dotted)] == "acts":
        assert before != after, f"{dotted} is said to act in a {analysis} run but changes nothing"
    else:
        assert before == after, f"{dotted} is said to be ignored in a {analysis} run but changes the result"


@pytest.mark.parametrize("analysis", ["static", "modal", "campbell", "dynamic"])
def test_the_table_holds_in_every_run(analysis, tmp_path):
    """Every key: said to act, it changes the run; said to be ignored, it changes nothing."""
    failures = []
    for _, dotted in _pairs((analysis,)):
        try:
            _check(analysis, dotted, tmp_path)
        except AssertionError as err:
            failures.append(str(err).splitlines()[0])
    assert not failures, "\n".join(failures)


@pytest.mark.parametrize("analysis", ["flight", "design"])
def test_the_table_holds_in_flight_and_design_runs(analysis, tmp_path):
    failures = []
    for _, dotted in _pairs((analysis,)):
        try:
            _check(analysis, dotted, tmp_path)
        except AssertionError as err:
            failures.append(str(err).splitlines()[0])
    assert not failures, "\n".join(failures)


#: A usage spectrum's own keys, the fatigue and limit keys its life depends on, and keys it is said
#: to ignore although its regimes' flight runs read them (margins, Floquet) or its run-up sets
#: itself (a dynamic run's start, run-up and times): each spectrum run is two flight runs, so
#: these rather than the whole table.
SPECTRUM_KEYS = tuple(k for k in VALUES if k.split(".")[0] in ("spectrum", "fatigue", "limits", "resonance")) + (
    "solver.floquet", "solver.periodic_tol", "solver.t_end", "solver.dt_out", "case.start", "rotor.runup_time",
    "drag.forward_speed", "loads.gravity", "design.parameters", "refinement.levels")


def test_the_table_holds_in_spectrum_runs(tmp_path):
    failures = []
    for _, dotted in _pairs(("spectrum",), SPECTRUM_KEYS):
        try:
            _check("spectrum", dotted, tmp_path)
        except AssertionError as err:
            failures.append(str(err).splitlines()[0])
    assert not failures, "\n".join(failures)


# -- the command line's flags --------------------------------------------------------------------

def _run_parser():
    from pydriver.__main__ import build_parser
    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    return sub.choices["run"]


@pytest.fixture
def cli(capsys):
    """main(['run', ...]) in this process: (status, stdout, stderr).  The signal handlers and
    the progress level it sets are restored afterwards."""
    import signal

    from pydriver import progress
    from pydriver.__main__ import main
    saved = {sig: signal.getsignal(sig) for sig in (signal.SIGTERM, signal.SIGHUP)}

    def call(*args):
        status = main(["run", *map(str, args)])
        out = capsys.readouterr()
        return status, out.out, out.err
    yield call
    for sig, handler in saved.items():
        signal.signal(sig, handler)
    progress.configure(progress.QUIET)


def _files(path) -> set:
    return {p.name for p in path.iterdir()} if path.exists() else set()


#: Per flag of ``rotorcable run`` (its argparse dest): what it does to a run of each analysis,
#: checked against the same run without it.  A flag missing here fails the test.
def _flag_checks():
    def new_files(suffix):
        def check(a, plain, run, **_):
            return any(f.endswith(suffix) for f in _files(run["dir"]) - _files(plain["dir"]))
        return check

    def restart(a, plain, run, **_):
        if a == "dynamic":
            return run["status"] == 0 and "restarted_from" in json.loads((run["dir"] / "summary.json").read_text())
        return run["status"] == 1 and "--restart" in run["err"]          # refused, naming the flag

    def refine(a, plain, run, **_):
        # These decks give the thesis's per-joint springs: refused, naming &refinement levels,
        # the key --refine sets (a cable deck refines: test_refine_acts_on_a_cable_deck).
        return run["status"] == 1 and "&refinement key 'levels'" in run["err"]

    return {
        "out": lambda a, plain, run, **_: plain["status"] == 0 and "summary.json" in _files(plain["dir"]),
        "plots": new_files(".png"),
        "report": new_files(".html"),
        # An analysis that keeps no cable to draw (a usage spectrum) refuses the flag, naming it.
        "vtk": lambda a, plain, run, **_: new_files(".pvd")(a, plain, run) or (
            not REGISTERED[a].draws and run["status"] == 1 and "--vtk" in run["err"]),
        "json": lambda a, plain, run, **_: json.loads(run["out"]) == json.loads(
            (run["dir"] / "summary.json").read_text()) and run["out"] != plain["out"],
        "verbose": lambda a, plain, run, **_: run["err"] != "" and all(
            ln.startswith("[") for ln in run["err"].splitlines()),
        "quiet": lambda a, plain, run, **_: (run["out"], run["err"]) == ("", "") and plain["out"] != "",
        "refine": refine,
        "restart": restart,
    }


FLAG_ARGS = {"out": [], "plots": ["--plots"], "report": ["--report"], "vtk": ["--vtk"], "json": ["--json"],
             "verbose": ["-v"], "quiet": ["-q"], "refine": ["--refine"], "restart": ["--restart", "{plain}"]}


def test_every_flag_is_checked():
    dests = {a.dest for a in _run_parser()._actions} - {"help", "decks"}
    assert dests == set(_flag_checks()) == set(FLAG_ARGS)


@pytest.mark.parametrize("analysis", ANALYSES)
def test_every_flag_acts_or_is_refused(analysis, cli, tmp_path):
    """Each flag of ``rotorcable run`` changes what a run of every analysis writes or prints,
    or the run is refused naming it (issue 35: --vtk on a static run wrote nothing, silently)."""
    from pydriver.deckfile import deck_text
    deck = tmp_path / f"{analysis}.nml"
    deck.write_text(deck_text(base_deck(analysis)))
    plain = {"dir": tmp_path / "plain"}
    plain["status"], plain["out"], plain["err"] = cli(deck, "--out", plain["dir"])
    assert plain["status"] == 0, plain["err"]
    if analysis == "dynamic":                  # --restart continues the plain run to a later end
        deck.write_text(deck_text(variant(base_deck(analysis), {"solver.t_end": 0.08})))
    failures = []
    for flag, check in _flag_checks().items():
        run = {"dir": tmp_path / flag}
        args = [x.format(plain=plain["dir"]) for x in FLAG_ARGS[flag]]
        run["status"], run["out"], run["err"] = cli(deck, "--out", run["dir"], *args)
        if not check(analysis, plain, run):
            failures.append(f"--{flag}: status {run['status']}, stderr {run['err'][:200]!r}")
    assert not failures, "\n".join(failures)


def test_refine_acts_on_a_cable_deck(cli, tmp_path):
    from pydriver.deckfile import deck_text
    deck = tmp_path / "cable.nml"
    deck.write_text(deck_text(variant(base_deck("static"), CABLE)))
    status, out, err = cli(deck, "--out", tmp_path / "r", "--refine", "--json")
    assert status == 0, err
    assert json.loads(out)["refinement"]["n"] == [5, 10, 20]
