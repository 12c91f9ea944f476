"""Richardson extrapolation (pydriver/richardson.py) on synthetic convergence sequences.

Tolerances: the inputs are O(1) values whose grid-to-grid changes are O(1e-3 .. 1e-2), so
each change carries a rounding error of ~1e-16 absolute, ~1e-13 relative. Orders (logarithms
of ratios of changes) and extrapolated values are therefore good to ~1e-13; the asserts use
1e-12 (or 1e-13 for absolute errors of values near 1), unless a bound is derived in the test.
"""

import math

import numpy as np
import pytest

from pydriver.richardson import Extrapolation, richardson, richardson_table

H = (1.0 / 8.0, 1.0 / 16.0, 1.0 / 32.0)          # grids n = 8, 16, 32: coarse to fine


def assert_all_finite(e: Extrapolation):
    """Every number of a result is finite, and any doubt is a sentence (the module's promise)."""
    numbers = [*e.values, e.extrapolated, e.observed_order, e.error_estimate, e.expected_order,
               e.order_used]
    assert all(math.isfinite(x) for x in numbers), e
    assert e.error_estimate >= 0.0, e
    if e.warning is None:
        # No doubt: the observed order was positive and is the one used.
        assert e.observed_order > 0.0 and e.order_used == e.observed_order, e
    else:
        # A doubt is a sentence that says which order was used instead (an empty or non-text
        # warning would also make order_used fall back to the observed order silently).
        assert isinstance(e.warning, str) and "expected order" in e.warning, e
        assert e.order_used == e.expected_order, e


@pytest.mark.parametrize("d", [0.4, -0.4])
def test_second_order_with_cubic_term(d):
    """f(h) = f0 + c h^2 + d h^3 on h = 1/8, 1/16, 1/32.

    With changes D1 = f(2h) - f(4h), D2 = f(h) - f(2h) (h the finest size), the observed order
    is p = log2(D1/D2) = 2 + log2(1 + 28 d h / (12 c + 28 d h)), and the extrapolation with p,
    f(h) + D2^2 / (D1 - D2), leaves exactly R - f0 = 16 d h^3 / (9 + 49 d h / c): an O(d h^3)
    error, bounded by (16/9) |d| h^3 / (1 - 49 |d| h / (9 c)) (about 1.97 |d| h^3 here).
    """
    f0, c = 1.3, 0.7
    e = richardson(*(f0 + c * h**2 + d * h**3 for h in H))
    h = H[-1]
    assert e.warning is None
    assert abs(e.observed_order - 2.0) <= 0.2                      # the brief's requirement
    p_exact = 2.0 + math.log2(1.0 + 28.0 * d * h / (12.0 * c + 28.0 * d * h))
    assert e.observed_order == pytest.approx(p_exact, rel=0.0, abs=1e-12)
    assert e.order_used == e.observed_order
    residual = e.extrapolated - f0
    assert residual == pytest.approx(16.0 * d * h**3 / (9.0 + 49.0 * d * h / c), rel=0.0, abs=1e-13)
    bound = 16.0 / 9.0 * abs(d) * h**3 / (1.0 - 49.0 * abs(d) * h / (9.0 * c))
    assert abs(residual) <= bound + 1e-13
    # The estimate |R - fine| misses the true error |fine - f0| by at most |R - f0|.
    true_error = abs(e.values[2] - f0)
    assert abs(e.error_estimate - true_error) <= abs(residual) + 1e-13


def test_first_order_sequence_is_exact():
    """f0 + c h exactly: observed order 1 and the exact f0 (rounding only, see module docstring)."""
    f0, c = 1.0, 0.3
    e = richardson(*(f0 + c * h for h in H), expected_order=1.0)
    assert e.warning is None
    assert e.observed_order == pytest.approx(1.0, rel=0.0, abs=1e-12)
    assert e.extrapolated == pytest.approx(f0, rel=0.0, abs=1e-13)
    assert e.error_estimate == pytest.approx(c * H[-1], rel=1e-12, abs=0.0)


def test_ratio_three():
    """A refinement ratio other than 2: f0 + c h^2 on h, h/3, h/9 gives p = 2 and f0."""
    f0, c, h = -2.5, 4.0, 0.3
    e = richardson(*(f0 + c * (h / 3.0**k) ** 2 for k in range(3)), ratio=3.0)
    assert e.warning is None
    assert e.observed_order == pytest.approx(2.0, rel=0.0, abs=1e-12)
    assert e.extrapolated == pytest.approx(f0, rel=1e-13, abs=0.0)


