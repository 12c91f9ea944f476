"""Ball B (&ball_b, src_fortran/supports/ball.f90): a spherical support at the chain's far end,
the tip held at a point and the last body free to turn (3 constraint rows, a force and no
moment).  The support added through the component registry alone (its file, its factory line,
its declaration, its schema rows), and checked here against independent formulations: the
static reactions against the global force and moment balance of the chain, the constraint
residual and Jacobian against the kinematics and central differences, the tangents of the GGL
residual against central differences, and the energy of a free swing it holds."""

from __future__ import annotations

import numpy as np
import pytest

import pydriver
from pydriver import core_probes as probes
from conftest import INPUTS
from pydriver.analyses.dynamics import equilibrium
from test_analytic_jacobian import _physics_columns, _random_state

#: Ball B a little away from the six-link start shape's tip, so that the start is projected.
OFFSET = np.array([0.02, -0.03, 0.01])


def ball_deck(tmp_path, analysis: str = "static", extra: str = "", damped: bool = True, ball: dict | None = None):
    """The six-link chain of inputs/six_link_static.nml (body 1 clamped at A, gravity) with
    joint springs resting in the start shape, and ball B instead of clamp B (``ball``: its
    keys as deck text, replacing the defaults)."""
    six = pydriver.Model.from_deck(INPUTS / "six_link_static.nml")
    position = six.description["clamp"][0] + OFFSET
    d = "0.5" if damped else "0.0"
    keys = {"active": ".true.", "position": ", ".join(repr(float(x)) for x in position), **(ball or {})}
    ball_text = "".join(f"  {k} = {v}\n" for k, v in keys.items())
    text = f"""&case
  name = 'ball_{analysis}'
  analysis = '{analysis}'
/
&chain
  n_bodies = 5
  total_length = 1.0
  diameter = 0.05
  density = 7801.0
  first_body = 'clamped'
/
&shape
  gamma_deg = 0.0, 0.0, 90.0, 0.0, 90.0
  beta_deg  = 90.0, 90.0, 90.0, 90.0, -90.0
/
&springs
  c_gamma = 40.0, c_beta = 40.0
  d_gamma = {d}, d_beta = {d}
  rest_gamma_deg = 0.0, 0.0, 90.0, 0.0, 90.0
  rest_beta_deg = 90.0, 90.0, 90.0, 90.0, -90.0
/
&ball_b
{ball_text}/
&loads
  gravity = 0.0, 0.0, -9.81
/
{extra}"""
    path = tmp_path / f"ball_{analysis}.nml"
    path.write_text(text)
    return path, position


def test_ball_reactions_balance_the_weight_and_take_no_moment(tmp_path):
    """At the static equilibrium: F_A + F_B + sum m_j g = 0 and, about A (the origin),
    M_A + P_{n+1} x F_B + M_B + sum C_j x m_j g = 0, with M_B = 0 exactly (a ball transmits
    no moment).  F_A, M_A come from the recursion over the bodies and F_B from the multipliers;
    the balance holds to the round-off of that recursion: bound 1e-9 of the weight (150 N),
    for the moment 1e-9 of the weight times 1 m (the chain's length), measured 6e-14 N and
    7e-15 Nm.  The multipliers are the force on the tip: F_B = lambda."""
    path, position = ball_deck(tmp_path)
    m = pydriver.Model.from_deck(path)
    assert (m.nc, m.description["support"]) == (3, "ball")
    q, lam, _ = equilibrium(m)
    s = m.core.sample(np.zeros(1), q.reshape(-1, 1), np.zeros((m.nq, 1)))
    w = s.wrenches.at(0)
    f_a, m_a, f_b, m_b = w.force_a, w.moment_a, w.force_b, w.moment_b
    shape = m.core.shape(q)
    masses = m.description["bodies"].masses
    g = np.array([0.0, 0.0, -9.81])
    weight = masses.sum() * 9.81
    np.testing.assert_allclose(shape["joints"][-1], position, atol=1.0e-12)
    np.testing.assert_array_equal(m_b, 0.0)
    np.testing.assert_allclose(f_b, lam, rtol=1.0e-12)
    assert np.abs(f_a + f_b + masses.sum() * g).max() <= 1.0e-9 * weight
    moment = m_a + np.cross(shape["joints"][-1], f_b) + sum(
        np.cross(c, mj * g) for c, mj in zip(shape["cm"], masses))
    assert np.abs(moment).max() <= 1.0e-9 * weight * 1.0
    # The ball carries a real share of the weight, so the balance is not met by F_A alone.
    assert np.linalg.norm(f_b) > 0.1 * weight


def test_ball_constraint_rows_and_jacobian(tmp_path):
    """g(q) = P_{n+1}(q) - p_B from the kinematics (to 1e-15 m: the same point), and G = dg/dq
    against central differences, step 1e-6: truncation ~h^2 |g'''| ~ 1e-12 m, round-off
    ~eps / h ~ 1e-10; bound 1e-8 of the largest entry (~1 m), measured 1.3e-10."""
    path, position = ball_deck(tmp_path)
    m = pydriver.Model.from_deck(path)
    q = m.q0 + 0.2 * np.random.default_rng(5).standard_normal(m.nq)
    np.testing.assert_allclose(m.core.constraint_residual(q), m.core.shape(q)["joints"][-1] - position,
                               atol=1.0e-15)
    g_jac = m.core.static_system(q, np.zeros(3), jacobian=True)["G"]
    fd = np.zeros_like(g_jac)
    for k in range(m.nq):
        qp, qm = q.copy(), q.copy()
        qp[k] += 1.0e-6
        qm[k] -= 1.0e-6
        fd[:, k] = (m.core.constraint_residual(qp) - m.core.constraint_residual(qm)) / 2.0e-6
    assert np.abs(g_jac - fd).max() <= 1.0e-8 * np.abs(fd).max()


