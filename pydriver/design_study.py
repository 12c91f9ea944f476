"""The design study of the README (issue 24, item 4): a design deck's fatigue life before and
after optimisation, each with its Richardson error bar.

1. **Optimise from several starts.**  A frequency margin splits the parameter box into separate
   feasible regions, one per gap between the forbidden bands k Omega (1 +- margin), and a
   gradient method stays in the gap its start's first frequency lies in
   (:func:`pydriver.design_measures.allowed_gap`).  The study starts the optimiser from the
   deck's own values and from the two corners of the box where every parameter sits at its lower
   bound and at its upper bound: where the first frequency is monotone enough in the parameters
   (a shorter cable, a clamp further out: stiffer), the corners reach the gaps on either side of
   the band the deck starts in.  The best design whose optimiser converged and that holds the
   margin wins; every start is reported.
2. **Refine before and after.**  The deck's own design and the winner are run as plain flight
   decks at n, 2n, 4n bodies (``&refinement levels``); the shortest fatigue life over the cable
   comes with its Richardson extrapolation, observed order and error estimate
   (:mod:`pydriver.analyses.refinement`, quantity ``fatigue life [h], shortest``).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from pydriver.analyses.hover_modes import hover_model
from pydriver.analyses.optimiser import design_analysis, parameter_changes
from pydriver.analyses.resonance import harmonic_margin, operating_speeds
from pydriver.deckfile import validate
from pydriver.design_problem import problem
from pydriver.model import Model
from pydriver.ownership import study_kind
from pydriver.run import run_deck
from pydriver.run_directory import RunDirectory

#: The refined quantity that is the cable's fatigue life (pydriver/analyses/refinement.py).
LIFE = "fatigue life [h], shortest"


def starts(model: Model) -> dict:
    """{label: parameter vector} of the optimiser's starts (module doc, step 1)."""
    prob = problem(model.deck)
    return {"deck": np.array([p.value for p in prob.parameters]), "all lower": prob.lower.copy(),
            "all upper": prob.upper.copy()}


def frequency_shift(model: Model, changes: dict, levels: int) -> float:
    """f1(converged) - f1(n) of the hover state of the design ``changes``: Richardson over n, 2n,
    4n of the modal analysis about the hover equilibrium (cheap beside a flight run)."""
    hover = hover_model(Model(_plain_flight_deck(model, changes, 1)))
    f1 = run_deck(hover.with_changes({"refinement.levels": levels})).summary["refinement"]["quantities"]["f1 [Hz]"]
    return float(f1["extrapolated"] - f1["values"][0])


def optimise_from(model: Model, p0, levels: int) -> dict:
    """One optimisation of the design deck from the parameter vector ``p0``, its frequency
    margin judged on the converged first frequency: f1 at the deck's n plus the discretisation
    shift f1(converged) - f1(n) at the start, then again with the shift at that optimum (it
    moves little with the design: the second pass starts at the first optimum).  Returns
    summary['design'] with the design's life at the deck's n."""
    prob = problem(model.deck)
    p = np.asarray(p0, float)
    shifts = []
    first_start = None
    for _ in range(2 if prob.frequency_margin_percent is not None else 1):
        changes = parameter_changes(model.deck, prob.parameters, p)
        shifts.append(frequency_shift(model, changes, levels) if prob.frequency_margin_percent is not None else 0.0)
        result = design_analysis(model.with_changes(changes), shifts[-1])
        p = np.array([d["optimum"] for d in result.summary["design"]["parameters"].values()])
        if first_start is None:
            first_start = result.summary["design"]["objective"]["start"]
    block = dict(result.summary["design"])
    block["life_hours"] = _life(result.summary)
    block["frequency_shifts_hz"] = shifts
    block["objective"] = {**block["objective"], "start": first_start}      # the start of the first pass
    block["optimum_changes"] = {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in
                                parameter_changes(model.deck, prob.parameters,
                                                  [d["optimum"] for d in block["parameters"].values()]).items()}
    return block


def refined_life(model: Model, changes: dict, levels: int) -> dict:
    """The shortest fatigue life of the design ``changes`` as a plain flight deck refined to
    ``levels`` levels: {n, values, extrapolated, error_estimate, observed_order}."""
    deck = _plain_flight_deck(model, changes, levels)
    summary = run_deck(Model(deck)).summary
    q = summary["refinement"]["quantities"][LIFE]
    f1 = summary["refinement"]["quantities"]["f1 [Hz]"]
    rpm = operating_rpm(Model(deck))
    margin = harmonic_margin(f1["extrapolated"], f1["error_estimate"], rpm, int(deck["resonance.harmonics"]))
    return {"n": summary["refinement"]["n"], "values_h": q["values"], "extrapolated_h": q["extrapolated"],
            "error_estimate_h": q["error_estimate"], "observed_order": q["observed_order"],
            "warning": q.get("warning", ""),
            # The margin held at the optimiser's n, judged again on the converged frequency.
            "f1_hz": f1["extrapolated"], "f1_error_hz": f1["error_estimate"], "f1_values_hz": f1["values"],
            "margin_percent": margin["margin_percent"], "worst_margin_percent": margin["worst_margin_percent"],
            "nearest_harmonic": margin["harmonic"]}


