"""A deck's model: read once, checked once, built once in the core.

>>> m = Model.from_deck("inputs/uh60_part2_modal.nml")
>>> softer = m.with_changes({"springs.c_beta": 20.0})     # a new model, no text edited

Every analysis (:mod:`pydriver.analyses`) runs on a :class:`Model`.
"""

from __future__ import annotations

from pathlib import Path

from pydriver import assembly, deck_rules
from pydriver.deckfile import Deck, read_deck


class Model:
    """The validated deck and its model in the core.

    Attributes
    ----------
    deck : Deck
        The validated deck values (defaults filled in).
    core : pydriver.core.CoreModel
        The model in the compiled core.
    description : dict
        What was built, as plain numbers (:func:`pydriver.assembly.build`).
    q0, v0 : numpy.ndarray
        The deck's start coordinates [rad] and rates [rad/s] (not yet made consistent).
    """

    def __init__(self, deck: Deck):
        deck_rules.check(deck)
        self.deck = deck
        self.core, self.description = assembly.build(deck)
        self.q0, self.v0 = self.description["q0"], self.description["v0"]

    @classmethod
    def from_deck(cls, path) -> "Model":
        """Read, validate and build the deck at ``path`` (its file is opened once)."""
        return cls(read_deck(path))

    def with_changes(self, changes: dict | None = None, **more) -> "Model":
        """A new model with some deck values changed, e.g. ``{"springs.c_beta": 20.0}``.

        Values are Python values or namelist value texts (``"90.0, 10*0.0"``); they are checked
        by the deck schema and rules exactly like a deck's own values.
        """
        changes = dict(changes or {})
        changes.update({k.replace("__", "."): v for k, v in more.items()})
        return Model(self.deck.with_values(changes))

    @property
    def name(self) -> str:
        """The deck's file name."""
        return self.deck.name

    @property
    def case(self) -> str:
        """The case name (the deck's file stem if it gives none)."""
        return self.deck["case.name"] or Path(self.deck.name).stem

    @property
    def analysis(self) -> str:
        return self.deck["case.analysis"]

    @property
    def n_bodies(self) -> int:
        return self.deck.n_bodies

    @property
    def nq(self) -> int:
        return self.core.nq

    @property
    def nc(self) -> int:
        return self.core.nc

    def solver_settings(self) -> dict:
        """The &solver values the integrator needs."""
        s = self.deck.values["solver"]
        return {k: s[k] for k in ("rtol", "atol", "atol_multiplier", "h_max", "max_steps", "linear_solver",
                                  "jacobian", "jacobian_max_age", "vector_kernels")}
