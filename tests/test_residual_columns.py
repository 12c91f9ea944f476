"""The sensitivity residual's columns F_y s + F_y' s' by the whole derivative matrices (issue 39,
item 2: ``ggl_residual_matrix_columns``, one Carpentier-Mansard pass and BLAS products) against
the tangent sweeps they replace where they are cheaper (``ggl_residual_tangent_columns``, the
independent check), on every deck with a distinct physics term (the decks of
tests/test_analytic_jacobian.py), at random states off the constraint manifold.

Tolerance 1e-12 relative to the largest entry (the issue's): both routes are exact derivatives,
summed in a different order, so they differ by round-off, ~1e-15 relative measured; a wrong or
missing term (a load's, the moving clamp's, the hub frame's) is of the order of the entries.
"""

import numpy as np
import pytest

import pydriver
from pydriver import core_probes as probes
from conftest import INPUTS
from test_analytic_jacobian import DECKS, _random_state

#: The issue's agreement of the analytic derivatives with the tangent sweeps (module doc).
RELATIVE = 1.0e-12


@pytest.mark.parametrize("stem", DECKS)
def test_matrix_columns_are_the_tangent_sweeps(stem):
    """Every column by the matrices equals its tangent sweep within 1e-12 of the largest entry,
    for 1, 5 and nq + 3 columns (one, a few, and more columns than coordinates: the route the
    sensitivity residuals then take)."""
    m = pydriver.Model.from_deck(INPUTS / f"{stem}.nml")
    t, y, yd = _random_state(m, 11)
    rng = np.random.default_rng(12)
    for width in (1, 5, m.nq + 3):
        dy = rng.standard_normal((len(y), width))
        dyd = rng.standard_normal((len(y), width))
        swept = probes.residual_tangent_columns(m.core, y, yd, dy, dyd, t=t, route="sweeps")
        whole = probes.residual_tangent_columns(m.core, y, yd, dy, dyd, t=t, route="matrices")
        assert np.all(np.isfinite(whole))
        assert np.abs(whole - swept).max() <= RELATIVE * np.abs(swept).max()


def test_the_sensitivity_residuals_take_the_cheaper_route():
    """The route the monodromy and the parameter sensitivities take: the sweeps' bits for a few
    columns, the matrices' bits for at least as many columns as coordinates on a short chain
    (ggl_residual_columns' rule, src_fortran/ggl_residual.f90), on the main job's cable."""
    m = pydriver.Model.from_deck(INPUTS / "uh60_part2_forward_flight_cable.nml")
    t, y, yd = _random_state(m, 5)
    rng = np.random.default_rng(6)
    for width, route in ((4, "sweeps"), (max(16, m.nq), "matrices")):
        dy = rng.standard_normal((len(y), width))
        dyd = rng.standard_normal((len(y), width))
        chosen = probes.residual_tangent_columns(m.core, y, yd, dy, dyd, t=t, route="chosen")
        assert np.array_equal(chosen, probes.residual_tangent_columns(m.core, y, yd, dy, dyd, t=t, route=route))
