"""The analytic Jacobian of the GGL residual (issue 14, item 1): dF/dq and dF/dv by tangent
sweeps of the kinematics, of every load, of clamp B and of the Newton-Euler pass
(``&solver jacobian = 'analytic'``, the default), against finite differences.

Every deck of ``inputs/`` with a distinct physics term is covered: gravity and springs (three
bodies, the six-link chain), the pulse (decay, inside its window), the tip force of a free end
(cantilever), the turning hub frame with Coriolis and the relative-inertia option (hover,
run-up), the moving blade clamp, cross-flow drag and the rotation-vector springs of xyz joints
(forward flight).  States are random: coordinates off the constraint manifold, rates of order
1 rad/s, random accelerations and multipliers, random times.
"""

import numpy as np
import pytest

import pydriver
from pydriver import core_probes as probes
from conftest import INPUTS

DECKS = ["three_body", "six_link_dynamic", "uh60_part1", "uh60_part2_decay", "cantilever_check",
         "uh60_part1_runup", "uh60_part2_hover", "uh60_part2_forward_flight",
         "uh60_part2_forward_flight_cable"]


def _random_state(m, seed):
    """A random (t, y, y') near the deck's start: the Jacobian is defined everywhere."""
    from pydriver.analyses.dynamics import start_state
    nq, nc = m.nq, m.nc
    q0, v0 = start_state(m)
    y, yd = probes.consistent_ggl_state(m.core, q0, v0)
    rng = np.random.default_rng(seed)
    y = y + np.concatenate([0.05 * rng.standard_normal(nq), rng.standard_normal(nq), rng.standard_normal(2 * nc)])
    yd = yd + rng.standard_normal(len(yd))
    return float(rng.uniform(0.0, 0.09)), y, yd


def _physics_columns(m, t, y, yd, jacobian):
    """dF/dq, dF/dv: the iteration matrix is P + cj E with E the exact y' blocks, so P = 2 J(1) -
    J(2) (cj = 0 itself cannot be asked for: the probe also factorises, dividing by cj)."""
    zero = np.zeros((len(y), 1))
    j1, j2 = (probes.iteration_matrix(m.core, y, yd, cj, zero, t=t, jacobian=jacobian)["jacobian"][:, :2 * m.nq]
              for cj in (1.0, 2.0))
    return 2.0 * j1 - j2


@pytest.mark.parametrize("stem", DECKS)
def test_analytic_columns_match_central_differences(stem):
    """Every physics column against central differences of the residual, step 1e-5 (scaled by
    |y_k| >= 1): their truncation error is ~h^2 |F'''| ~ 1e-10 of the matrix, round-off
    ~eps |F| / h ~ 1e-11.  Bound 1e-8 of the largest entry (measured 5e-11 at worst)."""
    m = pydriver.Model.from_deck(INPUTS / f"{stem}.nml")
    t, y, yd = _random_state(m, 1)
    ja = _physics_columns(m, t, y, yd, "analytic")
    jc = np.zeros_like(ja)
    for k in range(2 * m.nq):
        h = 1.0e-5 * max(1.0, abs(y[k]))
        yp, ym = y.copy(), y.copy()
        yp[k] += h
        ym[k] -= h
        jc[:, k] = (probes.ggl_residual(m.core, yp, yd, t) - probes.ggl_residual(m.core, ym, yd, t)) / (2.0 * h)
    assert np.abs(ja - jc).max() <= 1.0e-8 * np.abs(jc).max()


@pytest.mark.parametrize("stem", DECKS)
def test_analytic_and_finite_difference_paths_agree(stem):
    """The two settings of ``&solver jacobian`` at three random states agree to 1e-7 of the
    largest entry (the issue's figure).  The difference path is central (step eps^(1/3) max(|y|,
    1)), good to ~1e-10; measured worst 9e-11, so the bound has a margin of 1000."""
    m = pydriver.Model.from_deck(INPUTS / f"{stem}.nml")
    for seed in (2, 3, 4):
        t, y, yd = _random_state(m, seed)
        ja = _physics_columns(m, t, y, yd, "analytic")
        jf = _physics_columns(m, t, y, yd, "finite_difference")
        assert np.abs(ja - jf).max() <= 1.0e-7 * np.abs(ja).max()


@pytest.mark.parametrize("stem", ["six_link_dynamic", "uh60_part2_forward_flight_cable"])
def test_tangent_sweep_is_the_iteration_matrix_times_a_vector(stem):
    """One tangent sweep with (dy, cj dy) from body 1 is J dy for the full iteration matrix
    (analytic columns, exact blocks): the same sums in another order, 1e-12 relative."""
    m = pydriver.Model.from_deck(INPUTS / f"{stem}.nml")
    t, y, yd = _random_state(m, 5)
    dy = np.random.default_rng(6).standard_normal(len(y))
    for cj in (10.0, 1.0e4):
        full = probes.iteration_matrix(m.core, y, yd, cj, np.zeros((len(y), 1)), t=t)["jacobian"]
        jv = probes.residual_tangent(m.core, y, yd, dy, cj * dy, t=t)
        assert np.abs(jv - full @ dy).max() <= 1.0e-12 * np.abs(full).max() * np.abs(dy).max()


def test_a_run_with_either_jacobian_ends_in_the_same_place(deck_copy):
    """The Jacobian only steers the Newton iteration: runs with analytic and with
    finite-difference columns end within the integration error (six-link swing at rtol 1e-8:
    local errors ~1e-9 m; bound 1e-7 m)."""
    ends = []
    for jac in ("analytic", "finite_difference"):
        r = pydriver.run_deck(deck_copy("six_link_dynamic", "solver", {"jacobian": f"'{jac}'"}))
        ts = r.timeseries
        ends.append(np.array([ts[c][-1] for c in ts if c[0] in "xyz" and c[1:].isdigit()]))
    assert np.abs(ends[0] - ends[1]).max() < 1e-7


@pytest.mark.parametrize("stem", DECKS)
def test_tangent_columns_are_the_single_column_sweeps_bit_for_bit(stem):
    """The sensitivity residual's path (``ggl_residual_tangent_columns``: the chain's kinematics
    and Newton-Euler tangents over blocks of 4 columns, vectorised across them) gives every
    column the same bits as the single-column sweep: each column's arithmetic is the same terms
    in the same order.  Exact equality, no tolerance: 1 to 6 and 9 columns (one or two columns
    go column by column, three a padded block, then whole blocks and the rest), and a second
    call at the same point (the workspace then holds it)."""
    m = pydriver.Model.from_deck(INPUTS / f"{stem}.nml")
    t, y, yd = _random_state(m, 7)
    rng = np.random.default_rng(8)
    for width in (1, 2, 3, 4, 5, 6, 9):
        dy = rng.standard_normal((len(y), width))
        dyd = rng.standard_normal((len(y), width))
        together = probes.residual_tangent_columns(m.core, y, yd, dy, dyd, t=t)
        again = probes.residual_tangent_columns(m.core, y, yd, dy, dyd, t=t)
        single = np.column_stack([probes.residual_tangent(m.core, y, yd, dy[:, k], dyd[:, k], t=t)
                                  for k in range(width)])
        assert np.array_equal(together, single)
        assert np.array_equal(again, single)
