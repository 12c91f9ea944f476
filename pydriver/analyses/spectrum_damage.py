"""Damage over a usage spectrum: Miner's sum over the regimes, the ground-air-ground cycle and
the rotor's starts, at every jacket point of every joint, and the life at the worst point with
its Richardson error bar.

Per refinement level (the regimes and the run-up share the chain, so their jacket points are the
same points), at every point p:

    D(p) = sum_i share_i d_i(p)                                  regimes (flight hours in regime i)
         + F g(p)                                                one ground-air-ground cycle per flight
         + F S 2 c(p)                                            each start: the run-up and the run-down
         + F (S - 1) g0(p)                                       starts beyond the first: ground cycles

with d_i the regime's damage per hour in that regime (its own rainflow count of the periodic
revolution, :mod:`pydriver.analyses.fatigue_loads`), F flights per flight hour, S rotor starts per
flight, c the damage of the run-up record's closed cycles (the run-down is taken as the run-up
reversed, which has the same closed cycles; an assumption: a real run-down is slower), and

* g(p): the ground-air-ground (GAG) cycle, from the lowest to the highest value the point sees
  in a flight: min and max over the rest state (the run-up's first sample, the rotor stopped),
  the run-up and every regime's revolution.  This is the cycle that rainflow counting over the
  whole mission (ground, run-up, the regimes, ground) pairs from the mission's extremes, counted
  once per flight (ASTM E1049-85; the GAG cycle of helicopter and aircraft load spectra, AGARD
  CP-206, "Helicopter Design Mission Load Spectra", 1976; AC 29-2C on 14 CFR 29.571).  It is added on top
  of the regimes' own cycles: the mission's count would have absorbed one outer cycle of each
  regime into it, so this counts at most one revolution's largest cycle per regime and flight
  twice, against thousands of revolutions per flight hour (conservative).  Cycles between
  regimes other than the GAG (a regime's mean shifted against another's) are not counted: they
  lie inside the GAG range and are one per flight, where each regime adds Omega/(2 pi) x 3600
  share_i per hour.
* g0(p): a start-stop without a flight, from rest to the run-up's extremes and back.

Every cycle's amplitude is mean-stress corrected as the regimes' are (``&fatigue mean_stress``).
The life at a level is 1 / max_p D(p); over the levels n, 2n, 4n it is extrapolated as a
refined run extrapolates a flight's shortest life (:func:`pydriver.richardson.richardson`), so
the error bar carries every regime's discretisation error, combined level by level before the
extrapolation.  One regime of share 1 without flights is the flight run's own damage bit for bit
(``1.0 * d + 0.0``, the same maximum).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pydriver import fatigue
from pydriver.mean_stress import MeanStressCorrection, corrected
from pydriver.richardson import outside_physical_range, richardson, richardson_two


def cycle_damage(lo, hi, sn, correction: MeanStressCorrection) -> np.ndarray:
    """The Miner damage of one cycle from ``lo`` to ``hi`` at every point (mean-stress corrected)."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    out = np.empty(lo.shape)
    for p in range(lo.size):
        cyc = fatigue.Cycles(ranges=np.array([hi.flat[p] - lo.flat[p]]),
                             means=np.array([0.5 * (hi.flat[p] + lo.flat[p])]), counts=np.array([1.0]))
        out.flat[p] = fatigue.miner_damage(corrected(cyc, correction), sn)
    return out


@dataclass
class LevelDamage:
    """The spectrum's damage at every point of one refinement level."""

    n_bodies: int
    total: np.ndarray                    #: D(p) per flight hour
    regimes: np.ndarray                  #: share_i d_i(p), (regimes, points)
    regime_alone: np.ndarray             #: d_i(p) per hour in regime i, (regimes, points)
    gag: np.ndarray                      #: F g(p)
    start_stops: np.ndarray              #: F S 2 c(p) + F (S - 1) g0(p)
    gag_low: np.ndarray                  #: the GAG cycle's ends per point
    gag_high: np.ndarray
    rest: np.ndarray | None              #: the rest state per point (None without flights)
    joint: np.ndarray
    angle_deg: np.ndarray

    @property
    def worst(self) -> int:
        """The point of the largest damage (the first of equal ones)."""
        return int(np.argmax(self.total))

    @property
    def life_hours(self) -> float | None:
        """1 / the largest damage per flight hour; None when no point takes damage."""
        top = float(self.total[self.worst])
        return 1.0 / top if top > 0.0 else None


