"""pydriver.scene derived from the model as built (issue 23 item 3): the loads and support B by
name from their component-registry blocks, the rotor speed by name from the core, and what the
scene cannot describe refused with a DeckError naming the deck and the component, never dropped
(before, drag and the rotation-vector springs were dropped silently and Omega was the rotor
profile's first number by position)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import pydriver
from conftest import INPUTS
from pydriver.deckfile import deck_from_text
from pydriver.errors import DeckError
from pydriver.motions import RPM
from test_ball_support import ball_deck

SIX_LINK = (INPUTS / "six_link_dynamic.nml").read_text()


def with_drag(text: str = SIX_LINK) -> pydriver.Model:
    """The six-link dynamic chain in a 10 m/s cross-flow (&drag)."""
    return pydriver.Model(deck_from_text(text + "&drag\n  forward_speed = 10.0\n/\n", "six_link_drag.nml"))


def test_a_deck_with_drag_is_refused_naming_deck_and_load():
    with pytest.raises(DeckError, match=r"six_link_drag\.nml.*&drag.*cannot represent the load 'drag'"
                                        r".*ignore=\('drag',\)") as err:
        pydriver.scene(with_drag())
    assert err.value.group == "drag"


def test_ignoring_drag_is_the_scene_without_it():
    """The caller states the opt-out; the scene is then that of the deck without &drag, field by
    field (the start state included: drag of a chain at rest is zero), and says what it left."""
    ignored = pydriver.scene(with_drag(), ignore=("drag",))
    plain = pydriver.scene(pydriver.Model(deck_from_text(SIX_LINK, "six_link_drag.nml")))
    assert ignored.ignored == ("drag",) and plain.ignored == ()
    for f in dataclasses.fields(plain):
        if f.name != "ignored":
            assert np.array_equal(np.asarray(getattr(ignored, f.name)), np.asarray(getattr(plain, f.name))), f.name


def test_an_ignore_that_names_no_load_is_an_error():
    with pytest.raises(ValueError, match="names no load of the registry"):
        pydriver.scene(INPUTS / "six_link_static.nml", ignore=("dreg",))


def test_rotation_vector_springs_are_refused():
    """The physical xyz cable's springs act on each joint's rotation vector, not per coordinate
    as the scene's stiffness does: refused (that deck's moving clamp B is refused too)."""
    with pytest.raises(DeckError, match=r"&cable.*'rotation_springs'"):
        pydriver.scene(INPUTS / "uh60_part2_forward_flight_cable.nml")


def test_ball_b_is_refused(tmp_path):
    path, _ = ball_deck(tmp_path)
    with pytest.raises(DeckError, match=r"ball_static\.nml.*&ball_b.*cannot represent the support 'ball'"):
        pydriver.scene(path)


def test_a_run_up_rotor_is_refused():
    with pytest.raises(DeckError, match=r"&rotor.*profile 'runup'"):
        pydriver.scene(INPUTS / "uh60_part1_runup.nml")


@pytest.mark.parametrize("stem, rpm", [("uh60_part2_hover", 260.0), ("uh60_part2_campbell", 500.0)])
def test_rotor_speed_is_the_decks_rpm(stem, rpm):
    """Omega by name from the model (``rotor.omega``): the deck's rpm times 2 pi / 60, from the
    legacy &loads rotor_rpm and from &rotor rpm alike; the axis through the rotor centre the
    core turns about (&rotor centre, or minus &loads rotor_offset)."""
    m = pydriver.Model.from_deck(INPUTS / f"{stem}.nml")
    sc = pydriver.scene(m)
    assert sc.rotor_omega == pytest.approx(rpm * 2.0 * np.pi / 60.0, rel=1e-15)
    assert np.array_equal(sc.rotor_offset, -np.asarray(m.description["rotor"]["centre"], float))
    if m.deck.has("rotor.centre"):
        assert np.array_equal(sc.rotor_offset, -np.asarray(m.deck["rotor.centre"], float))


def test_rotor_speed_follows_the_model_not_a_position():
    """A model whose speed is updated in place (CoreModel.updated) gives that speed: the scene
    asks the model by name, it does not take a number of the deck's rotor profile."""
    m = pydriver.Model.from_deck(INPUTS / "uh60_part2_hover.nml")
    with m.core.updated({"rotor.omega": 100.0 * RPM}):
        assert pydriver.scene(m).rotor_omega == pytest.approx(100.0 * RPM, rel=1e-15)
    assert pydriver.scene(m).rotor_omega == pytest.approx(260.0 * RPM, rel=1e-15)


def test_loads_come_from_their_registry_blocks():
    """Gravity, the pulse and the joint springs of the decay deck are the blocks the model was
    built with (Model.description['loads'], by parameter name)."""
    m = pydriver.Model.from_deck(INPUTS / "uh60_part2_decay.nml")
    sc, loads = pydriver.scene(m), m.description["loads"]
    assert np.array_equal(sc.gravity, loads["gravity"]["g"])
    assert sc.pulse_body == int(loads["pulse"]["body"][0]) > 0
    assert np.array_equal(sc.pulse_force, loads["pulse"]["force"])
    assert np.array_equal(sc.pulse_window, [loads["pulse"]["t_start"][0], loads["pulse"]["t_end"][0]])
    for name in ("stiffness", "damping", "rest"):
        assert np.array_equal(getattr(sc, name), loads["joint_springs"][name])
