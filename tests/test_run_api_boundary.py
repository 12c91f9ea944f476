"""The run API's constraint residual and consistent start (issue 23 item 4: what the product
took from the probes now comes from rotorcable_api), checked against the probes they replace,
and what a build without the probes does when one is called anyway."""

import numpy as np
import pytest

import pydriver
from pydriver import core
from pydriver.analyses.dynamics import start_state
from pydriver.errors import RunError

from conftest import INPUTS

# A moving clamp B (blade-carried flap, lead-lag and pitch) and a fixed one.
DECKS = ["uh60_part2_forward_flight_cable", "uh60_part2_decay", "six_link_static"]


@pytest.mark.parametrize("stem", DECKS)
def test_constraint_residual_is_the_probes_g(stem):
    """Same core routine (model.f90 constraint_residual) behind both: equal to the last bit."""
    m = pydriver.Model.from_deck(INPUTS / f"{stem}.nml")
    rng = np.random.default_rng(3)
    zeros = np.zeros(m.nq)
    for t in (0.0, 0.137, 0.5):
        q = start_state(m)[0] + 0.05 * rng.standard_normal(m.nq)
        g = m.core.constraint_residual(q, t)
        assert g.shape == (m.nc,)
        assert np.array_equal(g, m.core.evaluate(q, zeros, zeros, np.zeros(m.nc), t)["g"])


@pytest.mark.parametrize("stem", DECKS)
def test_consistent_start_is_the_probes_start(stem):
    m = pydriver.Model.from_deck(INPUTS / f"{stem}.nml")
    q0, v0 = start_state(m)
    s = m.core.consistent_start(q0, v0)
    y, yd = m.core.consistent_ggl_state(q0, v0)
    nq, nc = m.nq, m.nc
    assert np.array_equal(s["q"], y[:nq]) and np.array_equal(s["v"], y[nq:2 * nq])
    assert np.array_equal(s["vdot"], yd[nq:2 * nq]) and np.array_equal(s["lambda"], y[2 * nq:2 * nq + nc])
    # On the constraints: |g| within the projection's 1e-10 (dae_integrator.f90, consistent_start).
    if nc:
        assert np.abs(m.core.constraint_residual(s["q"])).max() < 1e-10


def test_wrong_sizes_are_refused():
    m = pydriver.Model.from_deck(INPUTS / "six_link_static.nml")
    with pytest.raises(RunError, match="wrong sizes"):
        m.core.constraint_residual(np.zeros(m.nq + 1))


def test_a_probe_without_the_probes_names_the_option(monkeypatch):
    """The product wheel's behaviour (no rotorcable_probes), here by swapping the module out;
    tests/test_packaging.py checks the real wheel."""
    m = pydriver.Model.from_deck(INPUTS / "six_link_static.nml")
    monkeypatch.setattr(core, "_probes", core._ProbesAbsent())
    q0, v0 = start_state(m)
    with pytest.raises(core.ProbesNotBuilt, match="-Dprobes=true"):
        m.core.rank_margin(q0)
    with pytest.raises(core.ProbesNotBuilt, match="rc_probe_evaluate"):
        pydriver.evaluate_model(m, q0)
    # The run API does not need them.
    assert np.abs(m.core.constraint_residual(m.core.consistent_start(q0, v0)["q"])).max() < 1e-10
    assert pydriver.scene(m).n_bodies == m.n_bodies