def test_ball_tangents_match_central_differences(tmp_path):
    """The GGL residual's physics columns (with the ball's g, G v, G^T mu and their tangents)
    against central differences, as tests/test_analytic_jacobian.py does for every deck: bound
    1e-8 of the largest entry."""
    m = pydriver.Model.from_deck(ball_deck(tmp_path, "dynamic")[0])
    t, y, yd = _random_state(m, 2)
    ja = _physics_columns(m, t, y, yd, "analytic")
    jc = np.zeros_like(ja)
    for k in range(2 * m.nq):
        h = 1.0e-5 * max(1.0, abs(y[k]))
        yp, ym = y.copy(), y.copy()
        yp[k] += h
        ym[k] -= h
        jc[:, k] = (probes.ggl_residual(m.core, yp, yd, t) - probes.ggl_residual(m.core, ym, yd, t)) / (2.0 * h)
    assert np.abs(ja - jc).max() <= 1.0e-8 * np.abs(jc).max()


def test_ball_tangent_columns_are_the_single_column_sweeps_bit_for_bit(tmp_path):
    """The sensitivity residual's block path with the ball's rows (no moment rows, a 3-row
    wrench): every column the same bits as the single-column sweep (as
    tests/test_analytic_jacobian.py checks for every deck), 6 columns (a block and a padded one)."""
    m = pydriver.Model.from_deck(ball_deck(tmp_path, "dynamic")[0])
    t, y, yd = _random_state(m, 3)
    rng = np.random.default_rng(4)
    dy, dyd = rng.standard_normal((len(y), 6)), rng.standard_normal((len(y), 6))
    single = np.column_stack([probes.residual_tangent(m.core, y, yd, dy[:, k], dyd[:, k], t=t) for k in range(6)])
    assert np.array_equal(probes.residual_tangent_columns(m.core, y, yd, dy, dyd, t=t), single)


def test_a_swing_held_by_the_ball_keeps_its_energy(tmp_path):
    """Dampers off, released from the projected start shape: the ball does no work on the
    chain (its point is fixed), so kinetic + gravity + spring energy stays constant.  As in
    tests/test_energy.py: drift bound 1e-6 |E| at rtol 1e-10, far above the integrator's error
    and far below a wrong constraint force (a ~1e-2 effect); measured 3e-10.  The tip stays on
    the ball point: the constraint violation of every sample below 1e-10 m (measured 1e-13)."""
    path, _ = ball_deck(tmp_path, "dynamic", damped=False,
                        extra="&solver\n  t_end = 0.3\n  dt_out = 0.005\n  rtol = 1.0e-10\n  atol = 1.0e-12\n/\n")
    res = pydriver.run_deck(path, out=tmp_path / "out")
    e = res.extra["energy"]
    assert np.max(np.abs(e - e[0])) / abs(e[0]) < 1.0e-6
    assert np.ptp(res.timeseries["z3"]) > 1.0e-3          # it swings (3 cm)
    assert np.max(np.abs(res.extra["constraint_violation"])) < 1.0e-10
    np.testing.assert_array_equal(res.timeseries["MB_x"], 0.0)


def test_ball_and_clamp_at_once_is_a_deck_error(tmp_path):
    path, _ = ball_deck(tmp_path, extra="&clamp_b\n  active = .true.\n  from_start = .true.\n/\n")
    with pytest.raises(pydriver.DeckError) as exc:
        pydriver.Model.from_deck(path)
    assert exc.value.group == "ball_b" and "one support" in str(exc.value)


@pytest.mark.parametrize("key,value,words", [
    ("position", "1.0e4, 0.0, 0.0", "1000"),
    ("position", "0.5", "3"),
    ("position", "3.0, 0.0, 0.0", "out of reach"),
    ("active", "'yes'", "logical"),
])
def test_bad_ball_values_are_deck_errors_naming_the_key(tmp_path, key, value, words):
    """A fuzz case per key: out of range, of the wrong size, out of reach of the chain (the
    reach check through support_type%reach_target), not a logical."""
    path, _ = ball_deck(tmp_path, ball={key: value})
    with pytest.raises(pydriver.DeckError) as exc:
        pydriver.Model.from_deck(path)
    assert (exc.value.group, exc.value.key) == ("ball_b", key)
    assert words in str(exc.value)


def test_an_active_ball_needs_its_position(tmp_path):
    path = tmp_path / "nopos.nml"
    path.write_text((INPUTS / "six_link_static.nml").read_text().replace(
        "&clamp_b\n  active = .true.\n  from_start = .true.\n/", "&ball_b\n  active = .true.\n/"))
    with pytest.raises(pydriver.DeckError) as exc:
        pydriver.Model.from_deck(path)
    assert (exc.value.group, exc.value.key) == ("ball_b", "position") and "required" in str(exc.value)
