"""Values judged against the deck's limits (``&limits``): the largest jacket strain against
``jacket_strain`` and the shortest fatigue life against ``fatigue_life_hours``.  Each is the
quantity's headline value (:mod:`pydriver.quantities`: converged with its error bar where the
run was refined), and a limit is met only when the whole error bar meets it.

:func:`attach_limits` adds ``summary['limits']`` (one row per judged quantity: value, limit,
where, exceeded) and a warning for each limit exceeded; the terminal summary and report.html
show both.  A quantity the run computes but the deck sets no limit for is listed as not judged,
so that a reader does not take silence for a pass.
"""

from __future__ import annotations

import numpy as np

from pydriver.key_scope import applies


def _headline(result, name: str) -> dict | None:
    """The headline entry of a quantity (pydriver.quantities): its one value, converged with its
    error bar where the run was refined."""
    return (result.summary.get("headline") or {}).get(name)


def _largest_strain(result) -> tuple[float, str] | None:
    """(largest |jacket strain|, where) of a run: the flight peaks, a dynamic run's time series,
    or the equilibrium table (static, modal)."""
    s = result.summary
    top = s.get("spectrum", {}).get("largest_strain")
    if top is not None:                       # a usage spectrum: its regimes' largest
        return float(top["max_abs"]), (f"regime '{top['regime']}', joint {top['joint']}, azimuth "
                                       f"{top['azimuth_deg']:.0f} deg")
    peak = s.get("peaks", {}).get("strain")
    if peak is not None:
        where = f"joint {peak['joint']}" + (f", azimuth {peak['azimuth_deg']:.0f} deg" if "azimuth_deg" in peak else "")
        return float(peak["max_abs"]), where
    ts = result.timeseries
    if ts is not None:
        cols = [c for c in ts if c.startswith("strain") and c[6:].isdigit()]
        if cols:
            values = [float(np.max(np.abs(ts[c]))) for c in cols]
            k = int(np.argmax(values))
            return values[k], f"joint {cols[k][6:]}, over the run"
    if result.table is not None and "strain" in result.table:
        strain = np.abs(np.asarray(result.table["strain"], float))
        if strain.size:
            k = int(np.argmax(strain))
            return float(strain[k]), f"joint {k + 1}, at the equilibrium"
    return None


def _shortest_life(result) -> tuple[float, str] | None:
    spectrum = result.summary.get("spectrum")
    if spectrum is not None:
        # A usage spectrum's safe life: the converged life where the levels give it, divided by the
        # scatter factor (pydriver/analyses/spectrum.py).
        life = spectrum["safe_life_hours"]
        return None if life is None else (float(life), f"safe life (scatter factor {spectrum['scatter_factor']:g}) "
                                                       f"over the usage spectrum, {spectrum['worst_point']['where']}")
    hot = [h for h in result.summary.get("fatigue", {}).get("hotspots", []) if h["life_hours"] is not None]
    if not hot:
        return None
    h = min(hot, key=lambda r: r["life_hours"])
    return float(h["life_hours"]), h["quantity"]


def _row(quantity: str, unit: str, value: float, where: str, head: dict | None, limit, key: str,
         at_most: bool) -> dict:
    """One row: the headline value where there is one (converged, with its error bar), judged at
    the worst end of its error bar (a limit is met only when the whole bar meets it)."""
    error = 0.0
    basis = ""
    asymptotic = True
    if head is not None:
        value, error, basis = float(head["value"]), float(head.get("error_estimate", 0.0)), head["basis"]
        asymptotic = bool(head.get("asymptotic", True))
    worst = value + error if at_most else value - error
    exceeded = None if limit is None else bool(worst > limit if at_most else worst < limit)
    return {"quantity": quantity, "value": value, "error_estimate": error, "basis": basis, "asymptotic": asymptotic,
            "unit": unit,
            "where": where, "limit": limit, "key": key, "sense": "at most" if at_most else "at least",
            "exceeded": exceeded}


def judge(result, strain_limit: float | None, life_limit: float | None) -> list[dict]:
    """The rows of summary['limits'] (see the module docstring)."""
    rows = []
    strain = _largest_strain(result)
    if strain is not None:
        value, where = strain
        rows.append(_row("largest jacket strain", "-", value, where, _headline(result, "peak strain [-]"),
                         strain_limit, "&limits jacket_strain", at_most=True))
    life = _shortest_life(result)
    if life is not None:
        value, where = life
        rows.append(_row("shortest fatigue life", "h", value, where, _life_headline(result),
                         life_limit, "&limits fatigue_life_hours", at_most=False))
    return rows


def _life_headline(result) -> dict | None:
    """The headline of the life the limit judges: a run's shortest fatigue life, or a usage
    spectrum's safe life, its converged life over the scatter factor (error bar alike)."""
    spectrum = result.summary.get("spectrum")
    if spectrum is None:
        return _headline(result, "fatigue life [h], shortest")
    head = _headline(result, "spectrum life [h]")
    if head is None:
        return None
    factor = float(spectrum["scatter_factor"])
    return {**head, "value": head["value"] / factor, "error_estimate": head.get("error_estimate", 0.0) / factor}


def attach_limits(model, result) -> None:
    """Add summary['limits'] and a warning per limit exceeded (a limit the run has no value
    for is named in a warning too)."""
    deck = model.deck
    strain_limit = deck["limits.jacket_strain"]
    life_limit = deck["limits.fatigue_life_hours"]
    rows = judge(result, strain_limit, life_limit)
    if rows:                            # a run with nothing to judge (Campbell) has no such section
        result.summary["limits"] = rows
    warnings = []
    for r in rows:
        if r["exceeded"]:
            warnings.append(f"limit: {r['quantity']} {_fmt(r['value'], r['unit'])} ({r['where']}) is not "
                            f"{r['sense']} {_fmt(r['limit'], r['unit'])} ({r['key']})")
    judged = {r["key"] for r in rows}
    for key, limit in (("&limits jacket_strain", strain_limit), ("&limits fatigue_life_hours", life_limit)):
        # An analysis that never computes the quantity is said by pydriver/key_scope.py already.
        if limit is not None and key not in judged and applies(deck, "limits", key.split()[1]):
            warnings.append(f"limit: {key} = {limit:g} is not judged: this {model.analysis} run computes no "
                            + ("jacket strain" if "strain" in key else "fatigue life (&fatigue)"))
    if warnings:                        # no empty list: "no warnings key" means a clean run
        result.summary.setdefault("warnings", []).extend(warnings)


def _fmt(value: float, unit: str) -> str:
    if unit == "-":
        return f"{value:.4g} ({100 * value:.3g} %)"
    return f"{value:.4g} {unit}"
