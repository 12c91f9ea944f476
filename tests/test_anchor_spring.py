"""The anchor spring (&anchor, src_fortran/loads/anchor.f90): a linear spring from joint point
P_j to a fixed point, F = -k (P_j - a), potential k |P_j - a|^2 / 2.  The load added through the
component registry alone (its file, its factory line, its declaration, its schema rows), and
checked here against independent formulations: its tangent against central differences of
the residual, its potential against the closed form and against the work of its generalized
forces, and its deck keys against bad values."""

from __future__ import annotations

import re

import numpy as np
import pytest

import pydriver
from pydriver import core_probes as probes
from conftest import INPUTS
from test_analytic_jacobian import _physics_columns, _random_state

POINT = np.array([0.12, 0.25, -0.20])
STIFFNESS = 50.0          # N/m: at ~0.3 m stretch ~15 N, ten times the chain's weight (1.5 N)


def anchored(tmp_path, joint: int, gravity: str = "0.0, 0.0, -9.81", springs: bool = True,
             extra: str = "") -> pydriver.Model:
    """The three-body pendulum (inputs/three_body.nml) with an anchor spring at joint point P_j."""
    text = (INPUTS / "three_body.nml").read_text()
    if not springs:
        # The group up to its own '/' line (the '/' of a comment's "Nmm/rad" is not its end: cut
        # there, the rest of the group stood between groups, which a deck may not have: issue 37).
        group = re.search(r"&springs\b.*?\n\s*/", text, re.S)
        text = text[:group.start()] + text[group.end():]
    text += (f"\n&anchor\n  joint = {joint}\n  point = {', '.join(map(str, POINT))}\n"
             f"  stiffness = {STIFFNESS}\n{extra}/\n&loads\n  gravity = {gravity}\n/\n")
    path = tmp_path / f"anchored_{joint}.nml"
    path.write_text(text)
    return pydriver.Model.from_deck(path)


def _central_columns(m, t, y, yd):
    """dF/dq, dF/dv by central differences of the residual, step 1e-5 (scaled by |y_k| >= 1)."""
    jc = np.zeros((len(y), 2 * m.nq))
    for k in range(2 * m.nq):
        h = 1.0e-5 * max(1.0, abs(y[k]))
        yp, ym = y.copy(), y.copy()
        yp[k] += h
        ym[k] -= h
        jc[:, k] = (probes.ggl_residual(m.core, yp, yd, t) - probes.ggl_residual(m.core, ym, yd, t)) / (2.0 * h)
    return jc


@pytest.mark.parametrize("joint", [2, 4])
def test_anchor_tangent_matches_central_differences(tmp_path, joint):
    """The anchor's own part of dF/dq, dF/dv (the anchored model's columns less those of the
    same chain without it, at the same random state) with the anchor at an inner joint point
    (P_2, on body 2) and at the tip (P_4, on body 3), against the same difference of central
    differences, step 1e-5: truncation ~h^2 |F'''| ~ 1e-10 of the matrix, round-off
    ~eps |F| / h ~ 1e-11 of it (as in tests/test_analytic_jacobian.py); bound 1e-8 of the
    largest entry of the full matrix (measured 3e-11 at P_2, 9e-11 at the tip).  The anchor's
    part is checked to be a sizeable share of that matrix (measured 29 % and 96 %), so that a
    wrong tangent could not hide under the bound."""
    m = anchored(tmp_path, joint)
    free = pydriver.Model.from_deck(INPUTS / "three_body.nml")
    t, y, yd = _random_state(m, 3)
    jc = _central_columns(m, t, y, yd)
    part_a = _physics_columns(m, t, y, yd, "analytic") - _physics_columns(free, t, y, yd, "analytic")
    part_c = jc - _central_columns(free, t, y, yd)
    assert np.abs(part_c).max() > 0.1 * np.abs(jc).max()
    assert np.abs(part_a - part_c).max() <= 1.0e-8 * np.abs(jc).max()


