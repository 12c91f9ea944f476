"""The analytic Jacobian of the thesis's ODE route (issue 39, item 4): d(y')/dy of y' = (v, vdot),
vdot from the Baumgarte-stabilised eq. 3.55, as GSL msbdf gets it (``src_fortran/ode_integrator.f90``,
``jacobian_analytic``), against central differences of the right-hand side itself.

The analytic matrix differentiates [M G^T; G 0][vdot; -lambda] = [k; -b - w^2 g - 2 w G v] with the
core's whole-matrix derivatives (eom_derivatives, constraint_derivatives); only d(G vdot + b)/d(q, v),
which needs the constraints' second derivatives, is a central difference inside.  The check here
is independent of both: central differences of y' (the probe's ``ydot``).  Their error is
truncation ~h^2 |y'''| plus round-off ~eps cond(eq. 3.55) |y'| / h, so the step is chosen per
chain: on the closed UH-60 chain (axial inertias ~1e-6 of the bending ones) eq. 3.55 is
ill-conditioned and round-off dominates (disagreement 1.6e-6 of the column's largest entry at
h = 1e-4, 5.6e-6 at 3e-5, 9.6e-6 at 1e-5, while the analytic matrix stays put): h = 1e-4; the
open UH-60 chain is truncation-bound (1.5e-5 at 1e-4, 1.4e-6 at 3e-5, 1.5e-6 at 1e-5): h = 1e-5;
the six-link chain 4e-8 at 3e-5.  Bound: 1e-4 of each column's largest entry, a margin of >= 60
over the worst measured (1.6e-6) for any x86-64 CPU.

(The forward differences the route used before, step sqrt(eps) |y_j|, sit inside that round-off:
up to 47 % off in single columns of the closed UH-60 chain; ``differences`` of the probe.)
"""

from __future__ import annotations

import numpy as np
import pytest

import pydriver
from pydriver import core_probes as probes
from pydriver.analyses.dynamics import start_state
from pydriver.deckfile import read_deck, validate
from conftest import INPUTS

#: Central-difference step [rad, rad/s] per chain (module docstring) and the bound relative to
#: each column's largest entry.
STEP = {"six_link_dynamic": 3.0e-5, "uh60_part2_decay": 1.0e-4, "uh60_part2_decay_open": 1.0e-5}
RELATIVE = 1.0e-4


def _open_chain(stem: str) -> pydriver.Model:
    """The deck's chain with clamp B removed (nc = 0: no constraint rows at all)."""
    d = read_deck(INPUTS / f"{stem}.nml")
    raw = {g: dict(v) for g, v in d.raw.items() if g != "clamp_b"}
    starts = {g: dict(v) for g, v in d.starts.items() if g != "clamp_b"}
    deck = validate(raw, starts, f"{stem}_open")
    deck.path = d.path
    return pydriver.Model(deck)


MODELS = {"six_link_dynamic": lambda: pydriver.Model.from_deck(INPUTS / "six_link_dynamic.nml"),
          "uh60_part2_decay": lambda: pydriver.Model.from_deck(INPUTS / "uh60_part2_decay.nml"),
          "uh60_part2_decay_open": lambda: _open_chain("uh60_part2_decay")}


def _state(m, seed):
    """A random state near the consistent start: q off the constraint manifold (so Baumgarte's
    w^2 g and 2 w G v act), rates of order 0.3 rad/s, a time inside the pulse window."""
    q0, v0 = start_state(m)
    start = m.core.consistent_start(q0, v0)
    rng = np.random.default_rng(seed)
    q = start["q"] + 1e-3 * rng.standard_normal(m.nq)
    v = start["v"] + 0.3 * rng.standard_normal(m.nq)
    return float(rng.uniform(0.0, 0.09)), q, v


def _central(m, t, q, v, w, h):
    """Central differences of y' = (v, vdot) by q and v, column by column, step h."""
    nq = m.nq
    out = np.empty((2 * nq, 2 * nq))
    for k in range(nq):
        e = np.zeros(nq)
        e[k] = h
        f = lambda qq, vv: probes.ode_jacobian(m.core, qq, vv, w, t=t)["ydot"]  # noqa: E731
        out[:, k] = (f(q + e, v) - f(q - e, v)) / (2 * h)
        out[:, nq + k] = (f(q, v + e) - f(q, v - e)) / (2 * h)
    return out


@pytest.mark.parametrize("baumgarte", [0.0, 50.0])
@pytest.mark.parametrize("case", list(MODELS))
def test_analytic_ode_jacobian_matches_central_differences(case, baumgarte):
    m = MODELS[case]()
    for seed in (1, 2):
        t, q, v = _state(m, seed)
        jac = probes.ode_jacobian(m.core, q, v, baumgarte, t=t)
        analytic = jac["analytic"]
        reference = _central(m, t, q, v, baumgarte, STEP[case])
        scale = np.abs(reference).max(axis=0)
        assert np.all(scale > 0), "a column of zeros would make the check vacuous"
        worst = float(np.max(np.abs(analytic - reference).max(axis=0) / scale))
        assert worst < RELATIVE, f"{case}, w = {baumgarte}, seed {seed}: column-relative {worst:.1e}"
        # The (q, v) -> q' block is exactly (0, I): no differences involved.
        nq = m.nq
        assert np.array_equal(analytic[:nq, :nq], np.zeros((nq, nq)))
        assert np.array_equal(analytic[:nq, nq:], np.eye(nq))
