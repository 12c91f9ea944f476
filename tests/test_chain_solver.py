"""The O(n) chain linear solver (``&solver linear_solver = 'chain'``, issue 14 item 2).

It solves an approximate GGL iteration matrix (cj M + joint damping + joint stiffness / cj in
the v rows, the constraint blocks exact, geometric stiffness, gyroscopic terms and d(G v)/dq
dropped) by an articulated-body factorisation and a Schur complement on the clamp rows.  Two
checks: on that matrix it must agree with the block (LU) solver, and a whole integration with
it must end where the default solver ends, to within the integration error.
"""

import numpy as np
import pytest

import pydriver
from pydriver import core_probes as probes
from conftest import INPUTS

DECKS = ["three_body", "six_link_dynamic", "uh60_part2_decay"]
EPS = np.finfo(float).eps


def _chain(stem, cj, n_rhs=3):
    m = pydriver.Model.from_deck(INPUTS / f"{stem}.nml")
    y, _ = probes.consistent_ggl_state(m.core, m.q0, m.v0)
    b = np.random.default_rng(11).standard_normal((len(y), n_rhs))
    return probes.chain_solver(m.core, y, cj, b), b


@pytest.mark.parametrize("stem", DECKS)
@pytest.mark.parametrize("cj", [1.0, 1.0e3])
def test_chain_solve_matches_block_solve_of_the_same_matrix(stem, cj):
    """Both solve the chain's approximate matrix J; their solutions differ by the forward
    error of two stable solvers, at most a small multiple of cond(J) eps (Higham 2002, ch. 7):
    bound 100 cond(J) eps, which is below 1e-10 for these matrices except where cond(J) itself
    says no solver can do better.  The backward error of the chain solution must be of order eps
    (the stable recursion of rotorcable_articulated_body; LU's own bound ~ n eps, here 1e-13 as
    in test_linear_solver)."""
    out, b = _chain(stem, cj)
    jac, xc, xb = out["jacobian"], out["x_chain"], out["x_block"]
    cond = np.linalg.cond(jac)
    assert np.abs(xc - xb).max() / np.abs(xb).max() <= 100.0 * cond * EPS
    for k in range(b.shape[1]):
        err = np.abs(jac @ xc[:, k] - b[:, k]).max()
        scale = np.abs(jac).sum(axis=1).max() * np.abs(xc[:, k]).max() + np.abs(b[:, k]).max()
        assert err / scale < 1e-13


def test_chain_matrix_is_the_iteration_matrix_without_the_dropped_terms():
    """The chain matrix equals the full iteration matrix in every block it keeps: the q rows
    (cj I, -I, G^T), the constraint rows (G) and the mass part of the v rows.  The difference in
    the v rows is dF_v/dq - C and dF_v/dv - D (geometric stiffness, gyroscopic terms), which
    does not scale with cj: it is the same at cj = 1e3 and 1e6 to round-off of cj M
    (eps cj |M| relative, bound 1e-9 of |J| at cj = 1e6)."""
    m = pydriver.Model.from_deck(INPUTS / "uh60_part2_decay.nml")
    y, yd = probes.consistent_ggl_state(m.core, m.q0, m.v0)
    nq = m.nq
    zeros = np.zeros((len(y), 1))
    diffs = []
    for cj in (1.0e3, 1.0e6):
        full = probes.iteration_matrix(m.core, y, yd, cj, zeros)["jacobian"]
        approx = probes.chain_solver(m.core, y, cj, zeros)["jacobian"]
        d = full - approx
        keep = np.ones_like(d, dtype=bool)
        keep[nq:2 * nq, :2 * nq] = False
        assert np.abs(d[keep]).max() <= 1e-12 * np.abs(full).max()
        diffs.append(d[nq:2 * nq, :2 * nq])
    assert np.abs(diffs[1] - diffs[0]).max() <= 1e-9 * np.abs(full).max()


def _end_state(deck):
    r = pydriver.run_deck(deck)
    ts = r.timeseries
    return r, np.array([ts[c][-1] for c in ts if c[0] in "xyz" and c[1:].isdigit()])


@pytest.mark.parametrize("stem, changes, bound", [
    ("six_link_dynamic", {}, 1e-7),
    ("uh60_part2_decay", {"t_end": "0.05", "dt_out": "0.05"}, 1e-7)])
