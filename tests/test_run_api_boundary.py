"""The run API's constraint residual and consistent start (issue 23 item 4: what the product
took from the probes now comes from rotorcable_api), checked against the probes they replace,
and what a build without the probes does when one is called anyway."""

import subprocess
import sys

import numpy as np
import pytest

import pydriver
from pydriver import core_probes as probes
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
        assert np.array_equal(g, probes.evaluate(m.core, q, zeros, zeros, np.zeros(m.nc), t)["g"])


@pytest.mark.parametrize("stem", DECKS)
def test_consistent_start_is_the_probes_start(stem):
    m = pydriver.Model.from_deck(INPUTS / f"{stem}.nml")
    q0, v0 = start_state(m)
    s = m.core.consistent_start(q0, v0)
    y, yd = probes.consistent_ggl_state(m.core, q0, v0)
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
    monkeypatch.setattr(probes, "_probes", probes._ProbesAbsent())
    q0, v0 = start_state(m)
    with pytest.raises(probes.ProbesNotBuilt, match="-Dprobes=true"):
        probes.rank_margin(m.core, q0)
    with pytest.raises(probes.ProbesNotBuilt, match="rc_probe_evaluate"):
        probes.evaluate_model(m, q0)
    # The run API does not need them.
    assert np.abs(m.core.constraint_residual(m.core.consistent_start(q0, v0)["q"])).max() < 1e-10
    assert pydriver.scene(m).n_bodies == m.n_bodies


def test_the_driver_never_imports_the_probes():
    """The probe functions (pydriver.core_probes) are the tests' and benchmarks': running a deck
    of every analysis but the long design study, and loading the command line, the reports, the
    studies and the sweeps, leaves the module unimported (a fresh interpreter, so that this
    suite's own imports do not count)."""
    decks = [str(INPUTS / f"{stem}.nml") for stem in ("six_link_static", "uh60_part2_modal", "six_link_dynamic",
                                                       "uh60_part2_campbell", "uh60_part2_forward_flight")]
    code = ("import sys, pydriver, pydriver.__main__, pydriver.report_html, pydriver.study, pydriver.sweep\n"
            "for deck in sys.argv[1:]:\n"
            "    pydriver.run_deck(deck)\n"
            "loaded = sorted(m for m in sys.modules if m.startswith('pydriver'))\n"
            "assert 'pydriver.core_probes' not in loaded, loaded\n"
            "assert 'pydriver.analyses.campbell' in loaded and 'pydriver.analyses.flight' in loaded, loaded\n")
    done = subprocess.run([sys.executable, "-c", code, *decks], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
