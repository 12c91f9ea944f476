"""The model's workspace has no order rules (issue 23 item 2): the frames, motion, forces and
joint wrenches every evaluation shares are recorded with the state they belong to
(src_fortran/model.f90, model%ws), and a routine that reads them names its state and evaluates
it unless the workspace holds it.  So what a routine returns does not depend on what was
evaluated before it, to the bit, and a parameter update leaves nothing stale."""

from __future__ import annotations

import re

import numpy as np

import pydriver
from pydriver import core_probes as probes
from conftest import INPUTS, ROOT
from test_analytic_jacobian import _random_state


def test_the_tangent_does_not_depend_on_what_was_evaluated_before():
    """A tangent sweep about (y, y') is the same bits after a residual at another state (the
    base point is evaluated by the sweep) as after a residual at (y, y') itself."""
    m = pydriver.Model.from_deck(INPUTS / "uh60_part2_forward_flight_cable.nml")
    t, y, yd = _random_state(m, 7)
    _, y2, yd2 = _random_state(m, 8)
    dy = np.random.default_rng(9).standard_normal(len(y))
    probes.ggl_residual(m.core, y, yd, t=t)
    after_same = probes.residual_tangent(m.core, y, yd, dy, 3.0 * dy, t=t)
    probes.ggl_residual(m.core, y2, yd2, t=t + 0.01)
    after_other = probes.residual_tangent(m.core, y, yd, dy, 3.0 * dy, t=t)
    assert np.array_equal(after_same, after_other)
    # After a tangent at another state: the loads' linearisation (the rotation springs keep
    # their trigonometry for the columns of one state) belongs to that state, and is redone.
    probes.residual_tangent(m.core, y2, yd2, dy, 3.0 * dy, t=t + 0.01)
    after_other_tangent = probes.residual_tangent(m.core, y, yd, dy, 3.0 * dy, t=t)
    assert np.array_equal(after_same, after_other_tangent)


def test_samples_do_not_depend_on_what_was_evaluated_before():
    """Joint loads, shapes and energies of a sample are the same bits whatever the workspace held."""
    m = pydriver.Model.from_deck(INPUTS / "uh60_part2_forward_flight.nml")
    t, y, yd = _random_state(m, 3)
    q, v = y[:m.nq, None], y[m.nq:2 * m.nq, None]
    first = m.core.sample([t], q, v)
    probes.ggl_residual(m.core, *_random_state(m, 4)[1:], t=0.02)
    m.core.static_system(y[:m.nq] + 0.01, np.zeros(m.nc), t=t, jacobian=True)
    again = m.core.sample([t], q, v)
    for name, value in vars(first).items():
        if name == "wrenches":
            value, other = value.as_flat(), again.wrenches.as_flat()
        else:
            other = getattr(again, name)
        assert np.array_equal(value, other, equal_nan=True), name


def test_an_update_leaves_nothing_stale_in_the_workspace():
    """After a spring update at the same state, the tangent is the rebuilt model's, not one
    reusing the forces of the old springs."""
    m = pydriver.Model.from_deck(INPUTS / "six_link_dynamic.nml")
    stiffer = m.with_changes({"springs.c_beta": 3.0})
    t, y, yd = _random_state(m, 2)
    dy = np.random.default_rng(3).standard_normal(len(y))
    before = probes.residual_tangent(m.core, y, yd, dy, dy, t=t)
    m.core.update("springs.stiffness", stiffer.description["stiffness"])
    after = probes.residual_tangent(m.core, y, yd, dy, dy, t=t)
    assert not np.array_equal(before, after)
    assert np.array_equal(after, probes.residual_tangent(stiffer.core, y, yd, dy, dy, t=t))


def test_no_routine_trusts_its_caller_for_the_workspace():
    """No 'frames_current' flag and no 'must hold the state of ...' rule remain in the core."""
    for path in sorted((ROOT / "src_fortran").rglob("*.f90")):
        text = path.read_text()
        assert "frames_current" not in text, path.name
        assert not re.search(r"must hold the state|after sample_state|frames of q must be current", text), path.name
