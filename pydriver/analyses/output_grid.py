"""The output times of a dynamic run and the samples where IDA starts afresh, counted in whole
steps of the deck's decimal ``dt_out`` (issue 35).

A time built in binary drifts off the decimal one: 3 * 0.05 is 0.15000000000000002, not the
double a deck's ``t_end = 0.15`` gives.  A run continued from ``t_end = 0.15`` then started IDA
2.8e-17 s away from where the uninterrupted run (``checkpoint_interval = 0.05``) cut, and the
two differed by the solver's tolerance (2.5e-4 deg/s in the decay deck) instead of not at all.

Here sample i lies at i * dt_out computed exactly in decimal and rounded once to the nearest
double, dt_out being read as the shortest decimal that gives its double (``repr``: what the
deck said).  So sample 150 of ``dt_out = 0.001`` is the double of 0.15, the same double as
``t_end = 0.15``, and a segment boundary k * interval is the sample k * (interval / dt_out):
integers throughout, no sum or product of rounded times.  A ``dt_out`` with no short decimal
form (more digits than a double's integer range can scale exactly) falls back to
i * dt_out in binary, one rounding per sample.
"""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np

#: Integers below this are exact doubles (2**53).
_EXACT_INT = 2 ** 53
#: A t_end within this fraction of a step of a sample is that sample (the deck's text may
#: have been computed, e.g. 0.30000000000000004 for 0.3).
_ON_GRID = 1e-12


def decimal(x: float) -> Fraction:
    """The shortest decimal that rounds to the double ``x``, as an exact fraction."""
    return Fraction(repr(float(x)))


def step_times(n: int, dt: float) -> np.ndarray:
    """i * dt for i = 0 ... n with dt read as its shortest decimal, each rounded once.

    Both factors are integers (i * numerator) and a power of ten's divisor; when both are below
    2**53 they are exact doubles and IEEE division rounds their exact quotient once, as the
    integer division of Python would.
    """
    step = decimal(dt)
    num, den = step.numerator, step.denominator
    if n * num < _EXACT_INT and den < _EXACT_INT:
        return np.arange(n + 1, dtype=float) * float(num) / float(den)
    return np.arange(n + 1, dtype=float) * dt


def output_times(t_end: float, dt_out: float) -> np.ndarray:
    """0, dt_out, 2 dt_out, ... (:func:`step_times`) and exactly ``t_end`` last (never beyond
    it, never short of it)."""
    ratio = decimal(t_end) / decimal(dt_out)
    n = math.floor(ratio * (1 + Fraction(_ON_GRID)))
    t = step_times(n, dt_out)
    if t[-1] < t_end - _ON_GRID * max(abs(t_end), dt_out):
        t = np.append(t, t_end)
    t[-1] = t_end
    return t


def interval_steps(interval: float, dt_out: float) -> int:
    """``checkpoint_interval`` in whole ``dt_out`` (the deck's rules require a multiple)."""
    ratio = decimal(interval) / decimal(dt_out)
    return int(ratio) if ratio.denominator == 1 else max(1, round(interval / dt_out))


def output_grid(t_end: float, dt_out: float, interval: float = 0.0, restart_at: float | None = None):
    """(times, segment starts): the output times and the indices of the samples where IDA
    starts afresh: the first, every ``interval / dt_out``-th (``&solver checkpoint_interval``)
    and a continuation's start ``restart_at``.

    Raises
    ------
    ValueError
        ``restart_at`` is not one of the output times.
    """
    t = output_times(t_end, dt_out)
    last = len(t) - 1
    starts = {0}
    if interval > 0.0:
        m = interval_steps(interval, dt_out)
        starts.update(range(m, last, m))
    if restart_at is not None and restart_at < t[-1]:
        i = int(np.argmin(np.abs(t[:last] - restart_at)))
        if abs(t[i] - restart_at) > 1e-9 * max(dt_out, abs(restart_at)):
            raise ValueError(f"t = {restart_at!r} s is not on the output grid of dt_out = {dt_out:g} s")
        t[i] = restart_at            # the run being continued ended at exactly this double
        starts.add(i)
    return t, sorted(starts)


def is_segment_start(t_end: float, dt_out: float, interval: float, t: float) -> bool:
    """Whether the uninterrupted run to ``t_end`` starts IDA afresh at exactly ``t`` (so that a
    continuation from there makes the same calls: bit for bit the same run)."""
    times, starts = output_grid(t_end, dt_out, interval)
    return any(times[i] == t for i in starts)
