"""Each dynamic and flight run's estimate of its own integration error (issue 35).

IDA controls the local error of each step against ``&solver rtol`` and ``atol``; how large the
global error of the numbers a run reports comes out is not controlled, and a loose tolerance
gave the six-link dynamic reaction F_A,x 9 % off at rtol 1e-2 without a word.  So a run repeats
part of itself at a tolerance a hundred times tighter (:data:`TIGHTEN`) and reports how much its
headline numbers moved, which estimates its own error (the tighter pass's error is ~100 times
smaller, so the difference is the loose run's error to ~1 %):

* a flight run: its last, periodic revolution again from the same start on the orbit (the
  monodromy starts there too); the periodic state attracts, so one revolution carries the error
  of the reported one;
* a dynamic run: the whole run again (its error accumulates from t = 0), held in memory.

Reported per family of headline numbers (support reactions, joint loads, jacket strain; each the
largest change of a sampled value over the family's largest value) and, with ``&fatigue``, the
relative change of the shortest life.  A change above :data:`WARN_SHARE` (loads) or
:data:`WARN_LIFE_SHARE` (life) is a warning naming ``&solver rtol``.  ``&solver error_estimate =
.false.`` skips the pass (a long dynamic run pays about twice its cost for it).
"""

from __future__ import annotations

import numpy as np

from pydriver.analyses.record_columns import chunk_columns
from pydriver.errors import DeckError, RunError
from pydriver.progress import report

#: The check's tolerances are the run's divided by this.
TIGHTEN = 100.0
#: The tightest tolerances the check uses: rtol = atol = 1e-12 is the reference level every shipped
#: dynamic and flight deck reaches (benchmarks/work_precision.py's reference; tests/test_integration_error.py).
TIGHTEST = 1.0e-12
#: A headline load that moved by more than this share of its family's largest value is a warning:
#: fatigue damage goes with the amplitude to the S-N exponent (5 to 10), so 1e-3 in the loads is up
#: to 1 % in the damage.
WARN_SHARE = 1.0e-3
#: A shortest life that moved by more than this share is a warning.
WARN_LIFE_SHARE = 1.0e-2

_FAMILIES = {"support reactions": ("FA_", "MA_", "FB_", "MB_"),
             "joint loads": ("axial", "shear", "bending", "torsion"),
             "jacket strain": ("strain",)}


def check_settings(model) -> dict | None:
    """The solver settings of the check pass, or None when the run is at the tightest level."""
    settings = model.solver_settings()
    rtol, atol = float(settings["rtol"]), float(settings["atol"])
    if rtol <= TIGHTEST:
        return None
    settings.update(rtol=max(rtol / TIGHTEN, TIGHTEST), atol=max(min(atol, rtol) / TIGHTEN, TIGHTEST))
    return settings


def _family_changes(ts: dict, check: dict, rows) -> dict:
    """{family: largest |change| over its largest |value|} of the columns both series have."""
    out = {}
    for family, prefixes in _FAMILIES.items():
        # The reactions alone (their opposites, the loads on the supports, would count twice).
        names = [c for c in ts if c.startswith(prefixes) and "_on_support_" not in c and c in check]
        if not names:
            continue
        a = np.stack([np.asarray(ts[c], float)[rows] for c in names])
        b = np.stack([np.asarray(check[c], float) for c in names])
        scale = float(np.max(np.abs(a)))
        if scale > 0.0:
            out[family] = float(np.max(np.abs(a - b)) / scale)
    return out


#: A shortest life above this [h] is no damage worth estimating an error of: near the S-N curve's
#: endurance its relative change is that of a vanishing number (a hover's 1e63 h moved by 5 %).
NO_DAMAGE_HOURS = 1.0e9


def _shortest_life(fatigue: dict | None) -> float | None:
    hotspots = (fatigue or {}).get("hotspots") or []
    lives = [h["life_hours"] for h in hotspots if h.get("life_hours")]
    return min(lives) if lives and min(lives) < NO_DAMAGE_HOURS else None


