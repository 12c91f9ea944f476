"""Fatigue post-processing of load histories: rainflow cycles, Basquin or tabulated S-N curve, Miner damage.

Cycles are counted with the ``rainflow`` package, which implements the three-point rainflow
algorithm of ASTM E1049-85, section 5.4.4, and reports half cycles with a count of 0.5. Damage
is the Palmgren-Miner sum over a Basquin S-N curve written on the cycle *amplitude*
(half the range). The S-N parameters of a real cable jacket are not known to the project, so
nothing here has default S-N values: callers always pass an :class:`SNCurve`.

The intended input is the steady periodic state of a rotor run: one column per joint and
quantity (e.g. ``"M_bend_3"``), sampled over a whole number of revolutions.
"""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass

import numpy as np
import rainflow

#: log of the largest float: damage and amplitudes are computed as logarithms and compared with
#: it before exp(), so any positive finite S-N parameters give a number or a clean ValueError,
#: never an OverflowError or inf.
_LOG_MAX = math.log(sys.float_info.max)


def _positive_finite(name: str, value) -> float:
    """Return ``value`` as a float, or raise ValueError naming ``name`` if not finite and > 0."""
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number, got {value!r}") from None
    if not math.isfinite(x) or x <= 0.0:
        raise ValueError(f"{name} must be finite and > 0, got {value!r}")
    return x


@dataclass
class SNCurve:
    """Basquin S-N curve on the cycle amplitude, with an optional endurance cut-off.

    ``N(S_a) = reference_cycles * (S_a / reference_amplitude) ** (-exponent)`` cycles to
    failure at the constant amplitude ``S_a = range / 2``.

    Parameters
    ----------
    exponent : float
        Basquin exponent m > 0 (the inverse slope of the S-N curve in log-log axes).
    reference_amplitude : float
        Amplitude S_ref > 0 at which the curve passes through ``reference_cycles``, in the unit
        of the signal that is counted (N m for a bending moment, N for a force, ...).
    reference_cycles : float
        Cycles to failure N_ref > 0 at ``reference_amplitude``.
    endurance_amplitude : float, optional
        Optional cut-off: cycles whose amplitude is at or below it do no damage (infinite
        life). The default 0.0 means no cut-off (only cycles of zero amplitude are harmless).

    Raises
    ------
    ValueError
        If a parameter is not finite, or not > 0 (``endurance_amplitude``: not >= 0).
    """

    exponent: float
    reference_amplitude: float
    reference_cycles: float
    endurance_amplitude: float = 0.0

    def __post_init__(self):
        self.exponent = _positive_finite("SNCurve.exponent", self.exponent)
        self.reference_amplitude = _positive_finite("SNCurve.reference_amplitude",
                                                    self.reference_amplitude)
        self.reference_cycles = _positive_finite("SNCurve.reference_cycles", self.reference_cycles)
        try:
            endurance = float(self.endurance_amplitude)
        except (TypeError, ValueError):
            endurance = math.nan
        if not math.isfinite(endurance) or endurance < 0.0:
            raise ValueError("SNCurve.endurance_amplitude must be finite and >= 0, got "
                             f"{self.endurance_amplitude!r}")
        self.endurance_amplitude = endurance

    def cycles_to_failure(self, amplitude) -> np.ndarray:
        """Cycles to failure at the given constant amplitude(s).

        Parameters
        ----------
        amplitude : float or array_like
            Cycle amplitude(s) S_a = range / 2, >= 0, in the unit of ``reference_amplitude``.

        Returns
        -------
        numpy.ndarray
            N(S_a), same shape as ``amplitude``; ``inf`` at or below ``endurance_amplitude``
            (and so always at zero amplitude).

        Raises
        ------
        ValueError
            If an amplitude is negative, NaN or infinite.
        """
        a = np.asarray(amplitude, dtype=float)
        if not np.all(np.isfinite(a)) or np.any(a < 0.0):
            raise ValueError("cycles_to_failure: amplitudes must be finite and >= 0")
        damaging = a > self.endurance_amplitude
        n = np.full(a.shape, np.inf)
        # Only damaging amplitudes are raised to -m: a zero amplitude would divide by zero.
        # A tiny one may still overflow to inf cycles, which is the right limit: no damage.
        with np.errstate(over="ignore"):
            n[damaging] = self.reference_cycles * (a[damaging] / self.reference_amplitude) ** (-self.exponent)
        return n