@pytest.mark.parametrize("order, expected, far", [(4.0, 2.0, True), (1.0, 2.0, True), (2.4, 2.0, False)])
def test_order_far_from_expected_warns_and_uses_expected(order, expected, far):
    """An observed order outside expected +- 0.5 (4 or 1 for 2) warns, quoting both orders, and
    the extrapolation uses the expected order: fine + (fine - medium) / (2^2 - 1). An order
    within the tolerance (2.4) is used as observed."""
    f0, c = 0.75, 1.0
    coarse, medium, fine = (f0 + c * h**order for h in H)
    e = richardson(coarse, medium, fine, expected_order=expected)
    assert e.observed_order == pytest.approx(order, rel=0.0, abs=1e-12)
    assert_all_finite(e)
    if far:
        assert e.warning is not None
        assert f"observed order {order:.3g} is far from the expected order {expected:g}" in e.warning
        assert "asymptotic range" in e.warning
        assert e.order_used == expected
        assert e.extrapolated == pytest.approx(fine + (fine - medium) / 3.0, rel=1e-14, abs=0.0)
    else:
        assert e.warning is None
        assert e.extrapolated == pytest.approx(f0, rel=1e-12, abs=0.0)   # exact power law


@pytest.mark.parametrize("value", [1.7, 0.0, -3.0e-5, 2.0e200])
def test_identical_values_are_converged(value):
    """All three equal: converged, the value itself (exactly), error 0, order reported as the
    expected one, no warning and no NaN (nothing is divided by the zero changes)."""
    e = richardson(value, value, value, expected_order=2.0)
    assert e.extrapolated == value and e.error_estimate == 0.0
    assert e.observed_order == 2.0 and e.warning is None
    assert_all_finite(e)


def test_oscillating_sequence_warns():
    """Changes of opposite sign: "oscillating convergence", extrapolated with the expected order
    (1.5 + (1.5 - 2) / 3, to 1e-15 relative: a single division)."""
    e = richardson(1.0, 2.0, 1.5)
    assert e.warning is not None and e.warning.startswith("oscillating convergence")
    assert e.order_used == 2.0
    assert e.extrapolated == pytest.approx(1.5 - 0.5 / 3.0, rel=1e-15, abs=0.0)
    assert_all_finite(e)


def test_medium_equal_to_fine():
    """medium == fine != coarse: no observed order (it would be infinite); the fine value with
    error 0, the expected order reported, and a warning that says so."""
    e = richardson(1.0, 2.0, 2.0)
    assert e.extrapolated == 2.0 and e.error_estimate == 0.0
    assert e.observed_order == 2.0
    assert "observed order is undefined" in e.warning
    assert_all_finite(e)


def test_coarse_equal_to_medium():
    """coarse == medium != fine: no trend (observed order -inf); expected order, with a warning."""
    e = richardson(2.0, 2.0, 1.0)
    assert "no convergence trend" in e.warning
    assert e.extrapolated == pytest.approx(1.0 - 1.0 / 3.0, rel=1e-15, abs=0.0)
    assert_all_finite(e)


def test_diverging_sequence_warns():
    """Growing changes (observed order < 0) are not used even with a wide tolerance."""
    e = richardson(1.0, 1.1, 1.5, expected_order=0.5, order_tolerance=5.0)
    assert e.observed_order < 0.0 and "not positive" in e.warning
    assert_all_finite(e)


def test_outputs_are_always_finite():
    """Random triples, many with ties, zeros, sign changes and magnitudes from 1e-300 to 1e300,
    random orders, ratios and tolerances: every number returned is finite."""
    rng = np.random.default_rng(7)
    pools = [lambda: rng.normal(), lambda: float(rng.integers(-1, 2)),
             lambda: rng.normal() * 10.0 ** rng.integers(-300, 300), lambda: 0.0]
    for _ in range(3000):
        triple = [pools[rng.integers(len(pools))]() for _ in range(3)]
        e = richardson(*triple, expected_order=rng.uniform(0.5, 4.0), ratio=rng.uniform(1.1, 4.0),
                       order_tolerance=rng.uniform(0.0, 2.0))
        assert_all_finite(e)


