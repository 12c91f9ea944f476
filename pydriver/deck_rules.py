"""Cross-key rules of a deck: what the schema's per-key checks cannot see.

Each rule raises the deck's :class:`~pydriver.errors.DeckError` naming the group, the key and
the reason.  Rules about sizes that only the assembled model knows (reach of clamp B, enough
coordinates for the constraints) are checked by the core when the model is built.
"""

from __future__ import annotations

import math

import numpy as np

from pydriver import design, design_problem
from pydriver.analyses.registry import ANALYSES, analysis_of
from pydriver.deckfile import Deck

#: Largest number of output samples of one run.  At one sample per 1e-4 s this is a week of
#: simulated time; beyond it the request is a typo (dt_out = 1e-10) or a runaway t_end.
MAX_SAMPLES = 50_000_000
#: Largest number of time-series values a run holds in memory at once (samples x columns):
#: 2.5e8 float64 values are 2 GB, what a workstation can spare for one run.
MEMORY_BUDGET_VALUES = 250_000_000


def columns_per_sample(n_bodies: int) -> int:
    """Time-series columns of a chain of n bodies, an upper estimate: 186 were measured at
    n = 11 with xyz joints (coordinates, rates, reactions, loads and curvatures per joint)."""
    return 20 * n_bodies + 40


def check(deck: Deck) -> None:
    """Apply every rule; the first violation raises."""
    if not deck.has("case.analysis"):
        deck.fail("case", "analysis", "is required: " + ", ".join(f"'{a}'" for a in ANALYSES))
    _chain(deck)
    _joint_constants(deck)
    _clamp_b(deck)
    _loads(deck)
    _rotor(deck)
    _blade(deck)
    _output_times(deck)
    _fatigue(deck)
    _limits(deck)
    _refinement(deck)
    _resonance(deck)
    _analysis_rules(deck)
    _memory_budget(deck)
    # The optimiser's keys first: on another analysis they are refused by their own names, before
    # &design parameters is found missing.
    design_problem.problem(deck)      # analysis = 'design': objective, bounds, constraint, settings
    design.parameters(deck)           # &design parameters: names, differentiable keys, analysis


def _one_of(deck: Deck, keys: list[str], what: str):
    given = [k for k in keys if deck.has(k)]
    if len(given) != 1:
        group, key = (given[1] if len(given) > 1 else keys[0]).split(".")
        names = ", ".join(k.split(".")[1] if k.startswith(group) else k for k in keys)
        deck.fail(group, key, f"give exactly one of {names} ({what})")
    return given[0]


def _chain(deck: Deck):
    for key in ("gamma_deg", "beta_deg"):
        if not deck.has(f"shape.{key}"):
            deck.fail("shape", key, f"is required: one angle per body ({deck.n_bodies} values)")
    _one_of(deck, ["chain.total_length", "chain.body_length"], "the cable's length")
    if not deck.has("chain.diameter"):
        deck.fail("chain", "diameter", "is required (cable diameter)")
    _one_of(deck, ["chain.density", "chain.total_mass", "chain.body_mass", "cable.mass_per_length"],
            "the cable's mass")
    if deck["chain.n_bodies"] < 2 and deck["clamp_b.active"]:
        deck.fail("chain", "n_bodies", "a chain held by clamp B needs at least 2 bodies")