@dataclass
class TabulatedSNCurve:
    """S-N curve given as points (amplitude, cycles to failure), e.g. from a fatigue test report.

    Between the points, log N is interpolated linearly in log S_a (each segment a Basquin
    curve); beyond the first and the last point the end segments are extended (a cycle above
    the highest tested amplitude fails sooner, one below the lowest still does damage: the
    extrapolation is conservative where the test data end without a run-out).  The endurance
    cut-off, if any, is given separately: amplitudes at or below ``endurance_amplitude`` do no
    damage (for a table that ends at a run-out, its last amplitude).

    Parameters
    ----------
    amplitudes : array_like
        Cycle amplitudes S_a > 0, strictly decreasing as ``cycles`` increase.
    cycles : array_like
        Cycles to failure N > 0 at those amplitudes, strictly increasing; at least 2 points.
    endurance_amplitude : float, optional
        Amplitudes at or below it do no damage (default 0: none).
    exponent : float, optional
        The exponent m of damage-equivalent amplitudes; default the least-squares slope of the
        table in log-log axes, -d log N / d log S_a.

    Raises
    ------
    ValueError
        Fewer than two points, a value not finite and > 0, or not monotonic.
    """

    amplitudes: np.ndarray
    cycles: np.ndarray
    endurance_amplitude: float = 0.0
    exponent: float | None = None

    def __post_init__(self):
        a = np.asarray(self.amplitudes, dtype=float).ravel()
        n = np.asarray(self.cycles, dtype=float).ravel()
        if a.size != n.size or a.size < 2:
            raise ValueError(f"an S-N table needs at least two points of amplitude and cycles "
                             f"(got {a.size} amplitudes, {n.size} cycle counts)")
        if not (np.all(np.isfinite(a)) and np.all(np.isfinite(n)) and np.all(a > 0.0) and np.all(n > 0.0)):
            raise ValueError("S-N table: every amplitude and cycle count must be finite and > 0")
        order = np.argsort(n)
        a, n = a[order], n[order]
        if np.any(np.diff(n) <= 0.0) or np.any(np.diff(a) >= 0.0):
            raise ValueError("S-N table: the amplitude must fall strictly as the cycles to failure rise "
                             "(one point per cycle count)")
        self.amplitudes, self.cycles = a, n
        self._log_a, self._log_n = np.log(a[::-1]), np.log(n[::-1])       # increasing log amplitude
        endurance = float(self.endurance_amplitude)
        if not math.isfinite(endurance) or endurance < 0.0:
            raise ValueError(f"SN table: endurance_amplitude must be finite and >= 0, got {self.endurance_amplitude!r}")
        self.endurance_amplitude = endurance
        if self.exponent is None:
            slope = np.polyfit(np.log(a), np.log(n), 1)[0]
            self.exponent = float(-slope)
        self.exponent = _positive_finite("SN table exponent", self.exponent)

    def log_cycles_to_failure(self, amplitude) -> np.ndarray:
        """log N at amplitudes > 0 (no cut-off): the log-log interpolation, end segments extended."""
        x = np.log(np.asarray(amplitude, dtype=float))
        la, ln = self._log_a, self._log_n
        inside = np.interp(x, la, ln)
        low = ln[0] + (x - la[0]) * (ln[1] - ln[0]) / (la[1] - la[0])
        high = ln[-1] + (x - la[-1]) * (ln[-1] - ln[-2]) / (la[-1] - la[-2])
        return np.where(x < la[0], low, np.where(x > la[-1], high, inside))

    def cycles_to_failure(self, amplitude) -> np.ndarray:
        """Cycles to failure at the given amplitude(s); ``inf`` at or below the cut-off."""
        a = np.asarray(amplitude, dtype=float)
        if not np.all(np.isfinite(a)) or np.any(a < 0.0):
            raise ValueError("cycles_to_failure: amplitudes must be finite and >= 0")
        damaging = a > self.endurance_amplitude
        n = np.full(a.shape, np.inf)
        with np.errstate(over="ignore"):
            n[damaging] = np.exp(self.log_cycles_to_failure(a[damaging]))
        return n

    def describe(self, unit: str = "") -> str:
        """The curve in words, for the fatigue description."""
        return (f"the S-N table of {self.amplitudes.size} points (amplitude {self.amplitudes[-1]:g} ... "
                f"{self.amplitudes[0]:g}{unit} at {self.cycles[0]:g} ... {self.cycles[-1]:g} cycles), log-log "
                "interpolated")


