"""Aerodynamic drag by the cross-flow principle (issue 11): one new load in one new file
(src_fortran/loads/drag.f90), checked against a closed form."""

from __future__ import annotations

import numpy as np
import pytest

import pydriver
from pydriver.deckfile import deck_from_text


def hanging_chain(n: int, v: float) -> pydriver.Model:
    return pydriver.Model(deck_from_text(f"""&case analysis = 'static' /
&chain n_bodies = {n}, total_length = 0.6, diameter = 0.015, total_mass = 0.3, joint = 'xy', first_body = 'pivot' /
&shape gamma_deg = 0.0, beta_deg = 170.0, {n - 1}*0.0 /
&drag air_density = 1.225, cd = 1.2, stream_velocity = {v}, 0.0, 0.0 /""", "drag.nml"))


@pytest.mark.parametrize("n,v", [(1, 8.0), (6, 8.0), (6, 25.0)])
def test_hanging_chain_in_a_steady_stream(n, v):
    """A uniform chain pinned at the top in a horizontal stream V: every body carries its
    weight m g and the cross-flow drag 1/2 rho C_d d L (V cos th)^2 normal to it (u_n = V cos th
    for a body at th from the vertical).  When the drag equals the weight's normal part,
    m g sin th, every body's loads normal to the chain cancel by themselves, so the straight
    chain at sin th / cos^2 th = rho C_d d V^2 / (2 mu g) is the equilibrium, for any n.
    Newton's tolerance gives every body's angle to 1e-9 rad."""
    res = pydriver.run_deck(hanging_chain(n, v))
    t = res.table
    joints = np.column_stack([t["joint_x_m"], t["joint_y_m"], t["joint_z_m"]])
    joints = np.vstack([joints, res.summary["tip_m"]])
    e = np.diff(joints, axis=0)
    e /= np.linalg.norm(e, axis=1)[:, None]
    angle = np.arctan2(e[:, 0], -e[:, 2])
    k = 1.225 * 1.2 * 0.015 * v**2 / (2 * 0.5 * 9.81)
    th = np.arcsin((np.sqrt(1 + 4 * k**2) - 1) / (2 * k))      # sin/cos^2 = k, cos^2 = 1 - sin^2
    assert np.max(np.abs(angle - th)) < 1e-9
    assert np.max(np.abs(e[:, 1])) < 1e-12                     # stays in the stream's plane
    # The pivot carries the weight and the total drag.
    drag = 0.5 * 1.225 * 1.2 * 0.015 * 0.6 * (v * np.cos(th))**2
    assert res.summary["reactions"]["A"]["F"][0] == pytest.approx(-drag * np.cos(th), rel=1e-9)
    assert res.summary["reactions"]["A"]["F"][2] == pytest.approx(0.3 * 9.81 - drag * np.sin(th), rel=1e-9)


def test_still_air_and_no_drag_group_are_the_same():
    """Without a stream the drag of a body at rest is zero: the chain hangs straight down."""
    res = pydriver.run_deck(hanging_chain(4, 0.0))
    assert np.max(np.abs(res.table["joint_x_m"])) < 1e-10