def _entry(method: str, settings: dict, changes: dict, life: float | None, life_check: float | None) -> dict:
    entry = {"method": method, "check_rtol": settings["rtol"], "check_atol": settings["atol"],
             "relative_change": changes}
    if life is not None and life_check is not None:
        entry["shortest_life_relative_change"] = abs(life - life_check) / life
    return entry


def _warnings(model, entry: dict) -> list[str]:
    worst = max(entry["relative_change"].items(), key=lambda kv: kv[1], default=None)
    out = []
    rtol = model.deck["solver.rtol"]
    if worst is not None and worst[1] > WARN_SHARE:
        out.append(f"integration error: the {worst[0]} moved by {100 * worst[1]:.2g} % of their largest value when "
                   f"the run was repeated at rtol {entry['check_rtol']:g} (share allowed {100 * WARN_SHARE:g} %): "
                   f"the results at &solver rtol = {rtol:g} are not converged in the tolerance; tighten rtol")
    life = entry.get("shortest_life_relative_change")
    if life is not None and life > WARN_LIFE_SHARE:
        out.append(f"integration error: the shortest fatigue life moved by {100 * life:.2g} % at rtol "
                   f"{entry['check_rtol']:g} (share allowed {100 * WARN_LIFE_SHARE:g} %); tighten &solver rtol "
                   f"(now {rtol:g})")
    return out


def _attach(model, result, entry: dict) -> None:
    result.summary["integration_error"] = entry
    warnings = _warnings(model, entry)
    if warnings:
        result.summary.setdefault("warnings", []).extend(warnings)


def _skip(result, why: str) -> None:
    result.summary["integration_error"] = {"method": "not estimated", "why": why}


def flight_check(model, result) -> None:
    """Repeat the flight's last revolution at the check's tolerances and attach the estimate."""
    from pydriver.analyses.fatigue_loads import fatigue_of_run
    if not model.deck["solver.error_estimate"]:
        return _skip(result, "&solver error_estimate = .false.")
    settings = check_settings(model)
    if settings is None:
        return _skip(result, f"the run is at the tightest tolerance checked (rtol {TIGHTEST:g})")
    report(f"flight: integration error check (the last revolution again at rtol {settings['rtol']:g})")
    orbit, ts = result.extra["orbit"], result.timeseries
    period = orbit["period_s"]
    spr = len(ts["t"]) - 1
    t = period * np.arange(spr + 1) / spr
    session = model.core.start(settings, 0.0, orbit["q0"], orbit["v0"])
    try:
        q, v = session.advance(t)
    finally:
        session.close()
    check = chunk_columns(model, t, model.core.sample(t, q, v), q, v)
    life = life_check = None
    if "fatigue" in model.deck.groups:
        life = _shortest_life(result.summary.get("fatigue"))
        life_check = _shortest_life(fatigue_of_run(model, check, periodic=True)[0])
    _attach(model, result, _entry(f"the last revolution again from its start at rtol/{TIGHTEN:g}", settings,
                                  _family_changes(ts, check, slice(None)), life, life_check))


def dynamic_check(model, result, dynamic_analysis) -> None:
    """Repeat the dynamic run at the check's tolerances (in memory, by ``dynamic_analysis(model)``,
    the run's own function) and attach the estimate."""
    if not model.deck["solver.error_estimate"]:
        return _skip(result, "&solver error_estimate = .false.")
    settings = check_settings(model)
    if settings is None:
        return _skip(result, f"the run is at the tightest tolerance checked (rtol {TIGHTEST:g})")
    if result.timeseries is None:
        return _skip(result, "the run's time series is on disk only (too large to hold twice in memory)")
    report(f"dynamic: integration error check (the run again at rtol {settings['rtol']:g})")
    tight = model.with_changes({"solver.rtol": settings["rtol"], "solver.atol": settings["atol"]})
    try:
        check = dynamic_analysis(tight).timeseries
    except (DeckError, RunError) as exc:
        return _skip(result, f"the check pass failed: {exc}")
    _attach(model, result, _entry(f"the whole run again at rtol/{TIGHTEN:g}", settings,
                                  _family_changes(result.timeseries, check, slice(None)), None, None))
