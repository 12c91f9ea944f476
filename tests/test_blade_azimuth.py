"""The blade azimuth psi_b = 0 is the blade's own (issue 21 item 5): that of its pitch axis in
the rotor plane, pointing away from the rotor centre; ``azimuth0_deg`` overrides it."""

from __future__ import annotations

import numpy as np
import pytest

import pydriver
from conftest import INPUTS

FF = INPUTS / "uh60_part2_forward_flight_cable.nml"


def test_default_azimuth_is_the_pitch_axis():
    """Main job: pitch axis +y, rotor centre at y = -0.598 m behind the hinge at y = -0.217 m, so
    the blade points along +y: 90 deg from +x, i.e. 270 deg from downstream (-x) in the sense of
    rotation.  Clamp B's azimuth, the old default, is 8.9 deg further."""
    m = pydriver.Model.from_deck(FF)
    assert np.degrees(m.description["rotor"]["azimuth0"]) == pytest.approx(270.0, abs=1e-12)
    u = np.asarray(m.deck["clamp_b.position"][:2]) - np.asarray(m.deck["rotor.centre"][:2])
    old = np.degrees(np.mod(np.arctan2(u[1], u[0]) - np.pi, 2 * np.pi))
    assert old - 270.0 == pytest.approx(8.9, abs=0.05)


def test_pitch_axis_pointing_inwards_gives_the_same_azimuth():
    a = pydriver.Model.from_deck(FF).with_changes({"blade.pitch_axis": [0.0, -1.0, 0.0]})
    assert np.degrees(a.description["rotor"]["azimuth0"]) == pytest.approx(270.0, abs=1e-12)


def test_azimuth0_deg_overrides_and_reproduces_the_default():
    """Giving the default explicitly changes nothing (the same description to the bit)."""
    base = pydriver.Model.from_deck(FF)
    same = base.with_changes({"blade.azimuth0_deg": 270.0})
    other = base.with_changes({"blade.azimuth0_deg": 278.9})
    assert same.description["rotor"]["azimuth0"] == base.description["rotor"]["azimuth0"]
    assert np.degrees(other.description["rotor"]["azimuth0"]) == pytest.approx(278.9, abs=1e-12)
