"""How a value with its error bar prints (pydriver/number_format.py), the one text every output
uses for a headline: no digit the error bar already makes meaningless, no digit of the error bar
dropped that the value can show."""

import pytest

from pydriver.number_format import num, with_error


@pytest.mark.parametrize("value, error, text", [
    (15.957, 2.2, "16.0 +- 2.2"),            # the main job's life: 15.957 h carried noise digits
    (0.050370, 5.8e-5, "0.050370 +- 5.8e-05"),  # the error's second digit sets the place
    (16.350, 0.0076, "16.350 +- 0.0076"),     # capped at five significant digits of the value
    (243.15, 0.12, "243.15 +- 0.12"),
    (0.3, 5.0, "0.3 +- 5.0"),                 # an error larger than the value: one digit of it
    (15.957, None, "15.957"),                 # no error bar: the plain number
])
def test_a_value_prints_to_the_place_its_error_bar_allows(value, error, text):
    assert with_error(value, error) == text


def test_a_number_keeps_its_significant_digits():
    assert num(12.7964, 5) == "12.796"
    assert num(0.00050370, 3) == "5.04e-04"
    assert num(1234567.0, 3) == "1.23e+06"
