"""The monodromy matrix of a periodic run (issue 21, item 3): tangent integration (state and
forward sensitivities as one DAE with IDA, the analytic sensitivity residual), in the independent
coordinates x = (a, b) on the constraint manifold, checked against central differences of whole
one-period integrations."""

from __future__ import annotations

import numpy as np
import pytest

import pydriver
from conftest import INPUTS
from pydriver.analyses.flight import rotor_period
from pydriver.analyses.statics import equilibrium
from pydriver.deckfile import read_deck

CABLE = INPUTS / "uh60_part2_forward_flight_cable.nml"
#: The difference quotients' reference integrations: tight, so that their error over a period
#: (~1e-9 in x) divided by the step EPS stays near 1e-6.
TIGHT = {"rtol": 1.0e-10, "atol": 1.0e-12}
#: Step of the central differences in x (rad, rad/s).  Measured on the n = 11 cable: the
#: disagreement falls as 1/EPS (5.9e-5, 8.7e-6, 4.2e-6, 1.3e-6 at 3e-5, 1e-4, 3e-4, 1e-3), so it is
#: the differences' integration noise, and their truncation error (EPS^2) is not yet visible at
#: 1e-3: that EPS is used and the bound is 1e-5, eight times the measured 1.3e-6.
EPS = 1.0e-3
BOUND = 1.0e-5


def model_of(changes: dict, drop: tuple = ()) -> pydriver.Model:
    deck = read_deck(CABLE)
    for group in drop:                        # a group left out of the deck
        deck.raw.pop(group, None)
    # The blade azimuth the measurements below were taken at (clamp B's, the default before
    # issue 21's pitch-axis convention).  At the new default (270 deg) the tight reference
    # integrations (atol 1e-12) fail at their first step from the perturbed starts, an IDA start
    # problem at that tolerance, not one of the monodromy (noted in the issue).
    deck = deck.with_values({"refinement.levels": 1, "blade.azimuth0_deg": 278.9004, **changes})
    deck.name = "monodromy.nml"
    return pydriver.Model(deck)


def check_against_differences(model, rtol: float, n_dirs: int = 4) -> float:
    """Largest error of Phi d against central differences along n_dirs random unit directions d
    of x (each a whole one-period integration from the two perturbed starts), relative to
    ||Phi||_2: normwise, the measure that bounds the error of the multipliers and of a Newton
    step (a heavily damped Phi maps some directions to almost nothing, where a per-direction
    ratio would measure only the differences' noise)."""
    period = rotor_period(model)
    q0, _, _ = equilibrium(model, t=0.0)
    tight = dict(model.solver_settings(), **TIGHT)
    start = model.core.start(tight, 0.0, q0, np.zeros_like(q0))
    qs, vs = start.q0, start.v0
    start.close()
    mono = model.core.monodromy(dict(model.solver_settings(), rtol=rtol, atol=rtol * 1e-2), 0.0, qs, vs, [period])
    phi, basis = mono["phi"], mono["basis"]
    nf = basis.shape[1]
    assert phi.shape == (2 * nf, 2 * nf) and nf == model.nq - model.nc
    assert np.max(np.abs(mono["q0"] - qs)) < 1e-12            # the start was consistent already
    # Issue 39: all the columns are evaluated once a Newton iteration, at the state's update
    # (rotorcable_monodromy's tangent_ls_solve), not also with every residual (then twice as
    # often: 4850 against 2425 on the main job's cable).
    stats = mono["stats"]
    assert 0 < stats["sensitivity_residual_evals"] <= stats["residual_evals"], stats

    def x_end(d):
        # The start is projected onto the manifold (minimum-norm steps), the chart of the
        # monodromy to first order: s_v = N b - G^+ H N a.
        s = model.core.start(tight, 0.0, qs + basis @ d[:nf], vs + basis @ d[nf:])
        q, v = s.advance([period])
        s.close()
        return np.concatenate([basis.T @ (q[:, -1] - qs), basis.T @ (v[:, -1] - vs)])

    rng = np.random.default_rng(21)
    worst = 0.0
    for _ in range(n_dirs):
        d = rng.standard_normal(2 * nf)
        d /= np.linalg.norm(d)
        fd = (x_end(EPS * d) - x_end(-EPS * d)) / (2.0 * EPS)
        worst = max(worst, np.linalg.norm(phi @ d - fd) / np.linalg.norm(phi, 2))
    return worst


def test_monodromy_of_the_flight_cable_agrees_with_differences():
    """n = 11 xyz cable of the main job (6 clamp rows, 54 sensitivities), monodromy at rtol 1e-8."""
    model = model_of({})
    assert model.nc == 6
    assert check_against_differences(model, 1.0e-8) < BOUND


def test_monodromy_of_a_free_chain_agrees_with_differences():
    """The same cable with a free end (no clamp B: nc = 0, N = I), 4 bodies, in the turning hub
    frame and the stream, its clamp A on the flapping, lagging and pitching blade."""
    model = model_of({"clamp_b.active": False, "chain.n_bodies": 4, "shape.gamma_deg": [0.0, 90.0, 0.0, 0.0],
                      "shape.beta_deg": [0.0, 12.0, 12.0, 12.0], "blade.flap_deg": [0.0, 3.0, 1.0], "blade.lag_deg": [0.0, 1.0],
                      "blade.pitch_deg": [0.0],
                      "clamp_a.moves_with": "blade"}, drop=("clamp_b",))
    assert model.nc == 0
    assert check_against_differences(model, 1.0e-8) < BOUND


def test_monodromy_refuses_a_pulse_within_the_period():
    """A pulse makes the run non-periodic: the monodromy is refused with a message, not computed
    across the load's jump."""
    model = model_of({"loads.pulse_body": 3, "loads.pulse_force": [1.0, 0.0, 0.0], "loads.pulse_start": 0.01,
                      "loads.pulse_end": 0.02})
    q0, _, _ = equilibrium(model, t=0.0)
    with pytest.raises(pydriver.RunError, match="switch times"):
        model.core.monodromy(model.solver_settings(), 0.0, q0, np.zeros_like(q0), [rotor_period(model)])