@pytest.mark.parametrize("kwargs", [{"coarse": math.nan}, {"fine": math.inf}, {"ratio": 1.0},
                                    {"ratio": 0.5}, {"expected_order": 0.0},
                                    {"order_tolerance": -0.1}, {"medium": "1.0x"}])
def test_bad_arguments_are_refused(kwargs):
    """Non-finite inputs and meaningless parameters raise ValueError, never return NaN."""
    args = {"coarse": 1.0, "medium": 0.5, "fine": 0.4, **kwargs}
    with pytest.raises(ValueError, match="richardson"):
        richardson(**args)


def test_overflow_is_an_error_not_inf():
    """An extrapolated value beyond the float range raises instead of returning inf."""
    with pytest.raises(ValueError, match="overflows"):
        richardson(1.0e308, 1.5e308, 1.7e308, expected_order=1.0)


def test_richardson_table():
    """One row per quantity, in order, with the numbers of richardson() (identical floats)."""
    values = {"F_B_z": tuple(75.0 + 2.0 * h**2 for h in H), "f1_hz": (1.0, 2.0, 1.5)}
    rows = richardson_table(values)
    assert [r["quantity"] for r in rows] == ["F_B_z", "f1_hz"]
    for row, triple in zip(rows, values.values()):
        e = richardson(*triple)
        assert (row["coarse"], row["medium"], row["fine"]) == e.values
        assert row["extrapolated"] == e.extrapolated and row["error_estimate"] == e.error_estimate
        assert row["observed_order"] == e.observed_order and row["order_used"] == e.order_used
        assert row["warning"] == e.warning
    assert rows[0]["warning"] is None and rows[1]["warning"].startswith("oscillating")
    with pytest.raises(ValueError, match="'bad'"):
        richardson_table({"bad": (1.0, 2.0)})


# -- the physical range (issue 35) ---------------------------------------------------------------

def test_an_extrapolation_below_zero_or_with_an_error_bar_beyond_it_is_no_result():
    """234.4, 236.1, 0.0119 rpm (a finest level on other modes) extrapolate to -78.7 rpm: below
    0.  4, 2, 1 Hz (halving: order 1) extrapolate with the expected order to 0.667 Hz with an
    error estimate of at least the last change, 1 Hz: larger than the value.  Converging
    values pass."""
    from pydriver.richardson import departing_level, level_text, outside_physical_range
    below = richardson(234.4, 236.1, 0.0119)
    assert below.extrapolated < 0.0 and "below 0" in outside_physical_range(below)
    wide = richardson(4.0, 2.0, 1.0)
    assert wide.extrapolated == pytest.approx(2.0 / 3.0) and wide.error_estimate >= 1.0
    assert "exceeds the value" in outside_physical_range(wide)
    assert outside_physical_range(richardson(15.0, 15.8, 16.0)) is None
    assert outside_physical_range(richardson(15.0, 15.8, 16.0), low=16.5) is not None
    assert departing_level([234.4, 236.1, 0.0119]) == 2 and departing_level([4.0, 2.0, 1.0]) == 0
    assert departing_level([1.0, 2.0]) is None
    assert level_text(2, [11, 22, 44]) == "n = 44" and level_text(None, [11, 22]) == "n = 11 or n = 22"


def test_refined_frequencies_outside_the_physical_range_are_left_out():
    """pydriver.analyses.refinement.extrapolate: a frequency whose levels halve (4, 2, 1 Hz) is
    no result (not in the quantities, a warning naming it and the coarse level), a converging
    one (15.0, 15.8, 16.0 Hz) is extrapolated as before; a signed reaction whose error bar
    exceeds it is a result (it may be near 0)."""
    from pydriver.analyses.refinement import extrapolate
    summaries = [{"analysis": "static", "frequencies_hz": [f1, f2], "reactions": {"A": {"F": [fx, 0.0, 0.0],
                                                                                       "M": [0.0, 0.0, 0.0]}}}
                 for f1, f2, fx in ((4.0, 15.0, 0.3), (2.0, 15.8, -0.2), (1.0, 16.0, 0.1))]
    refinement, warnings = extrapolate(summaries, [8, 16, 32], 2.0)
    q = refinement["quantities"]
    assert "f1 [Hz]" not in q and q["f2 [Hz]"]["extrapolated"] == pytest.approx(16.0 + 0.2 / 3.0)
    assert "F_A x [N]" in q
    (said,) = [w for w in warnings if "physical range" in w]
    assert "f1 [Hz] (4, 2, 1" in said and "n = 8 departs" in said