@pytest.mark.parametrize("joint", [2, 4])
def test_anchor_potential_is_the_closed_form_and_the_work_of_its_forces(tmp_path, joint):
    """Gravity and springs off, so the model's only load is the anchor:

    * its potential equals k |P_j - a|^2 / 2 from the core's joint points (to 1e-14 relative:
      the same arithmetic in another order);
    * V(q1) - V(q0) equals the integral of the static residual along the straight path
      q0 -> q1, by 16-point Gauss-Legendre quadrature: for an unconstrained chain at rest the
      residual -k(q, 0) is minus the applied generalized force, dV/dq, and the integral is
      minus the work the spring does.  Q is smooth (trigonometric in q), so the quadrature error is
      far below round-off; bound 1e-10 of |V(q1) - V(q0)|, the round-off of summing 16 terms."""
    m = anchored(tmp_path, joint, gravity="0.0, 0.0, 0.0", springs=False)
    rng = np.random.default_rng(7)
    q0 = m.q0 + 0.3 * rng.standard_normal(m.nq)
    q1 = q0 + 0.8 * rng.standard_normal(m.nq)

    def potential(q):
        return float(m.core.sample(np.zeros(1), q.reshape(-1, 1), np.zeros((m.nq, 1))).potential[0])

    for q in (q0, q1):
        p_j = m.core.shape(q)["joints"][joint - 1]
        assert potential(q) == pytest.approx(0.5 * STIFFNESS * np.sum((p_j - POINT) ** 2), rel=1.0e-14)
    s, w = np.polynomial.legendre.leggauss(16)
    work = 0.0
    for si, wi in zip(0.5 * (s + 1.0), 0.5 * w):
        q = q0 + si * (q1 - q0)
        work += wi * m.core.static_system(q, np.zeros(0))["residual"] @ (q1 - q0)
    dv = potential(q1) - potential(q0)
    assert abs(dv) > 0.1                        # a real change, not two small numbers
    assert dv == pytest.approx(work, rel=1.0e-10)


@pytest.mark.parametrize("key,value,words", [
    ("joint", "5", "n_bodies + 1"),             # the three-body chain has joint points 1 ... 4
    ("joint", "0", "at least 1"),
    ("joint", "3000000000", "integer"),
    ("point", "1.0e4, 0.0, 0.0", "1000"),
    ("point", "0.1", "3"),
    ("stiffness", "-1.0", "positive"),
    ("stiffness", "0.0", "positive"),
    ("stiffness", "1.0e10", "1e+09"),
    ("stiffness", "1.2.3", "number"),
])
def test_bad_anchor_values_are_deck_errors_naming_the_key(tmp_path, key, value, words):
    """A fuzz case per key: out of range, of the wrong size or malformed, each refused as a
    DeckError naming &anchor and the key (joint beyond the tip by the core, through the
    registry's parameter name -> deck key map)."""
    text = (INPUTS / "three_body.nml").read_text() + \
        "\n&anchor\n  joint = 4\n  point = 0.1, 0.2, -0.2\n  stiffness = 50.0\n/\n"
    lines = [f"  {key} = {value}" if ln.strip().startswith(f"{key} =") else ln for ln in text.splitlines()]
    path = tmp_path / "bad.nml"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(pydriver.DeckError) as exc:
        pydriver.Model.from_deck(path)
    assert (exc.value.group, exc.value.key) == ("anchor", key)
    assert words in str(exc.value)


def test_a_missing_anchor_key_is_required(tmp_path):
    path = tmp_path / "missing.nml"
    path.write_text((INPUTS / "three_body.nml").read_text() + "\n&anchor\n  joint = 4\n  stiffness = 5.0\n/\n")
    with pytest.raises(pydriver.DeckError) as exc:
        pydriver.Model.from_deck(path)
    assert (exc.value.group, exc.value.key) == ("anchor", "point") and "required" in str(exc.value)