def level_damage(shares, regimes, runup, flights_per_hour: float, start_stops_per_flight: float, sn,
                 correction: MeanStressCorrection) -> LevelDamage:
    """D(p) of one level (module docstring).

    Parameters
    ----------
    shares : sequence of float
        Each regime's share of the flight time.
    regimes : sequence of JacketPoints
        Each regime's points at this level (:class:`pydriver.analyses.fatigue_loads.JacketPoints`
        of its periodic revolution).
    runup : JacketPoints or None
        The run-up's points at this level (an open record from rest); None without flights.
    flights_per_hour, start_stops_per_flight : float
        F and S.
    sn : SNCurve or TabulatedSNCurve
        The S-N curve (the regimes').
    correction : MeanStressCorrection
        The mean-stress correction (the regimes').

    Raises
    ------
    ValueError
        Regimes (and run-up) whose points differ, or a damage beyond the float range.
    """
    first = regimes[0]
    for other in (*regimes[1:], *([runup] if runup is not None else [])):
        if other.joint.shape != first.joint.shape or np.any(other.joint != first.joint) \
                or np.any(other.angle_deg != first.angle_deg):
            raise ValueError("the regimes' jacket points differ (another chain or circumferential_points)")
    alone = np.array([r.damage_per_hour for r in regimes])
    weighted = np.array([share * d for share, d in zip(shares, alone)])
    total = weighted[0].copy()
    for w in weighted[1:]:
        total = total + w
    gag = np.zeros_like(total)
    starts = np.zeros_like(total)
    lo = np.min([r.minimum for r in regimes], axis=0)
    hi = np.max([r.maximum for r in regimes], axis=0)
    rest = None
    if runup is not None and flights_per_hour > 0.0:
        rest = runup.first
        lo = np.minimum(lo, np.minimum(rest, runup.minimum))
        hi = np.maximum(hi, np.maximum(rest, runup.maximum))
        gag = flights_per_hour * cycle_damage(lo, hi, sn, correction)
        ground = cycle_damage(np.minimum(rest, runup.minimum), np.maximum(rest, runup.maximum), sn, correction)
        starts = (flights_per_hour * start_stops_per_flight * 2.0 * runup.closed_damage_per_record
                  + flights_per_hour * (start_stops_per_flight - 1.0) * ground)
        total = total + gag + starts
    if not np.all(np.isfinite(total)):
        raise ValueError("the spectrum's damage per flight hour exceeds the float range")
    return LevelDamage(n_bodies=int(first.joint.max()), total=total, regimes=weighted, regime_alone=alone, gag=gag,
                       start_stops=starts, gag_low=lo, gag_high=hi, rest=rest, joint=first.joint,
                       angle_deg=first.angle_deg)


@dataclass
class SpectrumLife:
    """The life over the levels: each level's, and its extrapolation with the error bar."""

    levels: list                         #: LevelDamage per level, coarse to fine
    extrapolated: float | None = None
    error_estimate: float | None = None
    observed_order: float | None = None
    order_observed: bool = False
    warning: str = ""                    #: why the extrapolation is doubtful or refused

    @property
    def finest(self) -> LevelDamage:
        return self.levels[-1]


def spectrum_life(levels: list, expected_order: float) -> SpectrumLife:
    """The lives of the levels and their Richardson extrapolation, as a refined run extrapolates
    a flight's shortest life (:func:`pydriver.analyses.refinement.extrapolate`): three or more
    levels with the observed order, two with the expected order and Roache's safety factor; an
    extrapolation outside the physical range (a negative life, an error bar larger than the
    life) is no result and says why."""
    out = SpectrumLife(levels=levels)
    lives = [lv.life_hours for lv in levels]
    if len(levels) < 2 or any(life is None for life in lives):
        return out
    e = (richardson_two(*lives, expected_order=expected_order) if len(lives) == 2 else
         richardson(*lives[-3:], expected_order=expected_order))
    why = outside_physical_range(e)
    if why is not None:
        out.warning = (f"the spectrum's life over n = {', '.join(str(lv.n_bodies) for lv in levels)} "
                       f"({', '.join(f'{x:.4g}' for x in lives)} h) extrapolates to {e.extrapolated:.4g} +- "
                       f"{e.error_estimate:.3g} h: {why}; no converged life is reported")
        return out
    out.extrapolated, out.error_estimate, out.observed_order = e.extrapolated, e.error_estimate, e.observed_order
    out.order_observed = len(lives) >= 3
    out.warning = e.warning or ""
    return out
