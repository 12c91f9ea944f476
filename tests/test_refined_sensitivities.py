"""Converged design sensitivities (issue 24): ``&refinement levels = 3`` with ``&design`` gives each
output's sensitivity at n, 2n, 4n and its Richardson extrapolation
(pydriver/analyses/refined_sensitivities.py).

The independent check is the definition: the converged sensitivity is the derivative of the
converged value.  So it must agree with the central difference of the refined runs' own
extrapolated values (``summary['refinement']``, whole refined runs at p +- h).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import pydriver
from pydriver import Model
from pydriver.analyses.refined_sensitivities import name_at_level

from conftest import INPUTS

CABLE = INPUTS / "uh60_part2_forward_flight_cable.nml"
#: Relative step of the whole-run differences: truncation ~h^2 ~ 1e-8 relative, the Newton
#: tolerance's noise on an extrapolated value (~1e-10, amplified by the extrapolation's weights,
#: at most ~3) over 2h ~ 1e-6 relative.
STEP = 1.0e-4


def _extrapolated(base: Model, parameter: str, value: float, quantity: str) -> float:
    group_key, _, index = parameter.partition("(")
    if index:
        array = np.array(base.deck[group_key], float)
        array[int(index.rstrip(")")) - 1] = value
        change = {group_key: array}
    else:
        change = {group_key: value}
    return pydriver.run_deck(base.with_changes(change)).summary["refinement"]["quantities"][quantity]["extrapolated"]


@pytest.mark.parametrize("analysis, parameter, output, quantity", [
    ("static", "cable.ei", "FA_x", "F_A x [N]"),
    ("static", "chain.total_length", "FB_z", "F_B z [N]"),
    ("static", "clamp_b.position(3)", "MA_y", "M_A y [Nm]"),
    ("modal", "chain.total_length", "f1_hz", "f1 [Hz]"),
    ("modal", "cable.ei", "f3_hz", "f3 [Hz]"),
])
def test_converged_sensitivity_is_the_derivative_of_the_converged_value(analysis, parameter, output, quantity):
    """Measured (n = 11, 22, 44): the two agree to 3e-6 ... 4.5e-5 relative, while the error
    estimates are 2.6e-4 ... 2.8e-3 of the values.  Both are Richardson extrapolations of one
    asymptotic expansion and differ by the derivative of the observed order, a term beyond it:
    bound 2e-4 relative and a tenth of the error estimate, whichever is larger (the bar must
    be far from tight: it says the extrapolations agree well inside their error bars)."""
    base = Model.from_deck(CABLE).with_changes({"case.analysis": analysis, "refinement.levels": 3})
    result = pydriver.run_deck(base.with_changes({"design.parameters": [parameter]}))
    refined = result.summary["sensitivities"]["refined"]
    assert refined["n"] == [11, 22, 44]
    value = refined["d_output_d_parameter"][output][parameter]
    error = refined["error_estimate"][output][parameter]
    p = result.summary["sensitivities"]["parameters"][parameter]["value"]
    h = STEP * max(abs(p), 1.0)
    fd = (_extrapolated(base, parameter, p + h, quantity) - _extrapolated(base, parameter, p - h, quantity)) / (2 * h)
    assert math.isfinite(value) and error > 0.0
    assert abs(value - fd) <= max(2.0e-4 * abs(fd), 0.1 * error), (value, fd, error)
    # The extrapolation moves the sensitivity beyond the finest level's by more than the check's
    # bar: the check could tell a refined sensitivity from the finest level's.
    row = result.extra["tables"]["sensitivities_refined.csv"]
    k = next(i for i, (o, q) in enumerate(zip(row["output"], row["parameter"])) if (o, q) == (output, parameter))
    assert abs(row["n44"][k] - fd) > abs(value - fd)


def test_joints_are_matched_by_material_point():
    """Joint j of n bodies is joint (j - 1) k + 1 of k n bodies; modes and reactions keep their names."""
    assert name_at_level("bending3_Nm", 4) == "bending9_Nm"
    assert name_at_level("strain1_peak", 2) == "strain1_peak"
    assert name_at_level("damage_per_hour11", 2) == "damage_per_hour21"
    assert name_at_level("f3_hz", 4) == "f3_hz"
    assert name_at_level("FA_x_max", 4) == "FA_x_max"


def test_refined_sensitivities_file(tmp_path):
    model = Model.from_deck(CABLE).with_changes(
        {"case.analysis": "static", "refinement.levels": 2, "design.parameters": ["cable.ei"]})
    result = pydriver.run_deck(model, out=tmp_path / "out")
    header = (tmp_path / "out" / "sensitivities_refined.csv").read_text().splitlines()[0]
    for cell in ("output [-]", "parameter [-]", "n11 [*]", "n22 [*]", "extrapolated [*]", "error_estimate [*]"):
        assert cell in header
    # The finest run's own sensitivities are as without refinement, with joints numbered at n = 22.
    assert "bending21_Nm" in result.summary["sensitivities"]["d_output_d_parameter"]
    assert "bending11_Nm" in result.summary["sensitivities"]["refined"]["d_output_d_parameter"]
    assert "bending21_Nm" not in result.summary["sensitivities"]["refined"]["d_output_d_parameter"]


def test_an_element_of_a_per_body_key_is_refused_with_refinement():
    with pytest.raises(pydriver.DeckError) as err:
        pydriver.run_deck(Model.from_deck(CABLE).with_changes(
            {"case.analysis": "static", "refinement.levels": 2, "design.parameters": ["drag.cd(3)"]}))
    assert (err.value.group, err.value.key) == ("design", "parameters")
    assert "another part of the cable" in err.value.reason