def _joint_constants(deck: Deck):
    joint = deck["chain.joint"]
    physical = "cable" in deck.groups and deck.has("cable.ei")
    if "cable" in deck.groups and not deck.has("cable.ei"):
        deck.fail("cable", "ei", "is required in &cable (bending stiffness EI)")
    if physical:
        if joint == "zy":
            deck.fail("chain", "joint", "physical cable parameters (&cable) need joint = 'xy' or 'xyz': the "
                                        "thesis's zy joint is singular on a straight cable")
        for key in ("c_gamma", "c_beta", "c_twist", "d_gamma", "d_beta", "d_twist"):
            if deck.has(f"springs.{key}"):
                deck.fail("springs", key, "give the joint constants either in &springs or through &cable, "
                                          "not both")
        if joint == "xyz" and not deck.has("cable.gj"):
            deck.fail("cable", "gj", "is required with joint = 'xyz' (torsional stiffness GJ)")
        if joint != "xyz" and deck.has("cable.gj"):
            deck.fail("cable", "gj", "a torsional stiffness needs the twist coordinate of joint = 'xyz'")
    if joint in ("xy", "xyz"):
        # Both Cardan angles bend the cable: c_beta/d_beta act on both.  The thesis's gamma
        # spring has no coordinate here, and rest angles or start rates in gamma/beta do not
        # translate into Cardan angles uniquely: refuse rather than guess.
        for key in ("c_gamma", "d_gamma"):
            if np.any(deck[f"springs.{key}"] != 0.0):
                deck.fail("springs", key, f"with joint = '{joint}' both bending angles use c_beta and d_beta; "
                                          "c_gamma and d_gamma have no coordinate (set them to 0)")
        for key in ("rest_gamma_deg", "rest_beta_deg"):
            if np.any(deck[f"springs.{key}"] != 0.0):
                deck.fail("springs", key, f"rest angles are not supported with joint = '{joint}' (straight rest)")
        for key in ("gamma_rate_deg", "beta_rate_deg"):
            if np.any(deck[f"shape.{key}"] != 0.0):
                deck.fail("shape", key, f"start rates are not supported with joint = '{joint}'")
    if joint == "xyz" and not physical:
        if not deck.has("springs.c_twist"):
            deck.fail("springs", "c_twist", "is required with joint = 'xyz' (the twist's own torsion spring; "
                                            "0 leaves the twist free, a zero-stiffness mode)")
    elif joint != "xyz":
        for key in ("c_twist", "d_twist"):
            if deck.has(f"springs.{key}"):
                deck.fail("springs", key, "a twist spring needs the twist coordinate of joint = 'xyz'")


def _clamp_b(deck: Deck):
    if not deck["clamp_b.active"]:
        for key in ("position", "gamma_deg", "beta_deg", "from_start"):
            if deck.has(f"clamp_b.{key}") and key != "from_start":
                deck.fail("clamp_b", key, "clamp B is not active (active = .false.): set active = .true. "
                                          "or remove the key")
        if deck["clamp_b.moves_with"] != "hub":
            deck.fail("clamp_b", "moves_with", "clamp B is not active")
        return
    if deck["clamp_b.from_start"]:
        return
    if not deck.has("clamp_b.position"):
        deck.fail("clamp_b", "position", "needs 3 coordinates (or from_start = .true.)")
    for key in ("gamma_deg", "beta_deg"):
        if not deck.has(f"clamp_b.{key}"):
            deck.fail("clamp_b", key, "gamma_deg and beta_deg of the last body are needed (or from_start = .true.)")


def _loads(deck: Deck):
    n = deck.n_bodies
    body = deck["loads.pulse_body"]
    if body > n:
        deck.fail("loads", "pulse_body", f"must be 0 (no pulse) or a body index 1..{n}")
    if body > 0:
        if not deck["loads.pulse_end"] > deck["loads.pulse_start"]:
            deck.fail("loads", "pulse_end", "must be later than pulse_start")
        if analysis_of(deck).time_axis == "t_end" and deck["loads.pulse_start"] >= deck["solver.t_end"]:
            deck.fail("loads", "pulse_start", f"the pulse starts at {deck['loads.pulse_start']:g} s, at or after "
                                              f"the end of the run (t_end = {deck['solver.t_end']:g} s)")
    if deck["clamp_b.active"] and np.any(deck["loads.tip_force"] != 0.0):
        deck.fail("loads", "tip_force", "a tip force needs a free end (clamp_b active = .false.)")


def _rotor(deck: Deck):
    if "rotor" not in deck.groups:
        if analysis_of(deck).needs_rotor and not (deck.has("loads.rotor_rpm") and deck["loads.rotor_rpm"] > 0):
            deck.fail("rotor", "rpm", f"analysis '{deck['case.analysis']}' needs a turning rotor (&rotor rpm)")
        return
    if deck.has("loads.rotor_rpm"):
        deck.fail("loads", "rotor_rpm", "give the rotor speed once: &rotor rpm (&loads rotor_rpm is the "
                                        "older spelling of the same)")
    profile = deck["rotor.profile"]
    if profile in ("constant", "runup") and not deck.has("rotor.rpm"):
        deck.fail("rotor", "rpm", f"is required with profile = '{profile}'")
    if profile == "runup" and not deck.has("rotor.runup_time"):
        deck.fail("rotor", "runup_time", "is required with profile = 'runup'")
    if profile == "table":
        t, w = deck["rotor.table_t"], deck["rotor.table_rpm"]
        if t is None or w is None or len(t) != len(w) or len(t) < 3:
            deck.fail("rotor", "table_rpm", "a speed table needs table_t and table_rpm of the same length, "
                                            "at least 3 points")
        if t[0] != 0.0 or np.any(np.diff(t) <= 0.0):
            deck.fail("rotor", "table_t", "must start at 0 and increase strictly")
    if analysis_of(deck).periodic and (profile != "constant" or deck["rotor.rpm"] <= 0.0):
        deck.fail("rotor", "profile", "a flight run (periodic steady state) needs a constant rotor speed > 0")
    if analysis_of(deck).sweeps_speed and profile != "constant":
        # Each speed of the diagram is the constant speed of the model (analyses/campbell.py); a
        # run-up or a table had been refused only at the first speed, as a missing model parameter.
        deck.fail("rotor", "profile", "a Campbell diagram sets the rotor's constant speed at each of its speeds: "
                                      "give profile = 'constant' (and &campbell rpm_max)")


