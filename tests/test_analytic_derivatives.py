"""The whole-matrix derivatives of the residual (issue 39, items 1 and 2): d(res)/dq, d(res)/dv
and M = d(res)/d(vdot) of the equation of motion in one recursive pass over the bodies
(``src_fortran/inverse_dynamics_derivatives.f90``, ``model_derivatives.f90``; the structure of
Carpentier and Mansard's RNEA derivatives), and with them the GGL iteration matrix's physics
columns, against the independent tangent sweeps (one directional sweep of the kinematics, the
loads, the supports and the Newton-Euler pass per column, ``ggl_residual_tangent``).

Both are exact: they are the same derivatives summed in another order, so they agree to
round-off.  The bound is 1e-12 of the largest entry of the matrix compared (the issue's figure);
the worst measured over four random states of every case below is 2.1e-14 (the hover deck,
Coriolis terms of the turning hub; 1e-15 elsewhere), so the bound has a margin of ~50 for any
x86-64 CPU's order of operations.

Covered: the three joints (zy: the thesis decks; xyz: run-up and forward flight; xy: two decks
switched to it), without a rotor (three bodies, six links, part 1, decay, cantilever) and with
one (hover, run-up with its changing speed, forward flight), clamp B fixed and moving with the
blade (forward flight), ball B, and every load (gravity, joint springs, the pulse inside its
window, the tip force, drag, rotation-vector springs, the anchor spring).  States are random
(tests/test_analytic_jacobian.py's ``_random_state``): coordinates off the constraint manifold,
rates of order 1 rad/s, random accelerations and multipliers, random times.
"""

from __future__ import annotations

import numpy as np
import pytest

import pydriver
from pydriver import core_probes as probes
from pydriver.study import override_deck
from conftest import INPUTS
from test_analytic_jacobian import DECKS, _physics_columns, _random_state
from test_anchor_spring import anchored
from test_ball_support import ball_deck

#: Round-off bound relative to the largest entry (module docstring).
RELATIVE = 1.0e-12

#: Decks switched to joint 'xy' (Cardan bending, no twist): one without a rotor, one with.
XY_DECKS = ["six_link_dynamic", "uh60_part2_hover"]


def _sweep_columns(m, t, y, yd):
    """dF/dq, dF/dv of the GGL residual, one tangent sweep per column at fixed y'."""
    n = len(y)
    columns = np.zeros((n, 2 * m.nq))
    for k in range(2 * m.nq):
        dy = np.zeros(n)
        dy[k] = 1.0
        columns[:, k] = probes.residual_tangent(m.core, y, yd, dy, np.zeros(n), t=t)
    return columns


def _close(a, b):
    """|a - b| within RELATIVE of b's largest entry (b is not all zeros: a zero reference
    would make the check empty)."""
    scale = np.abs(b).max()
    assert scale > 0.0
    return np.abs(a - b).max() <= RELATIVE * scale


def _check_model(m, seeds=(1, 2)):
    """The equation of motion's matrices and the physics columns, whole against by sweeps."""
    nq, nc = m.nq, m.nc
    for seed in seeds:
        t, y, yd = _random_state(m, seed)
        swept = _sweep_columns(m, t, y, yd)
        d = probes.eom_derivatives(m.core, y[:nq], y[nq:2 * nq], yd[nq:2 * nq], y[2 * nq:2 * nq + nc], t=t)
        assert _close(d["dres_dq"], swept[nq:2 * nq, :nq])
        assert _close(d["dres_dv"], swept[nq:2 * nq, nq:])
        mass = probes.evaluate(m.core, y[:nq], y[nq:2 * nq], yd[nq:2 * nq], y[2 * nq:2 * nq + nc], t=t)["M"]
        assert _close(d["mass"], mass)
        # The iteration matrix's physics columns as the integrator gets them (every row block:
        # the q rows' d(G^T mu)/dq, g's and the velocity constraint's rows)...
        whole = _physics_columns(m, t, y, yd, "analytic")
        assert _close(whole, _physics_columns(m, t, y, yd, "tangent_sweeps"))
        assert _close(whole, swept)
        # ... and the whole iteration matrix with its exact blocks (M given by the pass).
        zero = np.zeros((len(y), 1))
        full = [probes.iteration_matrix(m.core, y, yd, 1.0e3, zero, t=t, jacobian=method)["jacobian"]
                for method in ("analytic", "tangent_sweeps")]
        assert _close(full[0], full[1])


@pytest.mark.parametrize("stem", DECKS)
def test_whole_matrices_are_the_tangent_sweeps(stem):
    """Every deck with a distinct physics term (zy and xyz joints, rotor or none, moving
    clamp B), two random states."""
    _check_model(pydriver.Model.from_deck(INPUTS / f"{stem}.nml"))


@pytest.mark.parametrize("stem", XY_DECKS)
def test_whole_matrices_are_the_tangent_sweeps_on_xy_joints(tmp_path, stem):
    """The Cardan joint 'xy', without a rotor and with the turning hub (its bending springs
    are c_beta's: the deck's c_gamma and d_gamma set to 0, as 'xy' asks)."""
    changes = {"chain": {"joint": "'xy'"}, "springs": {"c_gamma": "0.0", "d_gamma": "0.0"}}
    m = pydriver.Model.from_deck(override_deck(INPUTS / f"{stem}.nml", tmp_path / f"{stem}_xy.nml", changes))
    assert m.nq > 0
    _check_model(m)


@pytest.mark.parametrize("joint", [2, 4])
def test_whole_matrices_are_the_tangent_sweeps_with_an_anchor_spring(tmp_path, joint):
    """The anchor spring at an inner joint point and at the tip (three bodies)."""
    _check_model(anchored(tmp_path, joint))


def test_whole_matrices_are_the_tangent_sweeps_with_ball_b(tmp_path):
    """Ball B: three constraint rows of the tip point, whose second derivatives enter the q
    rows' d(G^T mu)/dq and the velocity constraint's d(G v)/dq."""
    _check_model(pydriver.Model.from_deck(ball_deck(tmp_path, "dynamic")[0]))


@pytest.mark.parametrize("stem", ["uh60_part2_modal", "uh60_part2_campbell", "uh60_part2_forward_flight_cable"])
def test_rest_stiffness_and_damping_are_the_tangent_sweeps(stem):
    """Statics and the modal analyses take K = d(residual at rest)/dq and D = d/dv (v = vdot = 0,
    multipliers fixed) from the whole matrices too (statics.f90, rest_tangent): K of the static
    system and the modal D_r = N^T D N against the sweeps' columns at rest, at a random
    coordinate state near the start (the clamped cable, the turning hub, the xyz cable in the
    stream)."""
    from pydriver.analyses.dynamics import start_state
    m = pydriver.Model.from_deck(INPUTS / f"{stem}.nml")
    nq, nc = m.nq, m.nc
    rng = np.random.default_rng(9)
    q = start_state(m)[0] + 0.05 * rng.standard_normal(nq)
    lam = rng.standard_normal(nc)
    y = np.concatenate([q, np.zeros(nq), lam, np.zeros(nc)])
    swept = _sweep_columns(m, 0.0, y, np.zeros_like(y))
    k_swept, d_swept = swept[nq:2 * nq, :nq], swept[nq:2 * nq, nq:]
    assert _close(m.core.static_system(q, lam, jacobian=True)["K"], k_swept)
    mats = m.core.modal_matrices(q, lam)
    assert _close(mats["D_r"], mats["basis"].T @ d_swept @ mats["basis"])