@dataclass
class Cycles:
    """Rainflow cycles of a load history.

    Attributes
    ----------
    ranges : numpy.ndarray
        Cycle ranges (max - min), > 0.
    means : numpy.ndarray
        Cycle means (max + min) / 2.
    counts : numpy.ndarray
        1.0 for a full cycle, 0.5 for a half cycle (ASTM E1049-85, 5.4.4).
    """

    ranges: np.ndarray
    means: np.ndarray
    counts: np.ndarray

    @property
    def amplitudes(self) -> np.ndarray:
        """Cycle amplitudes S_a = range / 2."""
        return 0.5 * self.ranges

    @property
    def total(self) -> float:
        """Number of cycles, half cycles counting 0.5."""
        return float(np.sum(self.counts))


def _as_signal(signal, name: str = "signal") -> np.ndarray:
    """The signal as a 1-D float array; ValueError if empty or not finite."""
    x = np.asarray(signal, dtype=float)
    if x.ndim != 1:
        raise ValueError(f"{name} must be one-dimensional, got shape {x.shape}")
    if x.size == 0:
        raise ValueError(f"{name} is empty")
    if not np.all(np.isfinite(x)):
        bad = int(np.flatnonzero(~np.isfinite(x))[0])
        raise ValueError(f"{name} holds a non-finite value (NaN or inf) at sample {bad}")
    return x


def close_period(signal) -> np.ndarray:
    """One period of a periodic signal, rotated to start at its global maximum and closed.

    Parameters
    ----------
    signal : array_like
        One period (or a whole number of periods) of a periodic steady state. Whether the
        last sample repeats the first does not matter: a repeated value is a plateau, which
        rainflow counting skips.

    Returns
    -------
    numpy.ndarray
        The samples from the (first) global maximum to the end, then those before it, then
        that maximum again, so that the history starts and ends at its largest peak.
    """
    x = _as_signal(signal)
    i = int(np.argmax(x))
    return np.concatenate([x[i:], x[:i], x[i:i + 1]])


def _pair_half_cycles(ranges, means, counts):
    """Merge half cycles of identical range and mean into full cycles.

    In a history that starts and ends at its global maximum, ASTM E1049 still counts the
    ranges that touch the starting point as half cycles, but they come in pairs over the same
    two extremes (max -> min and min -> max), with bit-identical range and mean: each pair is
    one closed loop of the periodic load. An unpaired half cycle would be kept as one, but a
    closed history does not leave any (tests/test_fatigue.py checks random periods).
    """
    out, pending = [], {}
    for r, m, c in zip(ranges, means, counts):
        if c == 1.0:
            out.append((r, m, 1.0))
        elif (r, m) in pending:
            out[pending.pop((r, m))] = (r, m, 1.0)
        else:
            pending[(r, m)] = len(out)
            out.append((r, m, 0.5))
    return out


def cycles(signal, periodic: bool = False) -> Cycles:
    """Rainflow cycles of a load history (ASTM E1049-85, 5.4.4, via ``rainflow``).

    Parameters
    ----------
    signal : array_like
        Load history, 1-D, finite (one sample per time step; any sampling).
    periodic : bool, optional
        If True, ``signal`` is one period (or a whole number of periods) of a periodic steady
        state. It is then rotated to start at its global maximum and closed by that sample
        again (:func:`close_period`), and the half cycles that ASTM E1049 reports at the
        start of such a closed history are paired into full cycles. Every cycle of the
        periodic load then counts as a full cycle and no half cycles remain. Without this the
        residue of the open history is counted as half cycles: a sine started at zero over k
        periods gives k - 1/2 cycles of the full range plus two half cycles of about half that
        range, i.e. one of its k largest cycles is counted as half a cycle.

    Returns
    -------
    Cycles
        Ranges, means and counts. Zero-range cycles (plateaus, a constant signal) are
        dropped: they are not load cycles and do no damage, so a constant signal has none.

    Raises
    ------
    ValueError
        If the signal is empty, not 1-D, or holds NaN or inf.
    """
    x = close_period(signal) if periodic else _as_signal(signal)
    found = [(rng, mean, count) for rng, mean, count, _, _ in rainflow.extract_cycles(x) if rng > 0.0]
    if periodic:
        found = _pair_half_cycles(*zip(*found)) if found else []
    if not found:
        return Cycles(np.zeros(0), np.zeros(0), np.zeros(0))
    r, m, c = (np.array(v, dtype=float) for v in zip(*found))
    return Cycles(ranges=r, means=m, counts=c)


