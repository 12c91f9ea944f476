"""Energy conservation with the dampers off (issue 2): drift < 1e-6 relative at rtol = 1e-10."""

import numpy as np
import pytest

import pydriver


@pytest.mark.parametrize("stem", ["three_body", "six_link_dynamic"])
def test_energy_drift_without_dampers(deck_copy, stem):
    p = deck_copy(stem, "springs", {"d_gamma": "0.0", "d_beta": "0.0"})
    from conftest import edit_deck
    edit_deck(p, p, "solver", {"rtol": "1.0e-10", "atol": "1.0e-12"})
    res = pydriver.run_deck(p)
    e = res.extra["energy"]
    # Total energy = kinetic + gravity + springs; the swing exchanges ~|E| between kinetic
    # and potential, so a drift of 1e-6 |E| is far above a correct integrator at rtol 1e-10
    # (measured ~1e-9) and far below any missing or mis-signed force term (~1e-2).
    drift = np.max(np.abs(e - e[0])) / abs(e[0])
    assert drift < 1e-6
    # The motion is real: kinetic energy is exchanged, i.e. the test is not trivially static.
    assert np.ptp(res.timeseries[f"z{res.summary['n_bodies'] - 1}"]) > 1e-3


def test_damping_dissipates(deck_copy):
    # With the thesis's dampers the energy falls monotonically (to integration noise).
    res = pydriver.run_deck(deck_copy("six_link_dynamic"))
    e = res.extra["energy"]
    assert e[-1] < e[0] - 1.0
    assert np.all(np.diff(e) < 1e-6 * abs(e[0]))
