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

from pydriver.analyses.registry import analysis_of
from pydriver.errors import DeckError, RunError
from pydriver.progress import report, stage
from pydriver.quantities import label_of, quantities_of, unit_of
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


def extrapolate(summaries: list, ns: list, expected_order: float) -> tuple[dict, list]:
    """summary['refinement'] and its warnings from the summaries of the runs at ns = (n, 2n, 4n ...).

    Three or more levels: Richardson over the last three, with the observed order
    (:func:`pydriver.richardson.richardson`).  Two levels cannot observe the order: every value
    is extrapolated with the expected one and its error estimate widened by Roache's two-grid
    safety factor (:func:`pydriver.richardson.richardson_two`); each entry says
    ``order_observed = False`` and one warning says it for all.
    """
    per_run = [{name: value for name, (_, value) in quantities_of(s).items()} for s in summaries]
    kinds = {name: q for name, (q, _) in quantities_of(summaries[-1]).items()}
    names = [k for k in per_run[-1] if all(k in p for p in per_run)]
    quantities, doubtful, refused = {}, {"oscillating": [], "order": []}, []
    for name in names:
        values = [float(p[name]) for p in per_run]
        if max(abs(v) for v in values) <= NEGLIGIBLE * max(1.0, max(abs(float(x)) for x in per_run[-1].values())):
            continue
        e = (richardson_two(*values, expected_order=expected_order) if len(values) == 2 else
             richardson(*values[-3:], expected_order=expected_order))
        why = outside_physical_range(e) if kinds[name].nonnegative else None
        if why is not None:
            refused.append(f"{name} ({', '.join(f'{v:.4g}' for v in values)} -> {e.extrapolated:.4g} +- "
                           f"{e.error_estimate:.3g}: {why}; {level_text(departing_level(values), ns)} departs)")
            continue
        # "asymptotic": the values behave like f0 + C h^p with the observed order near the expected
        # one (no warning); two levels cannot show it.
        entry = {"unit": kinds[name].unit, "values": values, "extrapolated": e.extrapolated,
                 "observed_order": e.observed_order, "error_estimate": e.error_estimate}
        if len(values) == 2:
            quantities[name] = {**entry, "order_observed": False, "asymptotic": False, "warning": ""}
            continue
        quantities[name] = {**entry, "order_observed": True, "asymptotic": not e.warning, "warning": e.warning or ""}
        if e.warning:
            # Named in the warning as every output names it ("largest bending moment [Nm]").
            doubtful["oscillating" if "oscillating" in e.warning else "order"].append(label_of(name))
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
    # The quantity's name without its "[unit]", and its unit (pydriver.quantities) in a column of
    # its own ("peak bending [Nm]" -> "peak bending", "Nm"; "DEL MB_x" -> "DEL MB_x", "Nm").
    cols = {"quantity": [re.fullmatch(r"(.*?)(?: \[[^\]]*\])?", k).group(1) for k in names],
            "unit": [q[k].get("unit") or unit_of(k) for k in names]}
    for i, n in enumerate(refinement["n"]):
        cols[f"n{n}"] = [q[k]["values"][i] for k in names]
    for key in ("extrapolated", "error_estimate", "observed_order", "order_observed", "asymptotic"):
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
    coarse, walls, jackets = [], [], []
    floquet = model.deck["solver.floquet"] if entry.periodic else False
    for k, m in enumerate(models):
        if floquet:
            # Not the whole monodromy (its 2 nf columns cost as n^2 per step: 113 s at n = 44
            # for the main job): every level's Floquet verdict comes from a subspace of it
            # (floquet_subspace.py) and is extrapolated like every number.  Without it a
            # flight's design sensitivities start from the Krylov periodic start at every level.
            m = Model(m.deck.with_values({"solver.floquet": False}))
        name = f"refinement level {k + 1} of {levels} (n = {m.n_bodies})"
        t_level = time.perf_counter()
        with stage(name):
            try:
                result = analyse(m, run_dir if k == levels - 1 else None)
                if floquet:
                    from pydriver.analyses.floquet_subspace import add_floquet_subspace
                    report(f"refinement: the least damped Floquet modes at n = {m.n_bodies} (a subspace of the "
                           "monodromy)")
                    add_floquet_subspace(m, result)
            except RunError as exc:
                # Say which level failed (issue 22: a 40-body --refine flight failed after 49 s
                # without saying at which n).
                raise RunError(f"{name}: {exc}") from exc
            except DeckError as exc:
                raise DeckError(exc.deck, exc.group, exc.key, f"{exc.reason} ({name})") from exc
        walls.append(time.perf_counter() - t_level)
        # Every jacket point of every level (small: n x points values each): a usage spectrum adds
        # them over its regimes level by level (pydriver/analyses/spectrum_damage.py).
        jackets.append(result.extra.get("fatigue_points"))
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
    if all(j is not None for j in jackets):
        result.extra["fatigue_points_levels"] = jackets
    if floquet:
        # The Floquet verdict at every level; its least damped mode is in summary['refinement'].
        result.summary["floquet"]["levels"] = [
            {key: f[key] for key in ("n_bodies", "stable", "max_multiplier_abs", "least_damped", "wall_time_s")}
            for f in [c["floquet"] for c in coarse] + [result.summary["floquet"]]]
    # The job's time, all levels (the finest level's alone was printed as the job's).
    result.summary["wall_time_s"] = time.perf_counter() - t0
    result.summary["wall_time_levels_s"] = walls
    result.summary["deck_n_bodies"] = model.n_bodies
    if warnings:
        result.summary.setdefault("warnings", []).extend(warnings)
    result.extra.setdefault("tables", {})["refinement.csv"] = refinement_table(refinement)
    return result
