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
