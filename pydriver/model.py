"""A deck's model: read once, checked once, built once in the core.

>>> m = Model.from_deck("inputs/uh60_part2_modal.nml")
>>> softer = m.with_changes({"springs.c_beta": 20.0})     # a new model, no text edited

Every analysis (:mod:`pydriver.analyses`) runs on a :class:`Model`.
"""

from __future__ import annotations

from pathlib import Path

from pydriver import assembly, deck_rules
from pydriver.components import solver_settings
from pydriver.deckfile import Deck, read_deck

#: ``&solver linear_solver = 'auto'`` uses the O(n) chain solver from this many coordinates on.
AUTO_CHAIN_MIN_COORDS = 32


#: A flight's sensitivity integrations (IDAS with one column per parameter or Krylov direction)
#: with ``'auto'`` take the block solver below this many coordinates.  Every column repeats the
#: per-step work, so the exact matrix's fewer steps pay off to larger chains than for the state
#: alone: measured on the main job's cable with 8 parameters (benchmarks/README.md, "Design
#: sensitivities of a flight"), the sensitivities' wall time with the chain against the block
#: solver (median of 3) at n = 11 (33 coordinates) 0.62 against 0.51 s, n = 22 (66) 1.37
#: against 1.07 s, n = 44 (132) 1.90 against 2.50 s: the crossover lies between 66 and 132.
AUTO_SENSITIVITY_CHAIN_MIN_COORDS = 96


def resolve_linear_solver(choice: str, n_coords: int) -> str:
    """The IDA linear solver for ``&solver linear_solver = choice`` on a model of ``n_coords``
    coordinates: ``'auto'`` is the block solver below ``AUTO_CHAIN_MIN_COORDS`` and the O(n) chain
    solver from there on; any other choice is kept.  Measured (docs/jacobian.md): on small
    chains the block solver's exact matrix saves steps at loose tolerances (UH-60 decay, nq =
    20, rtol 1e-3: 10-17 against 24 ms), from about 30 coordinates the chain solver is faster at
    every tolerance (nq = 38: 8 against 13 ms at rtol 1e-3, 29 against 43 ms at 1e-6; n = 200:
    1.4 against 27 s per simulated second)."""
    if choice != "auto":
        return choice
    return "chain" if n_coords >= AUTO_CHAIN_MIN_COORDS else "block"


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

    def linear_solver(self) -> str:
        """The IDA linear solver a run uses (:func:`resolve_linear_solver` of the deck's)."""
        return resolve_linear_solver(self.deck.values["solver"]["linear_solver"], self.nq)

    def sensitivity_solver_settings(self) -> dict:
        """The &solver values of a flight's sensitivity integrations: the run's, with 'auto'
        resolved for them (:data:`AUTO_SENSITIVITY_CHAIN_MIN_COORDS`); a deck's own choice is kept."""
        choice = self.deck.values["solver"]["linear_solver"]
        if choice == "auto":
            choice = "chain" if self.nq >= AUTO_SENSITIVITY_CHAIN_MIN_COORDS else "block"
        return solver_settings(self.deck, choice)

    def solver_settings(self) -> dict:
        """The &solver values the integrator needs, by the names pydriver.components.SOLVER
        declares ('auto' resolved: :meth:`linear_solver`)."""
        return solver_settings(self.deck, self.linear_solver())