def _plain_flight_deck(model: Model, changes: dict, levels: int):
    """The design deck at the design ``changes`` without &design: a plain flight deck (no
    sensitivities), refined to ``levels``."""
    raw = {g: dict(v) for g, v in model.deck.raw.items() if g != "design"}
    given = {g: dict(v) for g, v in model.deck.starts.items() if g != "design"}
    raw["case"]["analysis"] = "flight"
    given.get("case", {}).pop("analysis", None)
    return validate(raw, given, model.deck.name).with_values({**changes, "refinement.levels": levels})


def operating_rpm(model: Model) -> float:
    """The rotor speed the margin is judged at [rpm]."""
    return [r for r in operating_speeds(model) if r > 0.0][0]


def _life(summary: dict) -> float | None:
    hot = summary.get("fatigue", {}).get("hotspots", [])
    return hot[0]["life_hours"] if hot else None


def design_study(deck_path, out: Path, levels: int = 3) -> dict:
    """Run the study (module doc) on a design deck with a flight objective; writes
    ``design_study.json`` into ``out`` and returns its content.

    ``out`` is an output of the kind ``study design`` (:mod:`pydriver.ownership`): new, empty
    or one earlier design study, checked before the optimisations start and written whole.

    Raises
    ------
    OutputError
        ``out`` must not be written (a user's files, another kind of output, a link, ...).
    RuntimeError
        No start converged to a design that holds the frequency margin.
    """
    model = Model.from_deck(deck_path)
    with RunDirectory(Path(out), deck=model.name, kind=study_kind("design")) as run_dir:
        study = _design_study(model, deck_path, levels)
        run_dir.path("design_study.json").write_text(json.dumps(study, indent=2, default=float) + "\n")
        run_dir.commit()
    return study


def _design_study(model: Model, deck_path, levels: int) -> dict:
    runs = {label: optimise_from(model, p0, levels) for label, p0 in starts(model).items()}
    fair = {k: r for k, r in runs.items()
            if r["converged"] and r.get("frequency_margin", {}).get("satisfied", True)}
    if not fair:
        raise RuntimeError(f"design study of '{model.name}': no start converged to a design that holds the "
                           "frequency margin: " + "; ".join(f"{k}: {r['message']}" for k, r in runs.items()))
    best = min(fair, key=lambda k: fair[k]["objective"]["optimum"])
    prob = problem(model.deck)
    deck_changes = parameter_changes(model.deck, prob.parameters, [p.value for p in prob.parameters])
    before = refined_life(model, deck_changes, levels)
    after = refined_life(model, runs[best]["optimum_changes"], levels)
    required = prob.frequency_margin_percent
    study = {"deck": str(deck_path), "objective": runs[best]["objective"]["name"], "starts": runs, "best": best,
             "before": before, "after": after, "required_margin_percent": required,
             "life_gain": after["extrapolated_h"] / before["extrapolated_h"]}
    # Judged on the converged frequency: a shortfall within its error bar is not resolved (the
    # optimum sits on a band edge when the margin is active); the margin at the far edge of the
    # error bar is reported beside.
    bar_percent = 100.0 * after["f1_error_hz"] / (after["nearest_harmonic"] * operating_rpm(model) / 60.0)
    if required is not None and after["margin_percent"] + bar_percent < required:
        study["warning"] = (f"the optimum holds the {required:g} % margin at n = {after['n'][0]}, but its converged "
                            f"first frequency {after['f1_hz']:.4g} +- {after['f1_error_hz']:.2g} Hz is only "
                            f"{after['margin_percent']:.2f} % from {after['nearest_harmonic']}/rev")
    return study


def study_lines(study: dict) -> list[str]:
    """The study's printed summary."""
    lines = []
    for label, r in study["starts"].items():
        fm = r.get("frequency_margin", {})
        params = ", ".join(f"{k} = {v['optimum']:.4g} {v['unit']}" for k, v in r["parameters"].items())
        lines.append(f"start '{label}': {r['objective']['name']} {r['objective']['start']:.4g} -> "
                     f"{r['objective']['optimum']:.4g} {r['objective']['unit']}, converged {r['converged']}, "
                     f"f1 + shift {fm.get('optimum', {}).get('f1_hz', float('nan')):.4g} Hz (shift "
                     f"{r['frequency_shifts_hz'][-1]:+.3g} Hz); {params}")
    for key in ("before", "after"):
        r = study[key]
        lines.append(f"life {key} (n = {', '.join(map(str, r['n']))}): {r['extrapolated_h']:.4g} +- "
                     f"{r['error_estimate_h']:.2g} h (Richardson, observed order {r['observed_order']:.2f}; "
                     f"at n = {r['n'][0]}: {r['values_h'][0]:.4g} h)")
    for key in ("before", "after"):
        r = study[key]
        lines.append(f"first frequency {key}: {r['f1_hz']:.4g} +- {r['f1_error_hz']:.2g} Hz (Richardson; at n = "
                     f"{r['n'][0]}: {r['f1_values_hz'][0]:.4g} Hz), {r['margin_percent']:.2f} % from "
                     f"{r['nearest_harmonic']}/rev ({r['worst_margin_percent']:.2f} % at the edge of its error bar)")
    lines.append(f"best start '{study['best']}': life x {study['life_gain']:.3g}")
    if "warning" in study:
        lines.append("warning: " + study["warning"])
    return lines
