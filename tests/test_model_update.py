"""Models that update (issue 23 item 2): a parameter changed in place in a built model gives the
model built with that parameter from its deck.

Every comparison is against a model rebuilt from the changed deck (``Model.with_changes``), in
the same test: residuals, tangent stiffness, equilibria and the linearised (modal) matrices.
The update changes exactly the numbers the rebuild would have put in, and every evaluation
runs the same operations on them, so the two agree bitwise; the tests allow round-off
(REL = 1e-12 relative to each array's size) so that they state what is promised, not how.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import pydriver
from pydriver.analyses import campbell, linear_modes
from pydriver.analyses.statics import equilibrium, static_analysis, unforced
from pydriver.errors import RunError
from pydriver.motions import RPM

INPUTS = Path(__file__).resolve().parents[1] / "inputs"
#: Round-off of a few hundred floating-point operations on numbers of order 1 (the brief's 1e-12).
REL = 1.0e-12


def close(a, b, rel: float = REL) -> bool:
    a, b = np.asarray(a, float), np.asarray(b, float)
    scale = max(float(np.max(np.abs(b))) if b.size else 0.0, 1e-300)
    return a.shape == b.shape and float(np.max(np.abs(a - b), initial=0.0)) <= rel * scale


def same_model(updated, rebuilt, t: float = 0.0) -> None:
    """Equal equilibria from the same start, and equal equations and linearisations there."""
    s = rebuilt.deck.values["solver"]
    q_u, lam_u, _ = updated.core.static(rebuilt.q0, t, s["newton_tol"], s["newton_max_iter"])
    q_r, lam_r, _ = rebuilt.core.static(rebuilt.q0, t, s["newton_tol"], s["newton_max_iter"])
    assert close(q_u, q_r) and close(lam_u, lam_r)
    a = updated.core.static_system(q_r, lam_r, t, jacobian=True)
    b = rebuilt.core.static_system(q_r, lam_r, t, jacobian=True)
    for k in ("residual", "g", "K", "G"):
        assert close(a[k], b[k], rel=REL) or np.max(np.abs(a[k] - b[k]), initial=0.0) < 1e-12, k
    ma, mb = updated.core.modal_matrices(q_r, lam_r, t), rebuilt.core.modal_matrices(q_r, lam_r, t)
    for k in ("M", "M_r", "K_r", "D_r", "basis"):
        assert close(ma[k], mb[k]), k


def test_rotor_speed_update_is_a_rebuild():
    model = pydriver.Model.from_deck(INPUTS / "uh60_part2_campbell.nml")
    for rpm in (0.0, 137.0, 420.0):
        rebuilt = model.with_changes({"rotor.rpm": rpm})
        with model.core.updated({"rotor.omega": rpm * RPM}):
            assert model.core.parameter("rotor.omega")[0] == rpm * RPM
            same_model(model, rebuilt)
    # Left as the deck says after the scope.
    assert model.core.parameter("rotor.omega")[0] == model.deck["rotor.rpm"] * RPM
    same_model(model, model.with_changes({}))


def test_pulse_off_is_the_model_without_pulse():
    model = pydriver.Model.from_deck(INPUTS / "uh60_part2_decay.nml")
    assert model.deck["loads.pulse_start"] <= 0.05 < model.deck["loads.pulse_end"]
    rebuilt = model.with_changes({"loads.pulse_body": 0})
    t = 0.05                                              # inside the pulse
    with unforced(model):
        assert model.core.parameter("loads.pulse")[0] == 0.0
        same_model(model, rebuilt, t=t)
        ref = rebuilt.core.sample([t], model.q0[:, None], np.zeros((model.nq, 1)))
        got = model.core.sample([t], model.q0[:, None], np.zeros((model.nq, 1)))
        assert close(got.wrenches.as_flat(), ref.wrenches.as_flat())
    # On again after the scope: the pulse's force is back in the residual at t.
    assert model.core.parameter("loads.pulse")[0] == 1.0
    on = model.core.static_system(model.q0, np.zeros(model.nc), t)["residual"]
    off = rebuilt.core.static_system(model.q0, np.zeros(model.nc), t)["residual"]
    assert np.max(np.abs(on - off)) > 1e-3


def test_static_analysis_of_a_pulsed_deck_leaves_the_pulse_on():
    """The statics of a pulsed deck run on the caller's model with the pulse off, and the model
    is the pulsed one afterwards (a dynamic run starts from such an equilibrium)."""
    model = pydriver.Model.from_deck(INPUTS / "uh60_part2_decay.nml").with_changes({"case.analysis": "static"})
    res = static_analysis(model)
    ref = static_analysis(model.with_changes({"loads.pulse_body": 0}))
    assert close(res.extra["q"], ref.extra["q"])
    assert close(res.summary["reactions"]["A"]["F"], ref.summary["reactions"]["A"]["F"])
    assert model.core.parameter("loads.pulse")[0] == 1.0
    q, _, _ = equilibrium(model)
    assert close(q, ref.extra["q"])
    assert model.core.parameter("loads.pulse")[0] == 1.0


@pytest.mark.parametrize("deck, change", [
    ("uh60_part2_decay", {"springs.c_beta": 20.0, "springs.d_beta": 0.01}),     # joint springs
    ("uh60_part2_forward_flight_cable", {"cable.ei": 2.5}),                     # rotation-vector springs
])
def test_spring_update_is_a_rebuild(deck, change):
    model = pydriver.Model.from_deck(INPUTS / f"{deck}.nml")
    rebuilt = model.with_changes(change)
    before = model.core.parameter("springs.stiffness")
    assert close(before, model.description["stiffness"])
    new = {"springs.stiffness": rebuilt.description["stiffness"], "springs.damping": rebuilt.description["damping"]}
    assert not close(new["springs.stiffness"], before)
    with unforced(model), model.core.updated(new):
        with unforced(rebuilt):
            same_model(model, rebuilt)
    assert close(model.core.parameter("springs.stiffness"), before)


def test_bad_updates_name_the_parameter():
    model = pydriver.Model.from_deck(INPUTS / "uh60_part2_campbell.nml")
    with pytest.raises(RunError, match="'rotor.spin'"):
        model.core.update("rotor.spin", 1.0)
    with pytest.raises(RunError, match="'loads.pulse'.*no component"):
        model.core.update("loads.pulse", 0.0)                  # this deck has no pulse
    with pytest.raises(RunError, match="'loads.pulse'.*no component"):
        model.core.parameter("loads.pulse")
    with pytest.raises(RunError, match="'springs.stiffness'.*per coordinate"):
        model.core.update("springs.stiffness", [1.0, 2.0])
    with pytest.raises(RunError, match="'rotor.omega'.*one value"):
        model.core.update("rotor.omega", [1.0, 2.0])
    pulsed = pydriver.Model.from_deck(INPUTS / "uh60_part2_decay.nml")
    with pytest.raises(RunError, match="'loads.pulse'.*1 \\(on\\) or 0"):
        pulsed.core.update("loads.pulse", 0.5)
    with pytest.raises(RunError, match="'rotor.omega'.*no rotor"):
        pulsed.core.update("rotor.omega", 10.0)               # a deck without a rotor
    session = pulsed.core.start(pulsed.solver_settings(), 0.0, pulsed.q0, pulsed.v0)
    try:
        with pytest.raises(RunError, match="'loads.pulse'.*integration"):
            pulsed.core.update("loads.pulse", 0.0)             # not under a running integration
    finally:
        session.close()
    pulsed.core.update("loads.pulse", 0.0)
    run_up = pydriver.Model.from_deck(INPUTS / "uh60_part2_runup.nml")
    with pytest.raises(RunError, match="'rotor.omega'.*not constant"):
        run_up.core.update("rotor.omega", 10.0)


def solve_speeds_rebuilt(model, rpm):
    """The Campbell diagram's speeds as they were solved before models updated: a model built
    from the deck at every speed (the reference)."""
    s = model.deck.values["solver"]
    q_prev, solved = None, []
    for r in rpm:
        m = model.with_changes({"rotor.rpm": float(r), "case.analysis": "static"})
        q, lam, _ = m.core.static(m.q0 if q_prev is None else q_prev, 0.0, s["newton_tol"], s["newton_max_iter"])
        q_prev = q
        mats = m.core.modal_matrices(q, lam)
        solved.append((mats, *linear_modes.complex_modes(mats)))
    return solved


@pytest.mark.parametrize("deck", ["uh60_part2_campbell", "uh60_part2_campbell_soft"])
def test_campbell_diagram_unchanged_by_updating(deck, monkeypatch):
    model = pydriver.Model.from_deck(INPUTS / f"{deck}.nml")
    updated = pydriver.run_deck(model)
    with monkeypatch.context() as mp:
        mp.setattr(campbell, "solve_speeds", solve_speeds_rebuilt)
        rebuilt = pydriver.run_deck(model)
    assert close(updated.extra["campbell"]["f"], rebuilt.extra["campbell"]["f"])
    assert close(updated.extra["campbell"]["zeta"], rebuilt.extra["campbell"]["zeta"])
    assert updated.summary["crossings"] == rebuilt.summary["crossings"]
    assert model.core.parameter("rotor.omega")[0] == model.deck["rotor.rpm"] * RPM