def _blade(deck: Deck):
    moving = [g for g in ("clamp_a", "clamp_b") if deck[f"{g}.moves_with"] == "blade"]
    if "blade" not in deck.groups:
        if moving:
            deck.fail(moving[0], "moves_with", "a support on the blade needs the blade's motion (&blade)")
        return
    if not moving:
        deck.fail("blade", "flap_hinge", "no support moves with the blade: set &clamp_b moves_with = 'blade'")
    if not deck.has("blade.flap_hinge"):
        deck.fail("blade", "flap_hinge", "is required (a point on the flap hinge axis)")
    for key in ("flap_axis", "lag_axis", "pitch_axis"):
        if not np.linalg.norm(deck[f"blade.{key}"]) > 0.0:
            deck.fail("blade", key, "must not be the zero vector")
    if deck["blade.motion"] == "table":
        t = deck["blade.table_t"]
        if t is None or len(t) < 3 or np.any(np.diff(t) <= 0.0):
            deck.fail("blade", "table_t", "an angle table needs at least 3 increasing times")
        for key in ("table_flap_deg", "table_lag_deg", "table_pitch_deg"):
            if deck[f"blade.{key}"] is not None and len(deck[f"blade.{key}"]) != len(t):
                deck.fail("blade", key, f"needs {len(t)} values (one per table time)")
        # After its last time a table's angle is held, so a table that still moves there (its
        # spline's end slope) jumps the blade's angle rate to 0: a velocity jump of clamp B that the
        # clamped cable cannot follow (IDA fails at that time).  A run that ends within the table
        # never meets it; a constant table has no end slope.
        moves = any(deck[f"blade.{key}"] is not None and np.ptp(deck[f"blade.{key}"]) > 0.0
                    for key in ("table_flap_deg", "table_lag_deg", "table_pitch_deg"))
        if moves and analysis_of(deck).time_axis == "t_end" and deck["solver.t_end"] > t[-1]:
            deck.fail("blade", "table_t", f"the angle table ends at {t[-1]:g} s, before &solver t_end = "
                                          f"{deck['solver.t_end']:g} s, while the blade still moves: the held angle "
                                          "after the table would jump the blade's angle rate to 0, which the clamped "
                                          "cable cannot follow; extend the table to t_end (or end the run within it)")
    elif analysis_of(deck).periodic and deck["blade.lag_extra_deg"] != 0.0:
        deck.fail("blade", "lag_extra_deg", "an oscillation at its own frequency makes the motion non-periodic "
                                            "in the azimuth: a flight run cannot reach a periodic steady "
                                            "state with it (use a dynamic run)")
    for g in moving:
        if analysis_of(deck).periodic and deck["blade.motion"] == "table":
            deck.fail("blade", "motion", "a flight run needs a periodic blade motion (Fourier series)")
        if g == "clamp_b" and not deck["clamp_b.active"]:
            deck.fail("clamp_b", "moves_with", "clamp B is not active")


def _output_times(deck: Deck):
    interval = deck["solver.checkpoint_interval"]
    if not analysis_of(deck).restartable:
        if interval:
            deck.fail("solver", "checkpoint_interval", "checkpoints are for dynamic runs")
        return
    if interval:
        steps = interval / deck["solver.dt_out"]
        if abs(steps - round(steps)) > 1e-9 * max(steps, 1.0) or round(steps) < 1:
            deck.fail("solver", "checkpoint_interval", f"must be a multiple of dt_out = {deck['solver.dt_out']:g} s "
                                                       f"(got {interval:g} s = {steps:.6g} dt_out)")
    n = deck["solver.t_end"] / deck["solver.dt_out"]
    if not math.isfinite(n) or n + 1 > MAX_SAMPLES:
        deck.fail("solver", "dt_out", f"t_end / dt_out = {n:.3g} output samples: more than {MAX_SAMPLES:.0e}; "
                                      "choose a larger dt_out")


