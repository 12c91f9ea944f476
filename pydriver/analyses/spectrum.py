"""Life over a usage spectrum (``&case analysis = 'spectrum'``; issue 38; docs/model.md, "Usage
spectrum").

The registry's run (:func:`spectrum_run`) makes the regimes' flight decks and the run-up deck
(:mod:`pydriver.usage_spectrum`), runs each in this process at the deck's refinement levels
(:mod:`pydriver.analyses.spectrum_records`), and combines them level by level
(:mod:`pydriver.analyses.spectrum_damage`) into :func:`spectrum_result`: the life in flight hours
at the worst jacket point with its Richardson error bar, the safe life, each regime's and the
ground-air-ground cycle's share of the damage there, and the hotspots.  A spectrum directory
(``rotorcable spectrum DECK --out DIR``, :mod:`pydriver.sweep.spectrum`) runs the same decks on
the sweep engines, keeps each regime's record and ends in the same :func:`spectrum_result`.
"""

from __future__ import annotations

import time

import numpy as np

from pydriver.analyses.common import base_summary
from pydriver.analyses.fatigue_loads import mean_stress, sn_curve
from pydriver.analyses.spectrum_damage import level_damage, spectrum_life
from pydriver.analyses.spectrum_records import RegimeRun, of_result, regime_result
from pydriver.errors import DeckError, RunError
from pydriver.progress import stage
from pydriver.run_result import Result
from pydriver.usage_spectrum import Spectrum, angle_fit_summary, base_flight_deck, spectrum_of

#: The rows of spectrum.csv that are not regimes.
GAG_ROW, STARTS_ROW = "ground-air-ground", "start-stops"


def spectrum_run(model, run_dir=None) -> Result:
    """The registry's run of ``analysis = 'spectrum'``: every regime and the run-up in this
    process, then :func:`spectrum_result`.  A regime that fails stops the run, naming itself (a
    spectrum directory keeps the others: :mod:`pydriver.sweep.spectrum`)."""
    t0 = time.perf_counter()
    spec = spectrum_of(model.deck)
    runs = {}
    for k, regime in enumerate(spec.regimes):
        with stage(f"regime '{regime.name}' ({k + 1} of {len(spec.regimes)})"):
            runs[regime.name] = run_regime(model.name, regime.deck, f"regime '{regime.name}'")
    runup = None
    if spec.runup is not None:
        with stage("the run-up"):
            runup = run_regime(model.name, spec.runup, "the run-up")
    return spectrum_result(model, spec, runs, runup, time.perf_counter() - t0)


def run_regime(spectrum: str, deck, what: str) -> RegimeRun:
    """One regime's (or the run-up's) run in this process; its errors name the spectrum deck
    ``spectrum`` and the regime (``what``)."""
    try:
        return of_result(regime_result(deck))
    except RunError as exc:
        raise RunError(f"deck '{spectrum}': {what}: {exc}") from exc
    except DeckError as exc:
        raise DeckError(spectrum, exc.group, exc.key, f"{what}: {exc.reason}") from exc


