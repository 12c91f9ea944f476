"""Resonance margins: how far each mode sits from the rotor harmonics at the operating speed.

A blade-mounted cable is excited at the harmonics k Omega (k = 1, 2, ... per revolution) of the
rotor speed: the blade's flap, lag and pitch motion and the periodic air load are Fourier
series in the azimuth.  A design keeps every mode a margin away from every harmonic.  The
default of 10 % of the harmonic's frequency is a common rule of thumb of rotorcraft frequency
placement (assumed here, not from the thesis; the requirement of issue 21); a design office
sets its own with ``&resonance margin_percent``.

Which harmonics excite is a deck choice (``&resonance excitation``, :func:`excited_harmonics`):
``'every'`` k/rev, k = 1 ... harmonics (the default: a cable on the blade sees the blade's own
motion, every harmonic of it), or ``'blade_passage'``, the multiples of the blade count
``&resonance blades`` up to ``harmonics`` (a part in the fixed frame sees only those: the other
harmonics of the blades cancel in the hub's loads).

For mode i with frequency f_i and harmonic k at speed Omega (rev/s = rpm/60), the margin is

    m_ik = |f_i - k Omega| / (k Omega)   (in percent),

the nearest harmonic is the k of the smallest m_ik over the excited harmonics, and with an error
bar e_i (Richardson, ``&refinement``) the worst margin is that of the frequency within
f_i +- e_i nearest the harmonic (0 when the band contains it).  A mode is flagged when its
worst margin is below the required one.  Modes far above the highest harmonic K (f > (K + 1)
Omega) are not excited and are not listed (:func:`highest_excited_hz`).

The frequencies are those of the linearised motion about the equilibrium at the operating
speed: damped frequencies (docs/model.md, "Resonance margins": what resonates is the damped
motion, with the Coriolis coupling of the turning frame in it); an overdamped mode does not
oscillate and has no resonance.  The design optimiser's frequency constraint judges the same
damped frequencies by the same :func:`harmonic_margin` (pydriver/analyses/optimiser.py).
"""

from __future__ import annotations

import math

import numpy as np

from pydriver.analyses.registry import analysis_of


def harmonic_orders(harmonics) -> np.ndarray:
    """The orders k of the harmonics considered: ``harmonics`` an int K (1 ... K) or the orders
    themselves (:func:`excited_harmonics`)."""
    if np.ndim(harmonics) == 0:
        return np.arange(1, int(harmonics) + 1)
    return np.asarray(sorted(int(k) for k in harmonics), int)


def excited_harmonics(deck, highest: int | None = None) -> list[int]:
    """The orders k of the harmonics k/rev that excite the cable (``&resonance excitation``):
    every k = 1 ... ``highest`` (default ``&resonance harmonics``), or the blade-passage
    multiples of ``&resonance blades`` up to it."""
    top = int(deck["resonance.harmonics"] if highest is None else highest)
    if deck["resonance.excitation"] == "blade_passage":
        blades = int(deck["resonance.blades"])
        return list(range(blades, top + 1, blades))
    return list(range(1, top + 1))


def harmonics_text(orders) -> str:
    """The harmonics in words: '1/rev ... 8/rev' or '4/rev, 8/rev, 12/rev'."""
    ks = [int(k) for k in harmonic_orders(orders)]
    if len(ks) > 2 and ks == list(range(ks[0], ks[-1] + 1)):
        return f"{ks[0]}/rev ... {ks[-1]}/rev"
    return ", ".join(f"{k}/rev" for k in ks)


def highest_excited_hz(harmonics, rpm: float) -> float:
    """The frequency above which a mode is not excited [Hz]: one harmonic above the highest
    considered, (K + 1) Omega."""
    return float((harmonic_orders(harmonics)[-1] + 1) * rpm / 60.0)


def harmonic_margin(f_hz: float, error_hz: float, rpm: float, harmonics) -> dict:
    """The nearest harmonic of one frequency and its margins.

    Parameters
    ----------
    f_hz : float
        Mode frequency [Hz] (> 0).
    error_hz : float
        Its error bar [Hz] (0: none).
    rpm : float
        Rotor speed [rpm] (> 0).
    harmonics : int or sequence of int
        Harmonics considered: K for 1/rev ... K/rev, or their orders (:func:`excited_harmonics`).

    Returns
    -------
    dict
        ``harmonic`` k, ``harmonic_hz``, ``margin_percent`` and ``worst_margin_percent``.
    """
    rev = rpm / 60.0
    ks = harmonic_orders(harmonics)
    h = ks * rev
    margins = np.abs(f_hz - h) / h
    i = int(np.argmin(margins))
    # Worst case within the error bar: the distance from the band [f - e, f + e] to k Omega.
    worst = np.maximum(np.abs(f_hz - h) - abs(error_hz), 0.0) / h
    return {"harmonic": int(ks[i]), "harmonic_hz": float(h[i]), "margin_percent": float(100.0 * margins[i]),
            "worst_margin_percent": float(100.0 * np.min(worst)),
            "worst_harmonic": int(ks[int(np.argmin(worst))])}


