"""Numbers as a person reads them: significant digits without exponent clutter near 1, a strain
also in percent.  Every printed number of the terminal summary, the verdicts and report.html
goes through here, so the same value prints the same way everywhere."""

from __future__ import annotations

import math


def num(x: float, digits: int = 5) -> str:
    """A number with ``digits`` significant digits, without exponent clutter near 1."""
    if x == 0 or not math.isfinite(x):
        return f"{x:g}"
    if 1e-3 <= abs(x) < 1e6:
        decimals = max(0, digits - 1 - int(math.floor(math.log10(abs(x)))))
        return f"{x:.{decimals}f}"
    return f"{x:.{digits - 1}e}"


def value_with_unit(value: float, unit: str) -> str:
    """A value with its unit (a strain, unit '-', also in percent)."""
    return f"{num(value, 3)} ({num(100 * value, 3)} %)" if unit == "-" else f"{num(value, 3)} {unit}"


def with_error(value: float, error: float | None, digits: int = 5) -> str:
    """``value +- error``: the error with two significant digits and the value to the same decimal
    place (at most ``digits`` significant digits), so no digit is printed that the error bar
    already makes meaningless (15.957 +- 2.2 prints as 16.0 +- 2.2)."""
    if not error or not math.isfinite(error) or not math.isfinite(value) or value == 0:
        return num(value, digits) + ("" if error is None else f" +- {num(error, 2)}")
    error_place = int(math.floor(math.log10(abs(error)))) - 1  # place of the error's 2nd digit
    value_place = int(math.floor(math.log10(abs(value)))) - (digits - 1)
    place = max(error_place, value_place)
    shown_digits = int(math.floor(math.log10(abs(value)))) - place + 1
    if shown_digits < 1:  # the error bar is larger than the value: one digit of it
        return f"{num(value, 1)} +- {num(error, 2)}"
    return f"{num(value, shown_digits)} +- {num(error, 2)}"
