"""A flight march that cannot reach its periodic state is refused before it runs (issue 35).

An undamped refined flight (``&cable damping_time = 0``) had run for minutes and then failed at
its step budget; the design deck without damping was still running after 300 s.  The hover modes
(which a flight computes anyway) say how many revolutions the march needs
(:func:`pydriver.analyses.hover_modes.revolutions_needed`); beyond ``max_revolutions`` the run is
a DeckError naming the mode and what to change.
"""

from __future__ import annotations

import pytest

from conftest import INPUTS
from pydriver.analyses import run
from pydriver.analyses.hover_modes import hover_modes, revolutions_needed
from pydriver.errors import DeckError
from pydriver.model import Model


@pytest.mark.parametrize("stem", ["uh60_part2_forward_flight", "uh60_part2_forward_flight_cable"])
def test_the_estimate_brackets_the_revolutions_a_march_takes(stem):
    """The estimate against the march itself on the shipped flight decks (5.5 against 5, 7.4 against
    6 revolutions): never short by more than one revolution (it would refuse a march that ends)
    and at most twice the march (it only has to tell thousands from tens)."""
    model = Model.from_deck(INPUTS / f"{stem}.nml").with_changes({"refinement.levels": 1,
                                                                  "solver.error_estimate": False})
    estimate, _ = revolutions_needed(model, hover_modes(model))
    taken = run(model).summary["revolutions"]
    assert taken - 1 <= estimate <= 2 * taken


@pytest.mark.parametrize("stem", ["uh60_part2_forward_flight_cable", "uh60_part2_design_flight"])
def test_an_undamped_flight_is_refused_before_it_marches(stem):
    """Refused from the hover modes (a DeckError naming max_revolutions and the damping), where a
    march would have ended in a RunError at its step budget minutes later."""
    model = Model.from_deck(INPUTS / f"{stem}.nml").with_changes({"cable.damping_time": 0.0})
    with pytest.raises(DeckError, match=r"max_revolutions.*damped only.*add damping"):
        run(model)
