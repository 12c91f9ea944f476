"""Converged numbers: the same cable at n, 2n, 4n bodies and Richardson extrapolation.

With the physical cable parameters (``&cable``) a deck describes a cable, not a chain: the
joint constants follow from EI, GJ and the body length for any n (docs/model.md, "Per-body
and physical parameters").  ``&refinement levels = 3`` (or ``rotorcable run --refine``) runs
the deck at n, 2n and 4n bodies, each body of the deck split into equal parts, and reports
every printed number (frequencies, reactions, peak loads, damage-equivalent loads) with its
Richardson extrapolation, the observed order and an error estimate
(:func:`pydriver.richardson.richardson`).  The written files are those of the finest run.

How a deck is refined (:func:`refined_deck`): body j becomes k bodies of length l_j / k; the
first keeps body j's start angles and rates, the other k - 1 continue it straight (relative
angles 0), so the start polygon is the deck's own (a ``&shape resample = .true.`` deck's shape
is instead resampled from its own points at every n, :mod:`pydriver.shape_resample`).  Per-body values (diameter, drag
coefficient) are repeated; a deck that sets per-joint constants, per-body masses or lengths,
or a force pulse on one body cannot be refined this way and is refused (deck_rules).
"""

from __future__ import annotations

import re
import time

import numpy as np

from pydriver.analyses.registry import analysis_of, sections_of
from pydriver.errors import DeckError, RunError
from pydriver.progress import report, stage
from pydriver.richardson import (TWO_GRID_SAFETY, departing_level, level_text, outside_physical_range,
                                 richardson, richardson_two)
from pydriver.schema import GROUPS

#: Relative size below which a quantity is taken to be zero by symmetry and not extrapolated
#: (its differences between grids are round-off, whose "order" means nothing).
NEGLIGIBLE = 1.0e-9


def refined_deck(deck, factor: int):
    """The deck with every body split into ``factor`` equal bodies."""
    if factor == 1:
        return deck
    n = deck.n_bodies
    changes = {"chain.n_bodies": n * factor, "refinement.levels": 1}
    for group, keys in GROUPS.items():
        for name, key in keys.items():
            dotted = f"{group}.{name}"
            if key.shape == "joint" and deck.has(dotted):
                deck.fail(group, name, "per-joint values cannot be refined: give the cable's &cable parameters")
            if key.shape != "body" or not deck.has(dotted):
                continue
            if dotted in ("chain.body_length", "chain.body_mass"):
                deck.fail(group, name, "per-body lengths or masses cannot be refined: give total_length and "
                                       "a mass per length")
            if group == "shape" and deck["shape.resample"] and name in ("gamma_deg", "beta_deg"):
                continue                                   # resampled from the deck's points at every n
            values = np.asarray(deck[dotted], float)
            if group == "shape":
                fine = np.zeros(n * factor)
                fine[::factor] = values                    # the first part keeps the joint's angles
            else:
                fine = np.repeat(values, factor)
            changes[dotted] = fine.tolist()
    if deck["loads.pulse_body"] > 0:
        deck.fail("loads", "pulse_body", "a pulse on one body cannot be refined (the body changes with n)")
    return deck.with_values(changes)