def _joint_arcs(spec: Spectrum, n: int) -> np.ndarray:
    """Arc length of every joint from clamp A at n bodies [m] (a uniform chain: refinement's)."""
    from pydriver.analyses.refinement import refined_deck
    from pydriver.assembly import bodies
    deck = spec.regimes[0].deck
    lengths = bodies(refined_deck(deck, n // deck.n_bodies)).lengths
    return np.concatenate([[0.0], np.cumsum(lengths)[:-1]])


def _where(quantity: str, joint: int, arc: float, angle: float) -> str:
    return f"{quantity} at joint {joint} ({arc:.3f} m), {angle:.0f} deg around"


def spectrum_result(model, spec: Spectrum, runs: dict, runup: RegimeRun | None, wall: float) -> Result:
    """The spectrum's result from its regimes' runs (``{name: RegimeRun}``) and the run-up's.

    Raises
    ------
    RunError
        Regimes run at other levels than the others (a spectrum directory whose records do not
        belong together).
    """
    deck = model.deck
    base = base_flight_deck(deck)
    sn, correction = sn_curve(base), mean_stress(base)
    names = [r.name for r in spec.regimes]
    ns = runs[names[0]].ns
    for name in names[1:]:
        if runs[name].ns != ns:
            raise RunError(f"deck '{deck.name}': regime '{name}' was run at n = {runs[name].ns}, regime "
                           f"'{names[0]}' at n = {ns}: the records do not belong together")
    if runup is not None and runup.ns != ns:
        raise RunError(f"deck '{deck.name}': the run-up was run at n = {runup.ns}, the regimes at n = {ns}")
    shares = [r.share for r in spec.regimes]
    levels = []
    for k in range(len(ns)):
        try:
            levels.append(level_damage(shares, [runs[name].levels[k] for name in names],
                                       runup.levels[k] if runup is not None else None, spec.flights_per_hour,
                                       spec.start_stops_per_flight, sn, correction))
        except ValueError as err:
            raise RunError(f"deck '{deck.name}': n = {ns[k]}: {err}") from None
    life = spectrum_life(levels, float(deck["refinement.expected_order"]))
    fine = life.finest
    w = fine.worst
    total_w = float(fine.total[w])
    arcs = _joint_arcs(spec, ns[-1])
    quantity = base["fatigue.sn_quantity"]
    unit = "-" if quantity == "strain" else "Nm"
    joint_w, angle_w = int(fine.joint[w]), float(fine.angle_deg[w])

    def share_of(x: float) -> float:
        return x / total_w if total_w > 0.0 else 0.0

    regimes = []
    for i, regime in enumerate(spec.regimes):
        alone = fine.regime_alone[i]
        top = float(np.max(alone))
        entry = {"name": regime.name, "time_share": regime.share,
                 "changes": {k: str(v) for k, v in regime.changes.items()},
                 "damage_per_hour_in_regime": float(alone[w]), "damage_per_flight_hour": float(fine.regimes[i][w]),
                 "damage_share": share_of(float(fine.regimes[i][w])),
                 "life_alone_hours": 1.0 / top if top > 0.0 else None}
        refined = runs[regime.name].summary.get("refinement", {}).get("quantities", {}).get(
            "fatigue life [h], shortest")
        if refined:
            entry["life_alone_extrapolated_hours"] = refined["extrapolated"]
            entry["life_alone_error_hours"] = refined["error_estimate"]
        if regime.blade_file:
            entry["blade_file"] = regime.blade_file
            entry["blade_fit"] = {angle: angle_fit_summary(fit) for angle, fit in regime.blade_fit.items()}
        regimes.append(entry)
    life_fine = fine.life_hours
    converged = life.extrapolated if life.extrapolated is not None else life_fine
    block = {
        "description": (f"Miner's sum over {len(names)} regimes (their shares of the flight time), "
                        f"{spec.flights_per_hour:g} ground-air-ground cycles per flight hour and "
                        f"{spec.flights_per_hour * spec.start_stops_per_flight:g} rotor start-stops (run-up and "
                        f"run-down) per flight hour, at every point around every joint's jacket ({quantity}); "
                        + ("no mean-stress correction" if not correction.active else correction.describe())),
        "sn_quantity": quantity, "unit": unit,
        "life_hours": life_fine, "n_bodies": ns[-1],
        "life_converged_hours": converged,
        "scatter_factor": spec.scatter_factor,
        "safe_life_hours": None if converged is None else converged / spec.scatter_factor,
        "damage_per_flight_hour": total_w,
        "worst_point": {"joint": joint_w, "angle_deg": angle_w, "arc_length_m": float(arcs[joint_w - 1]),
                        "where": _where(quantity, joint_w, float(arcs[joint_w - 1]), angle_w)},
        "damage_shares": {**{r["name"]: r["damage_share"] for r in regimes},
                          GAG_ROW: share_of(float(fine.gag[w])), STARTS_ROW: share_of(float(fine.start_stops[w]))},
        "flights_per_hour": spec.flights_per_hour, "start_stops_per_flight": spec.start_stops_per_flight,
        "mean_stress": correction.method,
        "regimes": regimes,
        "levels": [{"n": n, "life_hours": lv.life_hours, "worst_joint": int(lv.joint[lv.worst]),
                    "worst_angle_deg": float(lv.angle_deg[lv.worst])} for n, lv in zip(ns, levels)],
    }
    if life.extrapolated is not None:
        block.update(life_extrapolated_hours=life.extrapolated, life_error_hours=life.error_estimate,
                     observed_order=life.observed_order, order_observed=life.order_observed,
                     safe_life_error_hours=life.error_estimate / spec.scatter_factor)
    if fine.rest is not None:
        block["gag_cycle"] = {"rest": float(fine.rest[w]), "low": float(fine.gag_low[w]),
                              "high": float(fine.gag_high[w]),
                              "damage_per_cycle": float(fine.gag[w]) / spec.flights_per_hour}
    # Each joint's worst point, the joints ranked by it.
    per_joint = [(int(j), int(np.argmax(np.where(fine.joint == j, fine.total, -np.inf))))
                 for j in np.unique(fine.joint)]
    ranked = sorted(per_joint, key=lambda t: float(fine.total[t[1]]), reverse=True)
    block["hotspots"] = [{"rank": r + 1, "joint": j, "arc_length_m": float(arcs[j - 1]),
                          "angle_deg": float(fine.angle_deg[p]),
                          "quantity": _where(quantity, j, float(arcs[j - 1]), float(fine.angle_deg[p])),
                          "damage_per_hour": float(fine.total[p]),
                          "life_hours": 1.0 / float(fine.total[p]) if fine.total[p] > 0.0 else None}
                         for r, (j, p) in enumerate(ranked[:int(base["fatigue.hotspots"])])]
    summary = base_summary(model, "spectrum", wall)
    summary["spectrum"] = block
    strains = [(runs[name].summary["peaks"]["strain"], name) for name in names if "peaks" in runs[name].summary]
    if strains:
        peak, name = max(strains, key=lambda t: t[0]["max_abs"])
        block["largest_strain"] = {"max_abs": peak["max_abs"], "joint": peak["joint"],
                                   "azimuth_deg": peak["azimuth_deg"], "regime": name}
    # One line per warning, naming every regime that gave it (the hover modes' resonance margin is
    # the same in every regime of one rotor speed).
    said: dict[str, list] = {}
    for name in names:
        for w_ in runs[name].summary.get("warnings", []):
            said.setdefault(w_, []).append(f"'{name}'")
    warnings = [f"regime{'s' if len(who) > 1 else ''} {', '.join(who)}: {w_}" for w_, who in said.items()]
    if runup is not None:
        warnings += [f"the run-up: {w_}" for w_ in runup.summary.get("warnings", [])]
    if life.warning:
        warnings.append(f"spectrum life: {life.warning}")
    if life_fine is None:
        warnings.append("spectrum: no point of the cable takes damage: the life is unbounded (an S-N curve far "
                        "above the loads, or an endurance cut-off above every cycle)")
    if warnings:
        summary["warnings"] = warnings
    tables = {"spectrum.csv": _spectrum_table(regimes, fine, w, spec.flights_per_hour, share_of)}
    if len(ns) > 1:
        from pydriver.analyses.refinement import refinement_table
        quantities = {}
        if life.extrapolated is not None:
            quantities["spectrum life [h]"] = {"unit": "h", "values": [lv.life_hours for lv in levels],
                                               "extrapolated": life.extrapolated,
                                               "observed_order": life.observed_order,
                                               "order_observed": life.order_observed,
                                               "asymptotic": bool(life.order_observed and not life.warning),
                                               "error_estimate": life.error_estimate,
                                               "warning": life.warning}
        summary["refinement"] = {"n": ns, "expected_order": float(deck["refinement.expected_order"]),
                                 "quantities": quantities}
        tables["refinement.csv"] = refinement_table(summary["refinement"])
    return Result(summary=summary, extra={"tables": tables, "spectrum_levels": levels})


def _spectrum_table(regimes: list, fine, w: int, flights: float, share_of) -> dict:
    """spectrum.csv: one row per regime, then the ground-air-ground cycles and the start-stops."""
    rows = [{"regime": r["name"], "time_share": r["time_share"],
             "damage_per_hour_in_regime": r["damage_per_hour_in_regime"],
             "damage_per_flight_hour": r["damage_per_flight_hour"], "damage_share": r["damage_share"],
             "life_alone_hours": r["life_alone_hours"]} for r in regimes]
    if flights > 0.0:
        for name, values in ((GAG_ROW, fine.gag), (STARTS_ROW, fine.start_stops)):
            top = float(np.max(values))
            rows.append({"regime": name, "time_share": None, "damage_per_hour_in_regime": None,
                         "damage_per_flight_hour": float(values[w]), "damage_share": share_of(float(values[w])),
                         "life_alone_hours": 1.0 / top if top > 0.0 else None})
    return {key: [r[key] for r in rows] for key in rows[0]}
