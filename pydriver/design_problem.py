"""The optimisation problem of a design deck (``&case analysis = 'design'``): objective, bounds,
frequency margin and the optimiser's settings, read from ``&design`` and checked.

The parameters themselves are :mod:`pydriver.design`'s; the objectives are the registry of
:mod:`pydriver.design_measures`; the run is :mod:`pydriver.analyses.optimiser`.  Every refusal
is the deck's :class:`~pydriver.errors.DeckError` naming ``&design`` and the key.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pydriver.analyses.registry import ANALYSES, analysis_of
from pydriver.deckfile import Deck
from pydriver.design import Parameter, parameters
from pydriver.design_measures import OBJECTIVES, Measure
from pydriver.errors import DeckError
from pydriver.schema import lookup

#: The &design keys of the optimiser (the rest of &design, ``parameters``, also serves the
#: sensitivities of a static or modal run).
OPTIMISER_KEYS = ("objective", "lower", "upper", "frequency_margin_percent", "starts", "frequency_levels", "method",
                  "max_iterations", "tolerance")
#: The rotor speed sets the harmonics: it cannot be a parameter of a frequency-margin design.
ROTOR_SPEED_KEYS = ("loads.rotor_rpm", "rotor.rpm")


@dataclass(frozen=True)
class Problem:
    """A checked design problem.

    Attributes
    ----------
    parameters : list of Parameter
    lower, upper : numpy.ndarray
        Bounds of each parameter (deck units).
    objective : Measure
    frequency_margin_percent : float or None
        Required margin of every excited mode's damped frequency from the excited k/rev; None: no such
        constraint.
    method : str
        'slsqp' or 'trust-constr'.
    max_iterations : int
    tolerance : float
        On the scaled problem (parameters mapped to [0, 1], objective divided by its start value).
    base_analysis : str
        The analysis of each evaluation and of the optimum deck: 'flight' for a flight objective
        (the frequencies, where the margin needs them, are those of the flight's hover state),
        'spectrum' for the spectrum objective (the frequencies those of its base flight deck's
        hover state), else 'modal' when a frequency is needed, else 'static'.
    starts : int
        The optimiser's starts (:func:`start_points`).
    frequency_levels : int
        Refinement levels of the frequencies the margin judges (1: the deck's n).
    """

    parameters: list
    lower: np.ndarray
    upper: np.ndarray
    objective: Measure
    frequency_margin_percent: float | None
    method: str
    max_iterations: int
    tolerance: float
    base_analysis: str
    starts: int = 3
    frequency_levels: int = 1


def _fail(deck: Deck, key: str, reason: str):
    raise DeckError(deck.name, "design", key, reason)


def problem(deck: Deck) -> Problem | None:
    """The deck's design problem (None unless ``&case analysis = 'design'``).

    Raises
    ------
    DeckError
        An optimiser key on another analysis; a missing objective or bound; bounds of the wrong
        count, reversed, outside the key's range or not holding the deck's value.
    """
    if not analysis_of(deck).optimises:
        for key in OPTIMISER_KEYS:
            if deck.has(f"design.{key}"):
                _fail(deck, key, "is a setting of the optimiser: only with &case analysis = 'design' "
                                 "(a static or modal run takes &design parameters alone, for its sensitivities)")
        return None
    params: list[Parameter] = parameters(deck)
    if not params:
        _fail(deck, "parameters", "is required with analysis = 'design': the deck keys the optimiser varies")
    if deck["design.objective"] is None:
        _fail(deck, "objective", f"is required with analysis = 'design': one of {', '.join(OBJECTIVES)}")
    bounds = {}
    for key in ("lower", "upper"):
        values = deck[f"design.{key}"]
        if values is None:
            _fail(deck, key, f"is required with analysis = 'design': one bound per parameter ({len(params)})")
        if len(values) != len(params):
            _fail(deck, key, f"has {len(values)} values for {len(params)} parameters: give one bound per "
                             "parameter, in the order of &design parameters")
        bounds[key] = np.asarray(values, float)
    lower, upper = bounds["lower"], bounds["upper"]
    for i, p in enumerate(params):
        if not lower[i] < upper[i]:
            _fail(deck, "upper", f"upper({i + 1}) = {upper[i]:g} is not above lower({i + 1}) = {lower[i]:g} "
                                 f"('{p.name}')")
        key = lookup(p.group, p.key)
        for name, b in (("lower", lower[i]), ("upper", upper[i])):
            if b < key.low or b > key.high or (key.low_open and b == key.low):
                _fail(deck, name, f"{name}({i + 1}) = {b:g} is outside the range of {p.group}.{p.key}, "
                                  f"{key.range_text()}")
        if not lower[i] <= p.value <= upper[i]:
            _fail(deck, "lower", f"the deck's value of '{p.name}', {p.value:g}, is outside its bounds "
                                 f"[{lower[i]:g}, {upper[i]:g}]: the optimiser starts from the deck")
    margin = deck["design.frequency_margin_percent"]
    if margin is not None:
        for p in params:
            if f"{p.group}.{p.key}" in ROTOR_SPEED_KEYS:
                _fail(deck, "parameters", f"'{p.name}' sets the harmonics the frequency margin is measured "
                                          "from: it cannot be varied under &design frequency_margin_percent")
    objective = OBJECTIVES[deck["design.objective"]]
    if objective.name == "max_damage_per_hour" and "fatigue" not in deck.groups:
        _fail(deck, "objective", "'max_damage_per_hour' needs the deck's S-N curve: add &fatigue")
    if objective.needs == "spectrum":
        if "spectrum" not in deck.groups:
            _fail(deck, "objective", f"'{objective.name}' needs the deck's usage spectrum: add &spectrum (regimes, "
                                     "share, flights_per_hour; docs/model.md, \"Usage spectrum\")")
        # The spectrum's own rules, through its registry row as a spectrum run applies them (its
        # regimes' decks are made and checked when the design runs, as a spectrum run makes them:
        # pydriver.analyses.spectrum_design.parameter_roles).
        ANALYSES["spectrum"].check_deck(deck)
    levels = int(deck["design.frequency_levels"])
    if levels > 1 and "cable" not in deck.groups:
        _fail(deck, "frequency_levels", f"= {levels} refines the frequencies over n, 2n ...: that needs the "
                                        "physical cable parameters (&cable ei, ...), not per-joint constants")
    needs_modes = objective.needs == "modal" or margin is not None
    base = objective.needs if objective.needs in ("flight", "spectrum") else "modal" if needs_modes else "static"
    return Problem(params, lower, upper, objective, None if margin is None else float(margin),
                   deck["design.method"], int(deck["design.max_iterations"]), float(deck["design.tolerance"]), base,
                   int(deck["design.starts"]), levels)


#: The labels of the optimiser's starts, in the order ``&design starts`` takes them.
START_LABELS = ("deck", "all lower", "all upper")


def start_points(prob: Problem) -> dict:
    """{label: parameter vector} of the optimiser's starts: the deck's values, then the box's
    corner with every parameter at its lower bound, then at its upper bound (``&design
    starts`` of them).

    Why these: a frequency margin splits the box into separate feasible regions, one per gap
    between the forbidden bands, and a gradient method stays in the gap its start lies in.
    Where the frequencies are monotone enough in the parameters (a shorter cable, a clamp
    further out: stiffer), the two corners reach the gaps on either side of the band the deck
    starts in."""
    points = (np.array([p.value for p in prob.parameters], float), prob.lower.copy(), prob.upper.copy())
    return dict(zip(START_LABELS[:prob.starts], points[:prob.starts]))