def _scalars(summary: dict) -> dict:
    """The printed numbers of a run that refinement extrapolates, by name."""
    out = {}
    for i, f in enumerate(summary.get("frequencies_hz", [])[:6]):
        out[f"f{i + 1} [Hz]"] = f
    # Damped frequencies (joint dampers and the Coriolis coupling of a turning frame): the
    # resonance margins are judged on them.  An overdamped mode (0 Hz) is not extrapolated.
    for i, f in enumerate(summary.get("damped_frequencies_hz", [])[:6]):
        if f > 0.0:
            out[f"fd{i + 1} [Hz]"] = f
    if "equilibrium" in sections_of(summary):        # the reactions of an equilibrium (static, modal)
        for support, wrench in summary.get("reactions", {}).items():
            for kind, unit in (("F", "N"), ("M", "Nm")):
                for comp, value in zip("xyz", wrench[kind]):
                    out[f"{kind}_{support} {comp} [{unit}]"] = value
    for comp, value in zip("xyz", summary.get("tip_m", ()) if not summary.get("n_constraints") else ()):
        out[f"tip {comp} [m]"] = value
    peaks = summary.get("peaks", {})
    for qty, unit in (("bending", "Nm"), ("torsion", "Nm"), ("axial", "N"), ("strain", "-")):
        if qty in peaks:
            out[f"peak {qty} [{unit}]"] = peaks[qty]["max_abs"]
    for name, p in peaks.items():
        if "min" in p:
            out[f"{name} max |.|"] = max(abs(p["min"]), abs(p["max"]))
    fat = summary.get("fatigue")
    if fat:
        top = fat["hotspots"][0]
        out[f"DEL {fat['sn_quantity']}, worst joint"] = top["del_amplitude"]
        if top["life_hours"] is not None:
            # The shortest life over the cable (its worst joint may be another at each n).
            out["fatigue life [h], shortest"] = top["life_hours"]
        for c in fat["clamp_loads"]:
            out[f"DEL {c['quantity']}"] = c["del_amplitude"]
    decay = summary.get("decay") or {}
    if "f_damped_hz" in decay:
        out["decay f_damped [Hz]"] = decay["f_damped_hz"]
    return out


def _non_negative(name: str) -> bool:
    """Whether a quantity of :func:`_scalars` cannot be negative (a frequency, a peak or an
    amplitude, a DEL, a life), so that its extrapolation must not be either
    (:func:`pydriver.richardson.outside_physical_range`); reactions and tip coordinates are signed."""
    return name.startswith(("f", "peak", "DEL", "decay")) or name.endswith("max |.|")


def extrapolate(summaries: list, ns: list, expected_order: float) -> tuple[dict, list]:
    """summary['refinement'] and its warnings from the summaries of the runs at ns = (n, 2n, 4n ...).

    Three or more levels: Richardson over the last three, with the observed order
    (:func:`pydriver.richardson.richardson`).  Two levels cannot observe the order: every value
    is extrapolated with the expected one and its error estimate widened by Roache's two-grid
    safety factor (:func:`pydriver.richardson.richardson_two`); each entry says
    ``order_observed = False`` and one warning says it for all.
    """
    per_run = [_scalars(s) for s in summaries]
    names = [k for k in per_run[-1] if all(k in p for p in per_run)]
    quantities, doubtful, refused = {}, {"oscillating": [], "order": []}, []
    for name in names:
        values = [float(p[name]) for p in per_run]
        if max(abs(v) for v in values) <= NEGLIGIBLE * max(1.0, max(abs(float(x)) for x in per_run[-1].values())):
            continue
        e = (richardson_two(*values, expected_order=expected_order) if len(values) == 2 else
             richardson(*values[-3:], expected_order=expected_order))
        why = outside_physical_range(e) if _non_negative(name) else None
        if why is not None:
            refused.append(f"{name} ({', '.join(f'{v:.4g}' for v in values)} -> {e.extrapolated:.4g} +- "
                           f"{e.error_estimate:.3g}: {why}; {level_text(departing_level(values), ns)} departs)")
            continue
        if len(values) == 2:
            quantities[name] = {"values": values, "extrapolated": e.extrapolated, "observed_order": e.observed_order,
                                "order_observed": False, "error_estimate": e.error_estimate, "warning": ""}
            continue
        quantities[name] = {"values": values, "extrapolated": e.extrapolated, "observed_order": e.observed_order,
                            "order_observed": True, "error_estimate": e.error_estimate, "warning": e.warning or ""}
        if e.warning:
            doubtful["oscillating" if "oscillating" in e.warning else "order"].append(name)
    # One warning per kind, naming the quantities (each one's reason is in its entry).
    warnings = []
    if len(ns) == 2 and quantities:
        warnings.append(f"refinement: two levels (n = {ns[0]}, {ns[1]}) cannot observe the order of convergence: "
                        f"every value is extrapolated with the expected order {expected_order:g} (&refinement "
                        f"expected_order) and its error estimate is {TWO_GRID_SAFETY:g} x the correction; "
                        "levels = 3 observes the order")
    if doubtful["order"]:
        warnings.append(f"refinement: observed order far from the expected {expected_order:g} (extrapolated with "
                        f"{expected_order:g}; not yet in the asymptotic range?) for " + ", ".join(doubtful["order"]))
    if doubtful["oscillating"]:
        warnings.append("refinement: non-monotonic convergence (error estimates unreliable) for "
                        + ", ".join(doubtful["oscillating"]))
    if refused:
        warnings.append("refinement: extrapolations outside the physical range (below 0, or an error estimate "
                        "larger than the value) are no result, left out of refinement.csv: " + "; ".join(refused))
    return {"n": ns, "expected_order": expected_order, "quantities": quantities}, warnings


