"""The life over a usage spectrum as a design objective (``&design objective =
'max_spectrum_damage_per_hour'``; issue 38, item 6; docs/model.md, "Design optimisation"): the
spectrum's damage per flight hour at every joint's worst point, with its exact gradient.

A design deck with this objective is a spectrum deck (a flight deck with ``&spectrum``,
:mod:`pydriver.usage_spectrum`) whose ``&case analysis`` is ``'design'``.  One evaluation at the
parameters p is the spectrum at the deck's n (:func:`spectrum_deck`, one refinement level): every
regime's flight to its periodic revolution and the run-up, run as ``analysis = 'spectrum'`` runs
them, combined by :func:`pydriver.analyses.spectrum_damage.level_damage` into the damage per flight
hour D at every jacket point, then the sensitivities of every run
(:func:`pydriver.analyses.flight_sensitivities.flight_sensitivities` of each regime,
:func:`pydriver.analyses.dynamic_sensitivities.dynamic_sensitivities` of the run-up) at the SAME
points: per joint j the point P_j around its jacket where the combined D is largest (the first of
equal ones, as the spectrum's hotspots take it).  The objective's terms are D(P_j) over the joints
(``spectrum_damage_per_hour{j}``); their largest is the spectrum's damage per flight hour at its
worst point, 1 / its life.

With the cycle sets, the extremes' samples and the points P_j held (as a flight's damage
sensitivity holds them; a change of any is a kink of D), every term of

    D = sum_r s_r d_r + F g + F S 2 c + F (S - 1) g0

is a smooth function of quantities whose sensitivities the runs give:

* d_r, a regime's damage per hour at P_j: ``damage_per_hour{j}`` of its flight sensitivities;
* g = (S_a / S_ref)^m / N_ref, the ground-air-ground cycle of amplitude S_a = (hi - lo) / 2,
  lo and hi the smallest and largest of every regime's extremes at P_j (``jacket_min{j}``,
  ``jacket_max{j}``, at their samples), the rest value (the run-up's first sample,
  ``jacket_first{j}``: the equilibrium, differentiated by the implicit function theorem) and the
  run-up's extremes: dg = m g / S_a (dhi - dlo) / 2, with dlo and dhi those of the run or sample
  that holds the end (a tie between two is a kink);
* c, the damage of the run-up's closed cycles (``closed_damage_per_hour{j}`` per record), and g0,
  the ground cycle from the rest value and the run-up's extremes, alike.

So the gradient is exact between changes of those selections: no stated approximation is needed
(``tests/test_spectrum_design.py`` holds it to central differences of whole spectrum runs).
Every parameter must enter each run as it is or not at all (:func:`parameter_roles`): a regime
that sets the key itself (its forward speed, a blade table) or the run-up (no forward speed, the
blade in its installed pose) does not depend on it, and its gradient there is zero; a key the
regimes scale (gravity under a load factor other than 1) is refused.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pydriver.analyses.dynamic_sensitivities import dynamic_sensitivities
from pydriver.analyses.fatigue_loads import mean_stress, sn_curve
from pydriver.analyses.flight import flight_analysis
from pydriver.analyses.flight_sensitivities import flight_sensitivities
from pydriver.analyses.hover_modes import hover_modes, require_periodic_reachable
from pydriver.analyses.sensitivities import plan
from pydriver.analyses.spectrum_damage import cycle_damage, level_damage
from pydriver.analyses.spectrum_records import regime_result
from pydriver.deckfile import Deck, validate
from pydriver.errors import DeckError
from pydriver.model import Model
from pydriver.progress import stage
from pydriver.usage_spectrum import base_flight_deck, spectrum_of

#: The evaluation's values: the spectrum's damage per flight hour at joint j's worst point.
DAMAGE = "spectrum_damage_per_hour"
#: The groups of a design deck that its plain spectrum deck (optimum.nml) does not carry: a
#: spectrum takes no &design (its regimes would each differentiate themselves).
DESIGN_ONLY = ("design",)


def spectrum_deck(deck: Deck) -> Deck:
    """The design deck as the plain spectrum deck it optimises: ``analysis = 'spectrum'``, without
    ``&design`` (``optimum.nml`` is this deck at the optimum)."""
    raw = {g: dict(v) for g, v in deck.raw.items() if g not in DESIGN_ONLY}
    starts = {g: dict(v) for g, v in deck.starts.items() if g not in DESIGN_ONLY}
    raw["case"]["analysis"] = "spectrum"
    starts.get("case", {}).pop("analysis", None)
    out = validate(raw, starts, deck.name)
    out.path = deck.path
    return out


def flight_deck(deck: Deck, parameters: list) -> Deck:
    """The spectrum deck as its base flight deck (the regimes' common base, without their
    changes) with the design parameters: the deck whose hover state the frequency margin judges."""
    return base_flight_deck(deck).with_values({"design.parameters": [p.name for p in parameters]})


@dataclass(frozen=True)
class Roles:
    """Which parameters act in which run of the spectrum (indices into the design's parameters)."""

    regimes: tuple       #: per regime, the parameters its flight deck takes as they are
    runup: tuple         #: the parameters the run-up deck takes as they are


def _value(deck: Deck, par):
    value = deck[f"{par.group}.{par.key}"]
    if value is None:
        return None
    value = np.asarray(value, float)
    return value if par.index is None else value[par.index]


def parameter_roles(deck: Deck, parameters: list, lower, upper, deck_at) -> Roles:
    """Which parameters act in which run: each parameter moved by a small step (``deck_at(p)``: the
    spectrum deck at the parameters p); a run whose deck does not change does not depend on it; a
    run whose deck carries the parameter's new value acts on it as it is.

    Raises
    ------
    DeckError
        Naming ``&design parameters``: a parameter that no run takes (every regime sets the key
        itself), or one a run takes changed (gravity under a load factor).
    """
    p0 = np.array([par.value for par in parameters], float)
    base = spectrum_of(deck_at(p0))
    regimes = [[] for _ in base.regimes]
    runup = []
    for i, par in enumerate(parameters):
        h = 1.0e-3 * (upper[i] - lower[i])
        p1 = p0.copy()
        p1[i] = p0[i] + h if p0[i] + h <= upper[i] else p0[i] - h
        moved = spectrum_of(deck_at(p1))
        runs = [(f"regime '{r.name}'", r.deck, r.text, m.deck, m.text, regimes[k])
                for k, (r, m) in enumerate(zip(base.regimes, moved.regimes))]
        if base.runup is not None:
            runs.append(("the run-up", base.runup, base.runup_text, moved.runup, moved.runup_text, runup))
        acts = False
        for what, before, text, after, text_after, takes in runs:
            if text == text_after:
                continue
            old, new = _value(before, par), _value(after, par)
            if old is None or new is None or not (np.array_equal(old, p0[i]) and np.array_equal(new, p1[i])):
                raise DeckError(deck.name, "design", "parameters",
                                f"'{par.name}' enters {what} of the usage spectrum changed (a load factor scales "
                                "the gravity, ...): a design parameter of a spectrum must enter every regime and "
                                "the run-up as it is, or not at all")
            takes.append(i)
            acts = True
        if not acts:
            raise DeckError(deck.name, "design", "parameters",
                            f"'{par.name}' acts in no regime of the usage spectrum and not in its run-up (each "
                            "regime sets it itself, &spectrum): it cannot be a design parameter of this spectrum")
    return Roles(regimes=tuple(tuple(r) for r in regimes), runup=tuple(runup))


def _with_parameters(deck: Deck, parameters: list, takes: tuple) -> Deck:
    return deck.with_values({"design.parameters": [parameters[i].name for i in takes]})


def _gradients(sens: dict, names: list, takes: tuple, parameters: list, n_par: int) -> dict:
    """{output: full gradient} of ``names``, zero for the parameters the run does not take."""
    table = sens["summary"]["d_output_d_parameter"]
    out = {}
    for name in names:
        g = np.zeros(n_par)
        for i in takes:
            g[i] = table[name][parameters[i].name]
        out[name] = g
    return out


def _basquin_slope(damage: float, amplitude: float, exponent: float) -> float:
    """d(damage)/d(amplitude) of one cycle on Basquin's curve, m D / S_a (0 below the cut-off,
    where the damage is 0)."""
    return exponent * damage / amplitude if damage > 0.0 and amplitude > 0.0 else 0.0


def _cycle(ends_low: list, ends_high: list, damage: float, exponent: float, n_par: int) -> np.ndarray:
    """The gradient of one cycle's damage between the lowest of ``ends_low`` and the highest of
    ``ends_high`` ((value, gradient) each; the first of equal ones holds the end)."""
    lo = min(ends_low, key=lambda e: e[0])
    hi = max(ends_high, key=lambda e: e[0])
    amplitude = 0.5 * (hi[0] - lo[0])
    if amplitude <= 0.0:
        return np.zeros(n_par)
    return _basquin_slope(damage, amplitude, exponent) * 0.5 * (hi[1] - lo[1])


def spectrum_sensitivities(deck: Deck, parameters: list, roles: Roles) -> tuple[dict, dict, dict]:
    """(values, gradients, details) of the spectrum ``deck`` at its n (module doc).

    Parameters
    ----------
    deck : Deck
        The plain spectrum deck at the design (:func:`spectrum_deck`), one refinement level.
    parameters : list of pydriver.design.Parameter
        The design's parameters, in its order.
    roles : Roles
        Which runs take which parameters (:func:`parameter_roles`).

    Returns
    -------
    values : dict
        ``spectrum_damage_per_hour{j}`` per joint j [1/h].
    gradients : dict
        Their gradients, one entry per parameter.
    details : dict
        The worst point and each regime's, the GAG cycles' and the start-stops' share of the
        damage there (the design report's before and after).
    """
    spec = spectrum_of(deck)
    n_par = len(parameters)
    runs = []
    for k, regime in enumerate(spec.regimes):
        with stage(f"regime '{regime.name}' ({k + 1} of {len(spec.regimes)})"):
            # The regime's flight as the spectrum runs it (pydriver.analyses.flight.flight_run):
            # a march that cannot become periodic is refused before it runs.
            model = Model(regime.deck)
            require_periodic_reachable(model, hover_modes(model))
            runs.append(flight_analysis(model))
    runup = None
    if spec.runup is not None:
        with stage("the run-up"):
            runup = regime_result(spec.runup)
    base = base_flight_deck(deck)
    sn, correction = sn_curve(base), mean_stress(base)
    level = level_damage([r.share for r in spec.regimes], [run.extra["fatigue_points"] for run in runs],
                         runup.extra["fatigue_points"] if runup is not None else None, spec.flights_per_hour,
                         spec.start_stops_per_flight, sn, correction)
    joints = np.unique(level.joint)
    first = {int(j): int(np.flatnonzero(level.joint == j)[0]) for j in joints}
    worst_k = [int(np.argmax(level.total[level.joint == j])) for j in joints]
    worst = [first[int(j)] + k for j, k in zip(joints, worst_k)]
    per_joint = [f"{name}{int(j)}" for j in joints for name in
                 ("damage_per_hour", "jacket_max", "jacket_min", "jacket_first", "closed_damage_per_hour")]
    regime_grads = []
    for k, (regime, run) in enumerate(zip(spec.regimes, runs)):
        takes = roles.regimes[k]
        if not takes:
            regime_grads.append({name: np.zeros(n_par) for name in per_joint})
            continue
        with stage(f"regime '{regime.name}': sensitivities"):
            model = Model(_with_parameters(regime.deck, parameters, takes))
            orbit = run.extra["orbit"]
            sens = flight_sensitivities(model, plan(model), orbit["period_s"], orbit, run.timeseries,
                                        worst_points=worst_k, jacket_extremes=True)
        regime_grads.append(_gradients(sens, per_joint, takes, parameters, n_par))
    runup_grads = {name: np.zeros(n_par) for name in per_joint}
    if runup is not None and roles.runup:
        with stage("the run-up: sensitivities"):
            model = Model(_with_parameters(spec.runup, parameters, roles.runup))
            sens = dynamic_sensitivities(model, plan(model), runup.timeseries, worst_points=worst_k,
                                         jacket_extremes=True)
        runup_grads = _gradients(sens, per_joint, roles.runup, parameters, n_par)
    values, gradients = {}, {}
    m = sn.exponent
    F, S = spec.flights_per_hour, spec.start_stops_per_flight
    points = [run.extra["fatigue_points"] for run in runs]
    up = runup.extra["fatigue_points"] if runup is not None else None
    for j, P in zip(joints, worst):
        j = int(j)
        grad = np.zeros(n_par)
        for share, g in zip((r.share for r in spec.regimes), regime_grads):
            grad = grad + share * g[f"damage_per_hour{j}"]
        if up is not None and F > 0.0:
            lows = [(float(pt.minimum[P]), g[f"jacket_min{j}"]) for pt, g in zip(points, regime_grads)]
            highs = [(float(pt.maximum[P]), g[f"jacket_max{j}"]) for pt, g in zip(points, regime_grads)]
            ground_low = [(float(up.first[P]), runup_grads[f"jacket_first{j}"]),
                          (float(up.minimum[P]), runup_grads[f"jacket_min{j}"])]
            ground_high = [(float(up.first[P]), runup_grads[f"jacket_first{j}"]),
                           (float(up.maximum[P]), runup_grads[f"jacket_max{j}"])]
            # The GAG cycle: level_damage takes the regimes' extremes first, then rest and run-up.
            grad = grad + F * _cycle(lows + ground_low, highs + ground_high, float(level.gag[P]) / F, m, n_par)
            closed = runup_grads[f"closed_damage_per_hour{j}"] / up.per_hour
            grad = grad + F * S * 2.0 * closed
            if S > 1.0:
                lo0, hi0 = min(e[0] for e in ground_low), max(e[0] for e in ground_high)
                g0 = float(cycle_damage(np.array([lo0]), np.array([hi0]), sn, correction)[0])
                grad = grad + F * (S - 1.0) * _cycle(ground_low, ground_high, g0, m, n_par)
        values[f"{DAMAGE}{j}"] = float(level.total[P])
        gradients[f"{DAMAGE}{j}"] = grad
    w = level.worst
    total = float(level.total[w])

    def share(x: float) -> float:
        return x / total if total > 0.0 else 0.0

    details = {"worst_point": {"joint": int(level.joint[w]), "angle_deg": float(level.angle_deg[w])},
               "damage_per_flight_hour": total,
               "damage_shares": {**{r.name: share(float(level.regimes[i][w])) for i, r in enumerate(spec.regimes)},
                                 "ground-air-ground": share(float(level.gag[w])),
                                 "start-stops": share(float(level.start_stops[w]))}}
    return values, gradients, details