def miner_damage(cyc: Cycles, sn: "SNCurve | TabulatedSNCurve") -> float:
    """Palmgren-Miner damage sum D = sum(n_i / N(S_a,i)).

    Parameters
    ----------
    cyc : Cycles
        Counted cycles (:func:`cycles`).
    sn : SNCurve or TabulatedSNCurve
        S-N curve on the amplitude; cycles at or below its endurance cut-off add nothing.

    Returns
    -------
    float
        Damage (failure at D = 1); 0.0 for no cycles.

    Raises
    ------
    ValueError
        If the damage exceeds the float range (typically an S-N curve in other units than
        the signal, e.g. MPa against Pa).
    """
    a = cyc.amplitudes
    damaging = a > sn.endurance_amplitude
    if not np.any(damaging):
        return 0.0
    a, n = a[damaging], cyc.counts[damaging]
    if isinstance(sn, TabulatedSNCurve):
        # log D = log sum n exp(-log N(a)), with the largest term factored out.
        terms = np.log(n) - sn.log_cycles_to_failure(a)
        top = float(np.max(terms))
        log_damage = top + math.log(float(np.sum(np.exp(terms - top))))
        if log_damage >= _LOG_MAX:
            raise ValueError(f"miner_damage: damage exceeds the float range (largest amplitude "
                             f"{float(np.max(a)):g} against the S-N table's {sn.amplitudes[0]:g} ... "
                             f"{sn.amplitudes[-1]:g}): check the units")
        return math.exp(log_damage)
    # n / N(a) = n (a / S_ref)^m / N_ref with the largest amplitude factored out, in logs:
    #   log D = m log(a_max / S_ref) - log N_ref + log sum n (a / a_max)^m,
    # every term finite for positive finite parameters (the sum is at least the largest
    # amplitude's count, 0.5), so only D itself can leave the float range.
    a_max = float(np.max(a))
    log_damage = (sn.exponent * (math.log(a_max) - math.log(sn.reference_amplitude)) - math.log(sn.reference_cycles)
                  + math.log(float(np.sum(n * (a / a_max) ** sn.exponent))))
    if log_damage >= _LOG_MAX:
        raise ValueError(f"miner_damage: damage exceeds the float range (largest amplitude {a_max:g} "
                         f"against reference amplitude {sn.reference_amplitude:g}, exponent {sn.exponent:g}): "
                         "check the units")
    return math.exp(log_damage)         # underflows to 0.0: no damage to double precision


def damage_equivalent_amplitude(cyc: Cycles, exponent: float, n_equivalent: float) -> float:
    """Damage-equivalent amplitude S_eq = (sum n_i S_a,i^m / n_equivalent)^(1/m).

    The constant amplitude that, applied ``n_equivalent`` times, gives the same Miner damage
    as the counted cycles on any Basquin curve of exponent m without a cut-off (the reference
    point cancels). With a cut-off the equivalence holds only if every amplitude exceeds it.

    Parameters
    ----------
    cyc : Cycles
        Counted cycles (:func:`cycles`).
    exponent : float
        Basquin exponent m > 0.
    n_equivalent : float
        Number of equivalent cycles, > 0 (e.g. the number of revolutions for a 1/rev DEL).

    Returns
    -------
    float
        S_eq in the unit of the signal; 0.0 for no cycles.

    Raises
    ------
    ValueError
        If ``exponent`` or ``n_equivalent`` is not finite and > 0, or S_eq exceeds the float
        range (an exponent far below 1 raises the cycle-count ratio to a huge power).
    """
    m = _positive_finite("exponent", exponent)
    n_eq = _positive_finite("n_equivalent", n_equivalent)
    a = cyc.amplitudes
    if a.size == 0 or not np.any(a > 0.0):
        return 0.0
    # Scaled by the largest amplitude (a ** m overflows for large m or large loads, N m) and in
    # logs (the 1/m-th power overflows for small m): log S_eq = log a_max + log(sum / n_eq) / m.
    a_max = float(np.max(a))
    weighted = float(np.sum(cyc.counts * (a / a_max) ** m))
    log_del = math.log(a_max) + (math.log(weighted) - math.log(n_eq)) / m
    if log_del >= _LOG_MAX:
        raise ValueError(f"damage_equivalent_amplitude: exceeds the float range (exponent {m:g}, "
                         f"{cyc.total:g} cycles against n_equivalent = {n_eq:g})")
    return math.exp(log_del)