def mode_margins(modes: list, rpm_values: list, harmonics, required_percent: float) -> list:
    """One row per (mode, operating speed) for modes within reach of the harmonics.

    Parameters
    ----------
    modes : list of (int, callable or float, callable or float or None)
        (mode number, frequency [Hz] or a function of rpm giving it, error bar [Hz] or a
        function of rpm giving it, None: no error bar); a frequency <= 0 (overdamped or
        zero-stiffness mode) is skipped.
    rpm_values : list of float
        Operating speeds [rpm].
    harmonics : int or sequence of int
        As :func:`harmonic_margin`.
    required_percent : float
        The required margin [%].
    """
    rows = []
    for rpm in rpm_values:
        if not rpm > 0.0:
            continue
        top = highest_excited_hz(harmonics, rpm)
        for mode, freq, err in modes:
            f = float(freq(rpm) if callable(freq) else freq)
            if not f > 0.0 or f > top or not math.isfinite(f):
                continue
            err = err(rpm) if callable(err) else err
            row = {"mode": int(mode), "operating_rpm": float(rpm), "frequency_hz": f,
                   "error_hz": float(err) if err is not None else None}
            row.update(harmonic_margin(f, err or 0.0, rpm, harmonics))
            row["within_margin"] = bool(row["worst_margin_percent"] < required_percent)
            rows.append(row)
    return rows


def summary_block(rows: list, rpm_values: list, harmonics, required_percent: float, about: str,
                  excitation: str = "every") -> dict:
    """summary['resonance']: the rows, the closest mode and the required margin; ``harmonics``
    the highest order and ``excited_harmonics`` the orders checked."""
    orders = harmonic_orders(harmonics)
    block = {"operating_rpm": [float(r) for r in rpm_values], "harmonics": int(orders[-1]) if orders.size else 0,
             "excitation": excitation, "excited_harmonics": [int(k) for k in orders],
             "frequencies": "damped",
             "required_margin_percent": float(required_percent), "modes_about": about, "modes": rows}
    if rows:
        closest = min(rows, key=lambda r: r["worst_margin_percent"])
        block["closest"] = dict(closest)
    block["flagged"] = [r for r in rows if r["within_margin"]]
    return block


def warnings_of(block: dict) -> list[str]:
    """One warning per flagged mode, in words a designer reads."""
    out = []
    for r in block["flagged"]:
        err = f" +- {r['error_hz']:.2g}" if r.get("error_hz") else ""
        out.append(f"resonance: mode {r['mode']} at {r['frequency_hz']:.2f}{err} Hz (damped) is within "
                   f"{r['worst_margin_percent']:.1f} % of {r['worst_harmonic']}/rev "
                   f"({r['worst_harmonic'] * r['operating_rpm'] / 60.0:.2f} Hz at {r['operating_rpm']:g} rpm); "
                   f"the required margin is {block['required_margin_percent']:g} % (&resonance margin_percent)")
    return out


def table_of(block: dict) -> dict:
    """resonance.csv columns."""
    rows = block["modes"]
    keys = ["mode", "operating_rpm", "frequency_hz", "error_hz", "harmonic", "harmonic_hz", "margin_percent",
            "worst_margin_percent", "within_margin"]
    if all(r["error_hz"] is None for r in rows):
        keys.remove("error_hz")                   # a single n: no error bars (not zero ones)
    return {k: [(float(r[k]) if isinstance(r[k], bool) else r[k]) for r in rows] for k in keys}


# -- a run's margins ---------------------------------------------------------------------------

def operating_speeds(model) -> list[float]:
    """The operating speed(s) [rpm]: ``&resonance operating_rpm``, else the deck's constant rotor
    speed (flight, modal in the hub frame), else a Campbell deck's operating range."""
    deck = model.deck
    if deck["resonance.operating_rpm"] is not None:
        return [float(x) for x in deck["resonance.operating_rpm"]]
    if analysis_of(model).sweeps_speed:
        op = deck["campbell.operating_rpm"]
        return [float(x) for x in op] if op is not None else []
    if "rotor" in deck.groups:
        if deck["rotor.profile"] == "constant" and deck["rotor.rpm"]:
            return [float(deck["rotor.rpm"])]
        return []
    if deck.has("loads.rotor_rpm") and deck["loads.rotor_rpm"] > 0.0:
        return [float(deck["loads.rotor_rpm"])]
    return []