def refinement_table(refinement: dict) -> dict:
    """refinement.csv: one row per quantity."""
    q = refinement["quantities"]
    names = list(q)
    # The quantity's unit in a column of its own ("peak bending [Nm]" -> "peak bending", "Nm").
    split = [re.fullmatch(r"(.*?)(?: \[([^\]]*)\])?", k).groups() for k in names]
    cols = {"quantity": [a for a, _ in split], "unit": [b or "-" for _, b in split]}
    for i, n in enumerate(refinement["n"]):
        cols[f"n{n}"] = [q[k]["values"][i] for k in names]
    for key in ("extrapolated", "error_estimate", "observed_order", "order_observed"):
        cols[key] = [q[k].get(key) for k in names]
    return cols


def run_refined(model, run_dir, analyse):
    """Run ``analyse(model, run_dir)`` at n, 2n, 4n ...; the finest run's result with
    summary['refinement'] added (a Campbell diagram: every tracked frequency and crossing speed,
    :func:`pydriver.analyses.campbell.refine_diagram`)."""
    from pydriver.model import Model
    t0 = time.perf_counter()
    levels = int(model.deck["refinement.levels"])
    models = [model if k == 0 else Model(refined_deck(model.deck, 2 ** k)) for k in range(levels)]
    # A Campbell diagram is a grid of frequencies and a list of crossings, not a few scalars:
    # its coarse results are kept whole (small); other runs keep only their summaries (a
    # flight's time series need not stay in memory).
    entry = analysis_of(model)
    diagram = entry.refinement == "diagram"
    coarse, walls = [], []
    floquet = model.deck["solver.floquet"] if entry.periodic else False
    floquet_base = None
    for k, m in enumerate(models):
        if floquet and k > 0:
            # Floquet at the deck's own n only: its sensitivities grow as n^2 per step.
            m = Model(m.deck.with_values({"solver.floquet": False}))
        name = f"refinement level {k + 1} of {levels} (n = {m.n_bodies})"
        t_level = time.perf_counter()
        with stage(name):
            try:
                result = analyse(m, run_dir if k == levels - 1 else None)
            except RunError as exc:
                # Say which level failed (issue 22: a 40-body --refine flight failed after 49 s
                # without saying at which n).
                raise RunError(f"{name}: {exc}") from exc
            except DeckError as exc:
                raise DeckError(exc.deck, exc.group, exc.key, f"{exc.reason} ({name})") from exc
        walls.append(time.perf_counter() - t_level)
        if floquet and k == 0:
            floquet_base = (result.summary.get("floquet"), result.extra.get("tables", {}).get("floquet.csv"))
        if k < levels - 1:
            coarse.append(result if diagram else result.summary)
    ns = [m.n_bodies for m in models]
    report(f"refinement: Richardson extrapolation over n = {', '.join(map(str, ns))}")
    expected = float(model.deck["refinement.expected_order"])
    if diagram:
        from pydriver.analyses.campbell import refine_diagram
        refinement, warnings = refine_diagram([*coarse, result], ns, expected)
    else:
        refinement, warnings = extrapolate([*coarse, result.summary], ns, expected)
    result.summary["refinement"] = refinement
    if floquet_base is not None and floquet_base[0] is not None:
        result.summary["floquet"] = dict(floquet_base[0], n_bodies=models[0].n_bodies)
        result.extra.setdefault("tables", {})["floquet.csv"] = floquet_base[1]
    # The job's time, all levels (the finest level's alone was printed as the job's).
    result.summary["wall_time_s"] = time.perf_counter() - t0
    result.summary["wall_time_levels_s"] = walls
    result.summary["deck_n_bodies"] = model.n_bodies
    if warnings:
        result.summary.setdefault("warnings", []).extend(warnings)
    result.extra.setdefault("tables", {})["refinement.csv"] = refinement_table(refinement)
    return result
