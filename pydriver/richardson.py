"""Richardson extrapolation of a result computed on three grids n, r n, r^2 n (or on two).

The mesh size is h ~ 1/n, so the grids have sizes h, h/r, h/r^2 (r = 2 for n, 2n, 4n). For a
value that converges as f(h) = f0 + C h^p, the three values give the observed order

    p = log(|(coarse - medium) / (medium - fine)|) / log(r)

and the extrapolated limit f0 ~ fine + (fine - medium) / (r^p - 1) (Richardson; Roache's
grid-convergence practice). Which p is used, and what happens when the three values do not
behave like f0 + C h^p, is decided in :func:`richardson` and stated in its result: the
result is always finite, and any doubt is a sentence in ``warning``, never a NaN.

Two grids cannot show the order: :func:`richardson_two` extrapolates with the expected order
and widens the error estimate by Roache's safety factor for that case.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

# r^p - 1 is computed as expm1(p log r); beyond this exponent r^p overflows a float and the
# correction (fine - medium) / (r^p - 1) is zero to double precision.
_MAX_EXPONENT = 700.0

#: Safety factor on the error estimate of a two-grid extrapolation, whose order is assumed, not
#: observed: Roache's grid convergence index uses 3 for two grids (P. J. Roache, "Perspective: a
#: method for uniform reporting of grid refinement studies", J. Fluids Eng. 116, 1994, 405-413;
#: 1.25 where three grids show the order).
TWO_GRID_SAFETY = 3.0
#: Roache's factor where three grids show an order (ibid.): applied to the error bar of values not
#: yet in the asymptotic range, which covers both the expected-order and the observed-order
#: extrapolation (issue 36: the bar must cover what the data say).
THREE_GRID_SAFETY = 1.25


@dataclass
class Extrapolation:
    """Richardson extrapolation of one quantity.

    Attributes
    ----------
    values : tuple of float
        The three values (two for :func:`richardson_two`), coarse to fine.
    extrapolated : float
        Estimate of the grid-converged value.
    observed_order : float
        Order p observed from the three values; the expected order where it is undefined
        (all three equal, or medium equal to fine), as ``warning`` then says.
    error_estimate : float
        |extrapolated - fine|: the estimated discretisation error of the finest value.
    expected_order : float
        Formal order of the discretisation, used when the observed one is not trusted.
    warning : str or None
        Why the values may not be in the asymptotic range, or None.
    """

    values: tuple[float, ...]
    extrapolated: float
    observed_order: float
    error_estimate: float
    expected_order: float
    warning: str | None

    @property
    def order_used(self) -> float:
        """The order used for the extrapolation: the observed one unless there is a warning."""
        return self.expected_order if self.warning else self.observed_order


def _finite(name: str, value) -> float:
    """``value`` as a float; ValueError naming ``name`` if it is not a finite number."""
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"richardson: {name} must be a number, got {value!r}") from None
    if not math.isfinite(x):
        raise ValueError(f"richardson: {name} must be finite, got {value!r}")
    return x


def _correction(fine_minus_medium: float, ratio: float, order: float) -> float:
    """(fine - medium) / (ratio^order - 1), for order > 0 and ratio > 1, without overflow."""
    exponent = order * math.log(ratio)
    if exponent > _MAX_EXPONENT:
        return 0.0
    return fine_minus_medium / math.expm1(exponent)


def _unscaled_text(scaled: float, power: int) -> str:
    """``scaled * 2**power`` for a message, written as such where it would overflow a float."""
    try:
        return f"{math.ldexp(scaled, power):.3g}"
    except OverflowError:
        return f"{scaled:.3g} * 2**{power}"


def richardson(coarse: float, medium: float, fine: float, expected_order: float = 2.0,
               ratio: float = 2.0, order_tolerance: float = 0.5) -> Extrapolation:
    """Richardson extrapolation from three grids refined by a constant ratio.

    The order used is the OBSERVED one when it is positive and within ``order_tolerance`` of
    ``expected_order``: then the three values fit f0 + C h^p exactly and the extrapolation is
    that fit's f0. Otherwise the values are not in the asymptotic range, the observed order
    would give an arbitrary (possibly huge) correction, and the EXPECTED order is used, with
    a ``warning`` saying why:

    - observed order far from the expected one (or not positive: the differences grow);
    - oscillating convergence: coarse - medium and medium - fine have opposite signs;
    - coarse equal to medium but fine different: no observed order, no trend.

    Degenerate cases give finite numbers without dividing by zero: all three values equal is
    converged (observed order reported as the expected one, error 0, no warning); medium
    equal to fine while coarse differs extrapolates to the fine value with error 0, reports
    the expected order and warns that the observed order is undefined.

    Parameters
    ----------
    coarse, medium, fine : float
        The quantity on grids of size h, h/ratio, h/ratio^2 (e.g. n, 2n, 4n bodies).
    expected_order : float, optional
        Formal order of convergence in h, > 0 (default 2).
    ratio : float, optional
        Grid refinement ratio r > 1 (default 2).
    order_tolerance : float, optional
        Largest |observed - expected| order for which the observed order is used, >= 0
        (default 0.5).

    Returns
    -------
    Extrapolation
        Every number in it is finite.

    Raises
    ------
    ValueError
        If an argument is not finite, ``expected_order`` <= 0, ``ratio`` <= 1,
        ``order_tolerance`` < 0, or the extrapolated value overflows a float.
    """
    c, m, f = (_finite(name, v) for name, v in (("coarse", coarse), ("medium", medium), ("fine", fine)))
    p_exp = _finite("expected_order", expected_order)
    r = _finite("ratio", ratio)
    tol = _finite("order_tolerance", order_tolerance)
    if p_exp <= 0.0:
        raise ValueError(f"richardson: expected_order must be > 0, got {expected_order!r}")
    if r <= 1.0:
        raise ValueError(f"richardson: ratio must be > 1, got {ratio!r}")
    if tol < 0.0:
        raise ValueError(f"richardson: order_tolerance must be >= 0, got {order_tolerance!r}")

    # Work on values scaled to at most 1 in magnitude: differences of values near the float
    # limit would overflow, and the order depends only on ratios of differences. The scale is
    # a power of two, so scaling and unscaling are exact (a converged triple returns `fine`).
    power = math.frexp(max(abs(c), abs(m), abs(f)))[1]
    cs, ms, fs = (math.ldexp(v, -power) for v in (c, m, f))
    d_cm = ms - cs                        # coarse -> medium change
    d_mf = fs - ms                        # medium -> fine change

    def result(p_obs: float, extrapolated_scaled: float, warning: str | None,
               error_at_least: float = 0.0) -> Extrapolation:
        try:
            extrapolated = math.ldexp(extrapolated_scaled, power)
            error = math.ldexp(max(abs(extrapolated_scaled - fs), error_at_least), power)
        except OverflowError:
            raise ValueError(f"richardson: extrapolation of ({c!r}, {m!r}, {f!r}) overflows") from None
        return Extrapolation(values=(c, m, f), extrapolated=extrapolated, observed_order=p_obs,
                             error_estimate=error, expected_order=p_exp, warning=warning)

    if d_mf == 0.0:
        if d_cm == 0.0:
            return result(p_exp, fs, None)
        # Zero change between the finest grids is "infinite order": it happens by chance
        # (a curve crossing its limit) as well as by convergence; the fine value is the
        # only defensible estimate.
        return result(p_exp, fs,
                      "medium and fine values are equal while the coarse one differs: the observed "
                      f"order is undefined (reported as the expected order {p_exp:g}); the fine value "
                      "is taken as converged, which may be a coincidence")

    fallback = fs + _correction(d_mf, r, p_exp)
    if d_cm == 0.0:
        return result(p_exp, fallback,
                      "coarse and medium values are equal while the fine one differs: no convergence "
                      f"trend, the observed order is undefined (reported as the expected order {p_exp:g}); "
                      "extrapolated with the expected order")

    # Logarithms of the two magnitudes separately: their ratio could overflow.
    p_obs = (math.log(abs(d_cm)) - math.log(abs(d_mf))) / math.log(r)
    # Outside the asymptotic range the expected-order correction is no error bound: the error
    # estimate is then at least the last change (oscillating, diverging) or the correction with
    # the observed order, whichever is larger (a conservative bar, as Roache's safety factor).
    if (d_cm > 0.0) != (d_mf > 0.0):
        return result(p_obs, fallback, error_at_least=abs(d_mf), warning=
                      f"oscillating convergence: the changes coarse->medium ({_unscaled_text(d_cm, power)}) and "
                      f"medium->fine ({_unscaled_text(d_mf, power)}) have opposite signs; extrapolated with the "
                      f"expected order {p_exp:g}, the error estimate may be unreliable")
    if p_obs <= 0.0:
        return result(p_obs, fallback, error_at_least=abs(d_mf), warning=
                      f"observed order {p_obs:.3g} is not positive (the changes do not shrink with "
                      f"refinement) and far from the expected order {p_exp:g}: the values may not be "
                      "in the asymptotic range; extrapolated with the expected order")
    if abs(p_obs - p_exp) > tol:
        # Not yet in the asymptotic range: the bar covers both extrapolations (the expected order's
        # and the observed order's, which fits the three values exactly), widened by Roache's factor.
        cover = THREE_GRID_SAFETY * max(abs(fallback - fs), abs(_correction(d_mf, r, p_obs)))
        return result(p_obs, fallback, error_at_least=cover, warning=
                      f"observed order {p_obs:.3g} is far from the expected order {p_exp:g} "
                      f"(tolerance {tol:g}): the values may not be in the asymptotic range; "
                      "extrapolated with the expected order")
    return result(p_obs, fs + _correction(d_mf, r, p_obs), None)


def richardson_two(coarse: float, fine: float, expected_order: float = 2.0, ratio: float = 2.0) -> Extrapolation:
    """Richardson extrapolation from two grids, h and h/ratio, with the expected order assumed.

    Two values cannot show the order of convergence, so it is taken to be ``expected_order``:
    the extrapolated value is fine + (fine - coarse) / (r^p - 1), and the error estimate is
    ``TWO_GRID_SAFETY`` (3) times that correction, Roache's grid convergence index for two
    grids.  ``observed_order`` reports the expected order (as :func:`richardson` does where the
    order is undefined) and ``warning`` says that it was assumed.

    Parameters
    ----------
    coarse, fine : float
        The quantity on grids of size h and h/ratio (e.g. n and 2n bodies).
    expected_order : float, optional
        Formal order of convergence in h, > 0 (default 2).
    ratio : float, optional
        Grid refinement ratio r > 1 (default 2).

    Returns
    -------
    Extrapolation
        Every number in it is finite.

    Raises
    ------
    ValueError
        If an argument is not finite, ``expected_order`` <= 0, ``ratio`` <= 1, or the
        extrapolated value or its error estimate overflows a float.
    """
    c, f = (_finite(name, v) for name, v in (("coarse", coarse), ("fine", fine)))
    p_exp = _finite("expected_order", expected_order)
    r = _finite("ratio", ratio)
    if p_exp <= 0.0:
        raise ValueError(f"richardson: expected_order must be > 0, got {expected_order!r}")
    if r <= 1.0:
        raise ValueError(f"richardson: ratio must be > 1, got {ratio!r}")
    # Scaled by a power of two as in richardson(): exact, and no overflow in the difference.
    power = math.frexp(max(abs(c), abs(f)))[1]
    cs, fs = math.ldexp(c, -power), math.ldexp(f, -power)
    correction = _correction(fs - cs, r, p_exp)
    try:
        extrapolated = math.ldexp(fs + correction, power)
        error = math.ldexp(TWO_GRID_SAFETY * abs(correction), power)
    except OverflowError:
        raise ValueError(f"richardson: extrapolation of ({c!r}, {f!r}) overflows") from None
    warning = None
    if c != f:
        warning = (f"two grids: the order of convergence is assumed (expected order {p_exp:g}), not observed; "
                   f"the error estimate is {TWO_GRID_SAFETY:g} x the correction")
    return Extrapolation(values=(c, f), extrapolated=extrapolated, observed_order=p_exp, error_estimate=error,
                         expected_order=p_exp, warning=warning)


def richardson_table(values: dict[str, tuple[float, float, float]], expected_order: float = 2.0,
                     ratio: float = 2.0, order_tolerance: float = 0.5) -> list[dict]:
    """Richardson extrapolation of many named quantities.

    Parameters
    ----------
    values : dict of str to (float, float, float)
        Quantity name to its (coarse, medium, fine) values.
    expected_order, ratio, order_tolerance : float, optional
        As for :func:`richardson`, the same for every quantity.

    Returns
    -------
    list of dict
        One row per quantity, in the order of ``values``, with keys ``quantity``, ``coarse``,
        ``medium``, ``fine``, ``extrapolated``, ``observed_order``, ``order_used``,
        ``error_estimate`` and ``warning``.

    Raises
    ------
    ValueError
        As :func:`richardson`, or if a value is not a triple; the message names the quantity.
    """
    rows = []
    for name, triple in values.items():
        try:
            coarse, medium, fine = triple
            e = richardson(coarse, medium, fine, expected_order, ratio, order_tolerance)
        except (TypeError, ValueError) as err:
            raise ValueError(f"richardson_table: quantity {name!r}: {err}") from None
        rows.append({"quantity": name, "coarse": e.values[0], "medium": e.values[1],
                     "fine": e.values[2], "extrapolated": e.extrapolated,
                     "observed_order": e.observed_order, "order_used": e.order_used,
                     "error_estimate": e.error_estimate, "warning": e.warning})
    return rows


def outside_physical_range(e: Extrapolation, low: float = 0.0) -> str | None:
    """Why the extrapolation of a quantity that cannot be below ``low`` (a speed, a frequency:
    0) is no result, or None if it may be one.

    Refused are a value below ``low`` (the levels do not converge towards a physical value) and
    an error estimate larger than the distance of the value from ``low`` (the estimate admits
    the unphysical side: the levels disagree by more than they converge).  Issue 35: a Campbell
    diagram whose finest level followed other modes extrapolated crossings to -78.7 rpm and
    frequencies to -5.0 +- 15 Hz.
    """
    if e.extrapolated < low:
        return f"{e.extrapolated:.4g} is below {low:g}"
    if e.error_estimate > e.extrapolated - low:
        return f"its error estimate {e.error_estimate:.3g} exceeds the value {e.extrapolated:.4g}" + \
            (f" above {low:g}" if low else "")
    return None


def departing_level(values) -> int | None:
    """The index of the level whose value departs from the others: the value farthest from the
    levels' median (three or more levels); None for two levels, which cannot tell which."""
    values = [float(v) for v in values]
    if len(values) < 3:
        return None
    middle = sorted(values)[len(values) // 2]
    return max(range(len(values)), key=lambda i: abs(values[i] - middle))


def level_text(index: int | None, ns) -> str:
    """``"n = 44"`` for the level ``index`` of the levels' numbers of bodies ``ns``; for None
    (two levels) ``"n = 11 or n = 22"``."""
    return f"n = {ns[index]}" if index is not None else " or ".join(f"n = {n}" for n in ns)