def _harmonics(model) -> list[int]:
    """The orders of the excited harmonics of a run (a Campbell deck's own ``harmonics`` unless
    &resonance sets one)."""
    deck = model.deck
    if analysis_of(model).sweeps_speed and not deck.has("resonance.harmonics"):
        return excited_harmonics(deck, int(deck["campbell.harmonics"]))
    return excited_harmonics(deck)


def _modal_modes(summary: dict, shifts: dict | None = None) -> list:
    """(mode, damped frequency, error bar) of a modal or flight summary; the extrapolated value
    and its error where the run was refined; else, for a mode of ``shifts`` ({mode: (shift,
    error)}: a design judged on converged frequencies, &design frequency_levels), the value
    shifted by its discretisation error, with the extrapolation's error bar."""
    refined = (summary.get("refinement") or {}).get("quantities", {})
    shifts = shifts or {}
    out = []
    for i, f in enumerate(summary.get("damped_frequencies_hz", [])):
        r = refined.get(f"fd{i + 1} [Hz]")
        if r is not None and "extrapolated" in r:
            out.append((i + 1, r["extrapolated"], r["error_estimate"]))
        elif i + 1 in shifts and f > 0.0:
            out.append((i + 1, f + shifts[i + 1][0], shifts[i + 1][1]))
        else:
            out.append((i + 1, f, None))
    return out


def _campbell_rows(result, rpm_values, harmonics, required):
    """A Campbell run's margins: at one operating speed, or the least over an operating range
    (sampled finely between the grid speeds; a crossing inside the range is a margin of 0).
    A refined diagram (&refinement) is judged on its extrapolated frequencies with their error
    bars, linearly interpolated between grid speeds; where a point has no extrapolation (a mode
    not oscillating at every level) on the finest level's frequency without one."""
    c = result.extra["campbell"]
    grid, freqs = np.asarray(c["rpm"], float), np.asarray(c["f"], float)
    errors = None
    if "f_extrapolated" in c:
        ext = np.asarray(c["f_extrapolated"], float)
        known = np.isfinite(ext)
        freqs = np.where(known, ext, freqs)
        errors = np.where(known, np.asarray(c["f_error"], float), 0.0)
    if len(rpm_values) == 1:
        speeds = np.asarray(rpm_values, float)
    else:
        lo, hi = min(rpm_values), max(rpm_values)
        speeds = np.union1d(np.linspace(lo, hi, 401), grid[(grid >= lo) & (grid <= hi)])
    modes = [(i + 1, (lambda r, i=i: np.interp(r, grid, freqs[:, i])),
              None if errors is None else (lambda r, i=i: float(np.interp(r, grid, errors[:, i]))))
             for i in range(freqs.shape[1])]
    rows = mode_margins(modes, list(speeds), harmonics, required)
    least = {}
    for r in rows:
        if r["mode"] not in least or r["worst_margin_percent"] < least[r["mode"]]["worst_margin_percent"]:
            least[r["mode"]] = r
    return [least[m] for m in sorted(least)]


def attach_margins(model, result, shifts: dict | None = None) -> None:
    """Add summary['resonance'], its warnings and resonance.csv to a modal, Campbell or flight
    result (after refinement, so that refined frequencies carry their error bars).  ``shifts``
    ({mode: (shift, error)}): a design optimum judged on converged frequencies (the design's
    own shifts, so that the table and the design's margin are one number)."""
    entry = analysis_of(model)
    if entry.modes is None:
        return
    rpm_values = operating_speeds(model)
    harmonics = _harmonics(model)
    required = float(model.deck["resonance.margin_percent"])
    about = entry.modes_about
    if not rpm_values:
        result.summary["resonance"] = {"operating_rpm": [], "note": "no operating speed: the rotor does not "
                                       "turn; set &resonance operating_rpm to check the margins"}
        return
    if entry.modes == "diagram":
        rows = _campbell_rows(result, rpm_values, harmonics, required)
    else:
        rows = mode_margins(_modal_modes(result.summary, shifts), rpm_values, harmonics, required)
        if shifts:
            about += (f" (n = {model.n_bodies}, each frequency shifted by its discretisation error f(converged) - "
                      "f(n), with its Richardson error bar: &design frequency_levels)")
    block = summary_block(rows, rpm_values, harmonics, required, about, model.deck["resonance.excitation"])
    result.summary["resonance"] = block
    warns = warnings_of(block)
    if warns:
        result.summary.setdefault("warnings", []).extend(warns)
    if rows:
        result.extra.setdefault("tables", {})["resonance.csv"] = table_of(block)