def test_chain_solver_gives_the_same_motion(deck_copy, stem, changes, bound):
    """A run with the chain solver ends where the block solver's run ends.  The two differ
    only in the Newton iteration matrix, so by the integration error: at rtol 1e-8 and atol
    1e-10 rad on the angles of bodies of at most 0.6 m the local errors are ~1e-9 m and their
    sum over the run ~1e-8 m; 1e-7 m is above that and far below the motion (cm, or the 1 N
    pulse's mm)."""
    _, x0 = _end_state(deck_copy(stem, "solver", dict(changes)))
    other, x1 = _end_state(deck_copy(stem, "solver", {**changes, "linear_solver": "'chain'"}))
    assert np.abs(x1 - x0).max() < bound
    assert other.summary["max_constraint_violation_m"] < 1e-9


def _long_chain(tmp_path, n, joint):
    """The scaling benchmark's scene: UH-60 part 2 decay cut into n bodies (66 deg of bend spread
    over the joints, so a zy joint sits within 0.3 deg of its beta = 0 singularity at n = 200);
    joint 'xy' bends both ways, 'xyz' also twists (c_twist = c_beta)."""
    from pydriver.analyses.dynamics import start_state
    from pydriver.study import override_deck
    bend = 66.0 / (n - 1)
    changes = {"chain": {"n_bodies": str(n), "joint": f"'{joint}'"},
               "shape": {"gamma_deg": f"90.0, 90.0, {n - 2}*0.0", "beta_deg": f"70.0, {n - 1}*{bend:.6f}"},
               "loads": {"pulse_body": str(n // 2)}, "solver": {"t_end": "0.01", "dt_out": "0.01"}}
    if joint != "zy":
        changes["springs"] = {"c_gamma": "0.0", "d_gamma": "0.0"}
    if joint == "xyz":
        changes["springs"].update({"c_twist": "35.0", "d_twist": "0.05"})
    m = pydriver.Model.from_deck(override_deck(INPUTS / "uh60_part2_decay.nml", tmp_path / f"n{n}.nml", changes))
    q0, v0 = start_state(m)
    return m, q0, v0


@pytest.mark.parametrize("n, joint", [(40, "xy"), (88, "xyz"), (200, "zy"), (200, "xy")])
def test_articulated_solve_keeps_its_digits_on_long_chains(tmp_path, n, joint):
    """(M + A)^-1 tau by the articulated-body factorisation against LAPACK's solve of the dense
    M (composite rigid bodies), at an armature that matters (1e-3) and at none.  The textbook
    recursion lost its digits along a chain of multi-axis joints (the 40-body xy chain: 1e-4
    relative error, the 88-body xyz chain: 1e2, i.e. garbage); the stable form of
    rotorcable_articulated_body has the forward error of a stable solver, ~cond(M) eps (measured
    2.5e-9 at n = 200, cond 2e8).  Bound 100 cond eps (at least 1e-12)."""
    m, q0, v0 = _long_chain(tmp_path, n, joint)
    mass = probes.evaluate(m.core, q0, v0, 0.0 * v0, np.zeros(m.nc))["M"]
    tau = np.random.default_rng(3).standard_normal(m.nq)
    for armature in (1.0e-3, 0.0):
        a = mass + armature * np.eye(m.nq)
        exact = np.linalg.solve(a, tau)
        x = probes.articulated_solve(m.core, q0, np.full(m.nq, armature), tau)
        bound = max(100.0 * np.linalg.cond(a) * EPS, 1e-12)
        assert np.linalg.norm(x - exact) <= bound * np.linalg.norm(exact), (armature, np.linalg.norm(x - exact))


@pytest.mark.parametrize("n, joint", [(40, "xy"), (88, "xyz")])
def test_chain_solve_keeps_its_digits_in_every_block(tmp_path, n, joint):
    """The whole chain solve (articulated body, Schur complement on the clamp rows) against the
    block LU of the same matrix, for right-hand sides in the v rows alone and in the constraint
    rows alone, from cj = 1e4 (steps of 0.1 ms) to 1e12 (the first steps of a tight run), where
    the armature no longer regularises M.  The backward error is taken block by block (rows of
    q, v, g, G v): over all rows at once the cj I of the q rows swamps it, and it passed while
    the v rows were wrong by 300 %.  Bound 1e-13 (LU's ~n eps; measured 5e-17 for both solvers).
    For v-row right-hand sides the solution itself agrees with LU's to 1e-6 (measured 3e-11;
    with constraint-row ones the multipliers reach 1e13 at cj = 1e12 and both solvers' forward
    errors are cond(J) eps, so only the backward error is compared there)."""
    m, q0, v0 = _long_chain(tmp_path, n, joint)
    y, _ = probes.consistent_ggl_state(m.core, q0, v0)
    nq, nc = m.nq, m.nc
    blocks = [slice(0, nq), slice(nq, 2 * nq), slice(2 * nq, 2 * nq + nc), slice(2 * nq + nc, 2 * nq + 2 * nc)]
    rng = np.random.default_rng(4)
    for rows in (slice(nq, 2 * nq), slice(2 * nq, 2 * nq + 2 * nc)):
        b = np.zeros(len(y))
        b[rows] = rng.standard_normal(rows.stop - rows.start)
        for cj in (1.0e4, 1.0e8, 1.0e12):
            out = probes.chain_solver(m.core, y, cj, b[:, None])
            jac, x = out["jacobian"], out["x_chain"][:, 0]
            r = jac @ x - b
            for blk in blocks:
                scale = np.abs(jac[blk]).sum(axis=1).max() * np.abs(x).max() + np.abs(b[blk]).max()
                assert np.abs(r[blk]).max() <= 1e-13 * scale, (rows, cj, blk)
            if rows.start == nq:
                xb = out["x_block"][:, 0]
                assert np.abs(x - xb).max() <= 1e-6 * np.abs(xb).max(), cj


def test_chain_solver_runs_a_long_chain_like_the_block_solver(tmp_path):
    """The 40-body chain (which the textbook recursion could not start: IDA's corrector failed at
    h ~ 1e-23) integrates with the chain solver to where the block solver gets.  Same model and
    tolerances, different Newton matrices, so the ends differ by the integration error: rtol
    1e-6 / atol 1e-8 on a 0.25 mm motion gives local errors ~1e-10 m, their sum over 300 steps
    at most ~1e-8 m; bound 1e-7 m, measured 5e-11 m."""
    m, _, _ = _long_chain(tmp_path, 40, "zy")
    ends = []
    for solver in ("block", "chain"):
        r = pydriver.run_deck(m.with_changes({"solver.linear_solver": solver}))
        ts = r.timeseries
        ends.append(np.array([ts[c][-1] for c in ts if c[0] in "xyz" and c[1:].isdigit()]))
        assert r.summary["solver"]["convergence_failures"] <= 10
    assert np.abs(ends[1] - ends[0]).max() < 1e-7


def test_auto_picks_the_block_solver_for_small_chains_and_the_chain_solver_for_long_ones():
    """``linear_solver = 'auto'`` (the default): the block solver below 32 coordinates (the UH-60
    decay, 20), the chain solver from 32 on (the forward-flight cable, 33); a run reports which it
    used, and an explicit choice is kept."""
    small = pydriver.Model.from_deck(INPUTS / "uh60_part2_decay.nml")
    large = pydriver.Model.from_deck(INPUTS / "uh60_part2_forward_flight_cable.nml")
    assert (small.nq, small.linear_solver()) == (20, "block")
    assert (large.nq, large.linear_solver()) == (33, "chain")
    assert small.with_changes({"solver.linear_solver": "chain"}).linear_solver() == "chain"
    r = pydriver.run_deck(small.with_changes({"solver.t_end": 0.01, "solver.dt_out": 0.01}))
    assert r.summary["linear_solver"] == "block"


def test_chain_solver_swings_a_free_physical_cable_like_the_block_solver():
    """A free end (no clamp rows: the chain solver without its Schur complement), xyz joints with
    the rotation-vector springs of the physical cable (&cable), 44 bodies under gravity from a
    straight horizontal start: 0.2 s of a 0.25 m swing end where the block solver's run ends.
    rtol 1e-6 on that motion gives local errors ~1e-8 m and a sum ~1e-7 m; bound 1e-6 m,
    measured 2.7e-9 m."""
    from pydriver.deckfile import deck_from_text
    ends = []
    for solver in ("block", "chain"):
        m = pydriver.Model(deck_from_text(f"""&case analysis = 'dynamic', start = 'shape' /
&chain n_bodies = 44, total_length = 0.59, diameter = 0.015, total_mass = 0.313, joint = 'xyz',
       first_body = 'clamped' /
&clamp_a beta_deg = 90.0 /
&cable ei = 0.163581, gj = 0.125832, damping_time = 1.0e-3 /
&shape gamma_deg = 0.0, beta_deg = 0.0 /
&loads gravity = 0.0, 0.0, -9.81 /
&solver t_end = 0.2, dt_out = 0.01, rtol = 1.0e-6, atol = 1.0e-8, linear_solver = '{solver}' /""", "free44.nml"))
        assert m.nc == 0
        ts = pydriver.run_deck(m).timeseries
        ends.append(np.array([ts[c][-1] for c in ts if c[0] in "xyz" and c[1:].isdigit()]))
        assert ts["z44"][0] - ts["z44"][-1] > 0.2                 # it really swings
    assert np.abs(ends[1] - ends[0]).max() < 1e-6