def _memory_budget(deck: Deck):
    """Refuse a run whose time series in memory would exceed MEMORY_BUDGET_VALUES, before any
    allocation (issue 20: samples_per_rev = 3e9 tried to allocate 22 GiB)."""
    time_axis = analysis_of(deck).time_axis
    n = deck.n_bodies * 2 ** (deck["refinement.levels"] - 1)      # the finest refinement level
    if time_axis == "revolutions":
        samples, key = deck["solver.samples_per_rev"] + 1, "samples_per_rev"
    elif time_axis == "t_end" and "fatigue" in deck.groups:     # rainflow needs the whole history
        samples, key = deck["solver.t_end"] / deck["solver.dt_out"] + 1, "dt_out"
    else:
        return
    values = samples * columns_per_sample(n)
    if values > MEMORY_BUDGET_VALUES:
        deck.fail("solver", key, f"{samples:.3g} samples x {columns_per_sample(n)} columns "
                                 f"(n = {n} bodies) = {values:.3g} values in memory, more than the "
                                 f"budget of {MEMORY_BUDGET_VALUES:.3g} (2 GB); fewer samples or bodies")


def _fatigue(deck: Deck):
    if "fatigue" not in deck.groups:
        return
    if deck["fatigue.sn_file"]:
        # The table is the curve; sn_exponent may stay, as the DELs' exponent.
        for key in ("sn_reference_amplitude", "sn_reference_cycles"):
            if deck.has(f"fatigue.{key}"):
                deck.fail("fatigue", key, "give the S-N curve once: Basquin's parameters or the table of sn_file")
    else:
        for key in ("sn_exponent", "sn_reference_amplitude", "sn_reference_cycles"):
            if not deck.has(f"fatigue.{key}"):
                deck.fail("fatigue", key, "is required: the S-N curve has no default (it is the cable's, from its "
                                          "fatigue tests); or give it as a table (sn_file)")
    method = deck["fatigue.mean_stress"]
    if method in ("goodman", "gerber") and not deck.has("fatigue.ultimate"):
        deck.fail("fatigue", "ultimate", f"is required with mean_stress = '{method}': the ultimate value S_u of the "
                                         f"{deck['fatigue.sn_quantity']} (its strain or moment at break)")
    if deck["design.parameters"] is not None:
        # The flight and dynamic sensitivities differentiate Basquin's damage of the uncorrected
        # amplitudes (pydriver/analyses/flight_sensitivities.py).
        if method != "none":
            deck.fail("fatigue", "mean_stress", "the design sensitivities of the damage hold no mean-stress "
                                                "correction: mean_stress = 'none' with &design parameters")
        if deck["fatigue.sn_file"]:
            deck.fail("fatigue", "sn_file", "the design sensitivities of the damage need Basquin's S-N curve "
                                            "(sn_exponent, sn_reference_amplitude, sn_reference_cycles)")


def _limits(deck: Deck):
    if deck.has("limits.fatigue_life_hours") and "fatigue" not in deck.groups:
        deck.fail("limits", "fatigue_life_hours", "needs &fatigue: without an S-N curve no life is computed to "
                                                  "judge against it")


def _resonance(deck: Deck):
    """Blade-passage excitation needs at least one multiple of the blade count among the
    harmonics checked (a Campbell deck's own harmonics unless &resonance sets them)."""
    if deck["resonance.excitation"] != "blade_passage":
        return
    group = "campbell" if analysis_of(deck).sweeps_speed and not deck.has("resonance.harmonics") else "resonance"
    top, blades = int(deck[f"{group}.harmonics"]), int(deck["resonance.blades"])
    if top < blades:
        deck.fail(group, "harmonics", f"= {top} is below &resonance blades = {blades}: with excitation = "
                                      "'blade_passage' no harmonic would be checked (the first is the blade count)")


def _refinement(deck: Deck):
    if deck["refinement.levels"] == 1:
        return
    if "cable" not in deck.groups:
        deck.fail("refinement", "levels", "refining n needs the physical cable parameters (&cable ei, ...), not the thesis's per-joint constants")
    if deck.has("chain.body_length"):
        deck.fail("chain", "body_length", "refinement subdivides a uniform chain: give total_length")


def _analysis_rules(deck: Deck):
    """The deck's analysis's own rules, where its registry row names them (a usage spectrum's
    &spectrum: pydriver.usage_spectrum.check)."""
    analysis_of(deck).check_deck(deck)
