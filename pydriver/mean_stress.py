"""Mean-stress corrections: a cycle of amplitude S_a about a mean S_m as the fully reversed
amplitude S_ar of equal life, so that an S-N curve measured at zero mean applies to it.

The three relations (N. E. Dowling, *Mechanical Behavior of Materials*, 4th ed., Pearson 2013,
ch. 9, "Mean stress effects", and ch. 10; the stress-life relations written for any signal S):

* Goodman:  S_ar = S_a / (1 - S_m / S_u)
* Gerber:   S_ar = S_a / (1 - (S_m / S_u)^2)
* Walker:   S_ar = S_max^(1 - gamma) S_a^gamma,  S_max = S_m + S_a  (gamma = 0.5: Smith, Watson
  and Topper)

S_u is the ultimate value of the counted quantity: the ultimate tensile strength for a stress,
the strain at break for a jacket strain (``&fatigue ultimate``), the moment at which the section
fails for a bending moment.

Compressive means.  Goodman's and Gerber's relations are fitted to tensile means; Gerber's
parabola would make a compressive mean as harmful as a tensile one, which the data contradict,
and Goodman's line gives credit for it that not every material shows.  Here a compressive mean
neither helps nor harms: S_m < 0 is taken as S_m = 0 (conservative; Dowling, ch. 9, discusses
both choices).  Walker's relation covers compressive means itself; a cycle whose maximum is
not above zero (S_max <= 0: the point stays in compression) does no damage in it (S_ar = 0, as
SWT predicts), which is the relation's own limit.

A mean at or beyond the ultimate (Goodman, Gerber) is a static failure, not a fatigue life:
:func:`equivalent_amplitudes` raises ValueError for it, and the run names ``&fatigue ultimate``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pydriver.fatigue import Cycles

#: The corrections a deck may ask for (``&fatigue mean_stress``); 'none' counts the amplitude alone.
METHODS = ("none", "goodman", "gerber", "walker")


@dataclass(frozen=True)
class MeanStressCorrection:
    """One mean-stress correction.

    Attributes
    ----------
    method : str
        One of :data:`METHODS`.
    ultimate : float or None
        S_u > 0, in the unit of the counted quantity (Goodman, Gerber).
    walker_gamma : float
        Walker's exponent gamma, 0 ... 1 (Walker only).
    """

    method: str = "none"
    ultimate: float | None = None
    walker_gamma: float = 0.5

    def __post_init__(self):
        if self.method not in METHODS:
            raise ValueError(f"mean-stress method {self.method!r}: one of {', '.join(METHODS)}")
        if self.method in ("goodman", "gerber") and not (self.ultimate is not None and np.isfinite(self.ultimate)
                                                         and self.ultimate > 0.0):
            raise ValueError(f"the {self.method} correction needs an ultimate value > 0, got {self.ultimate!r}")
        if self.method == "walker" and not 0.0 <= self.walker_gamma <= 1.0:
            raise ValueError(f"walker_gamma must lie in [0, 1], got {self.walker_gamma!r}")

    @property
    def active(self) -> bool:
        """Whether the correction changes anything ('none' does not)."""
        return self.method != "none"

    def describe(self) -> str:
        """The correction in words, for the fatigue description."""
        if self.method == "goodman":
            return f"Goodman mean-stress correction (ultimate {self.ultimate:g})"
        if self.method == "gerber":
            return f"Gerber mean-stress correction (ultimate {self.ultimate:g})"
        if self.method == "walker":
            return f"Walker mean-stress correction (gamma = {self.walker_gamma:g})"
        return "no mean-stress correction"


def equivalent_amplitudes(amplitude, mean, correction: MeanStressCorrection) -> np.ndarray:
    """The fully reversed amplitudes S_ar of cycles of amplitude S_a and mean S_m.

    Parameters
    ----------
    amplitude, mean : array_like
        S_a >= 0 and S_m of the cycles (same shape).
    correction : MeanStressCorrection
        The relation (module docstring).

    Returns
    -------
    numpy.ndarray
        S_ar >= 0; ``amplitude`` itself (as floats) for ``method = 'none'``.

    Raises
    ------
    ValueError
        A mean at or beyond the ultimate value (Goodman, Gerber): the part fails statically.
    """
    a = np.asarray(amplitude, dtype=float)
    m = np.asarray(mean, dtype=float)
    if correction.method == "none":
        return a
    if correction.method == "walker":
        s_max = m + a
        out = np.zeros_like(a)
        up = s_max > 0.0
        gamma = correction.walker_gamma
        out[up] = s_max[up] ** (1.0 - gamma) * a[up] ** gamma
        return out
    ratio = np.maximum(m, 0.0) / correction.ultimate         # compressive means: no credit, no harm
    if np.any(ratio >= 1.0):
        worst = float(np.max(m))
        raise ValueError(f"a cycle's mean {worst:g} reaches the ultimate value {correction.ultimate:g}: the part "
                         "fails statically, there is no fatigue life to compute")
    factor = 1.0 - ratio if correction.method == "goodman" else 1.0 - ratio ** 2
    return a / factor


def corrected(cyc: Cycles, correction: MeanStressCorrection) -> Cycles:
    """The cycles as their fully reversed equivalents (range 2 S_ar, mean 0, the same counts);
    ``cyc`` itself when the correction is 'none'."""
    if not correction.active:
        return cyc
    s_ar = equivalent_amplitudes(cyc.amplitudes, cyc.means, correction)
    return Cycles(ranges=2.0 * s_ar, means=np.zeros_like(s_ar), counts=cyc.counts)
