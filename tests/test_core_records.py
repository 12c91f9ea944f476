"""The named records the compiled core's results come back in (pydriver/core.py, issue 36
item 7): the wrenches' 12 values keep the core's order FA, MA, FB, MB (REACTION_NAMES, the
columns of every run) through :class:`Wrenches`, and the statistics' names are the summary's."""

from __future__ import annotations

import numpy as np

import pydriver
from conftest import INPUTS
from pydriver.analyses.common import REACTION_NAMES
from pydriver.core import STATIC_STATS, Wrenches


def test_wrenches_keep_the_order_of_the_reaction_names():
    # Two samples of 12 distinct values: each field must hold the columns of its own names,
    # and the flat form must give the core's array back exactly (slicing and joining only).
    flat = np.arange(24.0).reshape(2, 12)
    record = Wrenches.from_flat(flat)
    assert np.array_equal(record.as_flat(), flat)
    one = record.at(1)
    named = dict(zip(REACTION_NAMES, flat[1]))
    for field, prefix in (("force_a", "FA"), ("moment_a", "MA"), ("force_b", "FB"), ("moment_b", "MB")):
        assert list(getattr(one, field)) == [named[f"{prefix}_{c}"] for c in "xyz"], field


def test_a_static_runs_reactions_and_solver_statistics_by_name():
    # The summary's reactions are the sample's wrenches by name (exactly: the same doubles), and
    # its solver block is named by STATIC_STATS in that order.
    result = pydriver.run_deck(INPUTS / "six_link_static.nml")
    model = pydriver.Model.from_deck(INPUTS / "six_link_static.nml")
    q = result.extra["q"]
    w = model.core.sample([0.0], q[:, None], np.zeros((model.nq, 1))).wrenches.at(0)
    reactions = result.summary["reactions"]
    assert reactions["A"]["F"] == list(w.force_a) and reactions["A"]["M"] == list(w.moment_a)
    assert reactions["B"]["F"] == list(w.force_b) and reactions["B"]["M"] == list(w.moment_b)
    assert list(result.summary["solver"]) == list(STATIC_STATS)