def envelope(signal) -> dict:
    """Minimum, maximum, mean and half peak-to-peak of a signal.

    Parameters
    ----------
    signal : array_like
        1-D finite signal.

    Returns
    -------
    dict
        ``min``, ``max``, ``mean`` and ``amplitude`` = (max - min) / 2, as floats.

    Raises
    ------
    ValueError
        If the signal is empty, not 1-D, or holds NaN or inf.
    """
    x = _as_signal(signal)
    lo, hi = float(np.min(x)), float(np.max(x))
    return {"min": lo, "max": hi, "mean": float(np.mean(x)), "amplitude": 0.5 * (hi - lo)}


def fatigue_table(columns: dict[str, np.ndarray], sn: SNCurve, revolutions: float,
                  revolutions_per_hour: float, periodic: bool = True) -> list[dict]:
    """Damage, life and damage-equivalent amplitude of many signals, ranked as hotspots.

    Parameters
    ----------
    columns : dict of str to array_like
        Named signals (e.g. ``"M_bend_3"``: one column per joint and quantity), all sampled
        over the same ``revolutions`` whole revolutions of a periodic run.
    sn : SNCurve
        S-N curve, in the unit of the signals (one curve for all of them).
    revolutions : float
        Number of revolutions the signals cover, > 0.
    revolutions_per_hour : float
        Rotor speed in revolutions per hour, > 0.
    periodic : bool, optional
        Count each signal as a closed periodic history (:func:`cycles`); default True.

    Returns
    -------
    list of dict
        One row per signal, sorted by ``damage_per_hour``, largest first (equal damage keeps
        the order of ``columns``). Keys: ``quantity``, ``damage_per_rev`` (Miner damage of
        the record divided by ``revolutions``), ``damage_per_hour``, ``life_hours``
        (1 / ``damage_per_hour``), ``del_amplitude`` (damage-equivalent amplitude with
        ``n_equivalent = revolutions``, i.e. a 1/rev-equivalent amplitude, ignoring the cut-off),
        ``n_cycles`` (cycles in the whole record) and the :func:`envelope` keys ``min``,
        ``max``, ``mean``, ``amplitude``. Every value is finite except ``life_hours``, which is
        ``float('inf')`` exactly when the signal does no damage.

    Raises
    ------
    ValueError
        If ``revolutions`` or ``revolutions_per_hour`` is not finite and > 0, or a signal is
        empty or not finite (the message names the column).
    """
    revs = _positive_finite("revolutions", revolutions)
    per_hour = _positive_finite("revolutions_per_hour", revolutions_per_hour)
    rows = []
    for name, signal in columns.items():
        try:
            x = _as_signal(signal, name=f"column {name!r}")
        except ValueError as err:
            raise ValueError(f"fatigue_table: {err}") from None
        cyc = cycles(x, periodic=periodic)
        try:
            damage_per_rev = miner_damage(cyc, sn) / revs
        except ValueError as err:
            raise ValueError(f"fatigue_table: column {name!r}: {err}") from None
        damage_per_hour = damage_per_rev * per_hour
        rows.append({
            "quantity": name,
            "damage_per_rev": damage_per_rev,
            "damage_per_hour": damage_per_hour,
            # The one field allowed to be infinite: no damage means no finite life.
            "life_hours": 1.0 / damage_per_hour if damage_per_hour > 0.0 else math.inf,
            "del_amplitude": damage_equivalent_amplitude(cyc, sn.exponent, revs),
            "n_cycles": cyc.total,
            **envelope(x),
        })
    # sorted() is stable with reverse=True too: ties keep the column order.
    return sorted(rows, key=lambda row: row["damage_per_hour"], reverse=True)


def hotspots(rows: list[dict], top: int = 5) -> list[dict]:
    """The ``top`` most damaged rows of :func:`fatigue_table`, numbered from 1.

    Parameters
    ----------
    rows : list of dict
        Rows as returned by :func:`fatigue_table` (already ranked, largest damage first).
    top : int, optional
        How many rows to keep, >= 1 (default 5); fewer if there are fewer rows.

    Returns
    -------
    list of dict
        Copies of the first ``top`` rows, each with a ``rank`` key (1 = largest damage).

    Raises
    ------
    ValueError
        If ``top`` is not an integer >= 1.
    """
    if isinstance(top, bool) or not isinstance(top, (int, np.integer)) or top < 1:
        raise ValueError(f"hotspots: top must be an integer >= 1, got {top!r}")
    return [{"rank": k, **row} for k, row in enumerate(rows[:int(top)], start=1)]
