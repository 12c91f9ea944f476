"""The design parameters of a deck (``&design parameters``): names, values and difference steps.

A parameter names a real deck key the schema marks ``differentiable`` (:mod:`pydriver.schema`):

* ``'group.key'``: a scalar key, or every element of a per-body / per-joint key moved
  together (the deck must then give one value for all of them);
* ``'group.key(i)'``: element i (from 1) of an array key (``clamp_b.position(1)``).

This module only reads the deck; the sensitivities themselves are computed in
:mod:`pydriver.analyses.sensitivities`.  Every refusal is the deck's
:class:`~pydriver.errors.DeckError` naming ``&design`` key ``parameters`` and the reason.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from pydriver.analyses.registry import ANALYSES as REGISTERED
from pydriver.deckfile import Deck
from pydriver.errors import DeckError
from pydriver.schema import GROUPS, lookup

#: At most this many parameters (each costs two model builds and two residuals).
MAX_PARAMETERS = 64
#: The analyses that take &design parameters: those the registry can differentiate (static, modal,
#: dynamic, flight) and the optimiser built on them (pydriver/analyses/optimiser.py).
ANALYSES = tuple(a.name for a in REGISTERED.values() if a.sensitivities or a.optimises)
#: Relative difference step h = STEP * max(|p|, 1 unit): the cube root of the machine epsilon,
#: where the O(h^2) truncation of a central difference and its O(eps/h) round-off balance
#: (Nocedal & Wright, Numerical Optimization, 2nd ed., eq. 8.9): both ~1e-11 relative.
STEP = float(np.finfo(float).eps) ** (1.0 / 3.0)

_NAME = re.compile(r"^([a-z_][a-z_0-9]*)\.([a-z_][a-z_0-9]*)(?:\(\s*(\d+)\s*\))?$")


@dataclass(frozen=True)
class Parameter:
    """One design parameter of a deck.

    Attributes
    ----------
    name : str
        As written in the deck, normalised (lower case, no blanks): ``clamp_b.position(1)``.
    group, key : str
        The deck key.
    index : int or None
        0-based element, or None (a scalar, or every element of a per-body/per-joint key).
    unit : str
        The key's unit.
    value : float
        Its value in the deck.
    """

    name: str
    group: str
    key: str
    index: int | None
    unit: str
    value: float

    def changes(self, deck: Deck, value: float) -> dict:
        """The ``{"group.key": value}`` change that sets this parameter to ``value``."""
        dotted = f"{self.group}.{self.key}"
        current = deck[dotted]
        if self.index is None and not isinstance(current, np.ndarray):
            return {dotted: float(value)}
        array = np.array(current, dtype=float)
        if self.index is None:
            array[:] = value
        else:
            array[self.index] = value
        return {dotted: array}


def _fail(deck: Deck, reason: str):
    raise DeckError(deck.name, "design", "parameters", reason)


def parameters(deck: Deck) -> list[Parameter]:
    """The deck's design parameters, checked (empty without ``&design``).

    Raises
    ------
    DeckError
        A name that is not ``group.key`` or ``group.key(i)``, an unknown or non-differentiable key,
        an index out of range, a key without a value in this deck, a repeated name, more than
        ``MAX_PARAMETERS`` names, or an analysis without sensitivities.
    """
    if "design" not in deck.groups:
        return []
    names = deck["design.parameters"]
    if names is None or len(names) == 0:
        _fail(deck, "is required in &design: at least one name, e.g. 'cable.ei' or 'clamp_b.position(1)'")
    if len(names) > MAX_PARAMETERS:
        _fail(deck, f"at most {MAX_PARAMETERS} names, got {len(names)}")
    analysis = deck["case.analysis"]
    if analysis not in ANALYSES:
        _fail(deck, f"sensitivities are computed for analysis = {' or '.join(repr(a) for a in ANALYSES)} in "
                    f"this version, not '{analysis}'")
    out, seen = [], set()
    for raw in names:
        p = _parameter(deck, str(raw))
        if p.name in seen:
            _fail(deck, f"'{p.name}' is named twice")
        seen.add(p.name)
        out.append(p)
    return out


def _parameter(deck: Deck, raw: str) -> Parameter:
    text = re.sub(r"\s+", "", raw).lower()
    m = _NAME.match(text)
    if not m:
        _fail(deck, f"'{raw}' is not a key name: write 'group.key' or 'group.key(i)', e.g. 'cable.ei', "
                    "'clamp_b.position(1)'")
    group, name, index = m.group(1), m.group(2), m.group(3)
    key = lookup(group, name)
    if key is None:
        where = f"&{group} has no key '{name}'" if group in GROUPS else f"there is no group &{group}"
        _fail(deck, f"'{raw}': {where}")
    if not key.differentiable:
        allowed = ", ".join(f"{k.group}.{k.name}" for keys in GROUPS.values() for k in keys.values()
                            if k.differentiable)
        _fail(deck, f"'{raw}' is not differentiable (a start value, a switch or a solver setting); "
                    f"differentiable keys: {allowed}")
    if group == "clamp_b" and (not deck["clamp_b.active"] or deck["clamp_b.from_start"]):
        _fail(deck, f"'{raw}': clamp B is inactive or takes its pose from the start shape (from_start), "
                    "so its keys do not act")
    dotted = f"{group}.{name}"
    value = deck[dotted]
    if value is None or not (deck.has(dotted) or key.default is not None):
        _fail(deck, f"'{raw}': {dotted} has no value in this deck (it is neither given nor has a default)")
    if group in ("springs",) and deck.has("cable.ei") and name.startswith(("c_", "d_")):
        _fail(deck, f"'{raw}': this deck derives the joint constants from &cable (ei, gj, damping_time); "
                    "differentiate by those")
    if index is not None:
        if not key.is_array:
            _fail(deck, f"'{raw}': {dotted} is not an array (no index)")
        i = int(index)
        if key.shape in ("body", "joint") and deck["refinement.levels"] > 1:
            _fail(deck, f"'{raw}': element {i} of a per-{key.shape} key is another part of the cable at each "
                        "refinement level; with &refinement levels > 1 name the whole key (one value for all)")
        size = len(value)
        if not 1 <= i <= size:
            _fail(deck, f"'{raw}': index {i} is out of range 1 ... {size}")
        return Parameter(f"{dotted}({i})", group, name, i - 1, key.unit, float(value[i - 1]))
    if key.is_array:
        arr = np.asarray(value, float)
        if key.shape not in ("body", "joint"):
            _fail(deck, f"'{raw}': {dotted} has {arr.size} values; name one element, e.g. '{dotted}(1)'")
        if np.any(arr != arr[0]):
            _fail(deck, f"'{raw}': {dotted} differs between elements; name one element, e.g. '{dotted}(1)'")
        return Parameter(dotted, group, name, None, key.unit, float(arr[0]))
    return Parameter(dotted, group, name, None, key.unit, float(value))


def step(p: Parameter) -> float:
    """The difference step of a parameter: STEP relative to its value, or to 1 of its unit at 0."""
    return STEP * max(abs(p.value), 1.0)


def ratio_unit(out_unit: str, par_unit: str) -> str:
    """The unit of d(output)/d(parameter): ``'N'``, ``'m'`` -> ``'N/m'``; ``'N'``, ``'N m^2'`` ->
    ``'N/(N m^2)'``; a dimensionless parameter keeps the output's unit."""
    if par_unit in ("-", ""):
        return out_unit
    if any(c in par_unit for c in " /^*"):
        par_unit = f"({par_unit})"
    return f"{'1' if out_unit in ('-', '') else out_unit}/{par_unit}"
