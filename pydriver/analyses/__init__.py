"""The analyses a deck can ask for, each on a :class:`~pydriver.model.Model`:
static equilibrium, dynamic run, modal analysis (and, built on them, forward flight, the
Campbell diagram and design optimisation), registered in :mod:`pydriver.analyses.registry`.
:func:`run` looks the deck's ``&case analysis`` up there; runs whose analysis has modes end with
their resonance margins (:mod:`pydriver.analyses.resonance`)."""

from __future__ import annotations


def run(model, run_dir=None, restart=None):
    """Run the deck's analysis; time series stream into ``run_dir`` (an output.RunDirectory).
    With ``&refinement levels > 1`` the analysis runs at n, 2n, 4n ... bodies
    (:mod:`pydriver.analyses.refinement`).  ``restart`` (a checkpoint) continues a dynamic run.
    With ``&design parameters`` a static or modal run adds its design sensitivities
    (:mod:`pydriver.analyses.sensitivities`); the parameters are checked before the analysis."""
    import time

    from pydriver.analyses.registry import analysis_of
    from pydriver.analyses.sensitivities import attach_sensitivities, plan
    entry = analysis_of(model)
    # An optimiser differentiates each of its evaluations itself (pydriver/analyses/optimiser.py).
    t_plan = time.perf_counter()
    plans = plan(model) if entry.sensitivities else []
    t_plan = time.perf_counter() - t_plan
    if restart is not None:
        if model.deck["refinement.levels"] > 1:
            model.deck.fail("refinement", "levels", "--restart continues one run at one n: set levels = 1")
        from pydriver.analyses import dynamics
        # pydriver.checkpoint.continuation refused a deck whose analysis is not restartable.
        result = dynamics.dynamic_analysis(model, run_dir, restart=restart)
    elif model.deck["refinement.levels"] > 1 and entry.refinement != "own":
        from pydriver.analyses.refinement import run_refined
        result = run_refined(model, run_dir, _with_sensitivities(model, plans) if plans else run_single)
    else:
        result = run_single(model, run_dir)
        attach_sensitivities(model, result, plans)
        if plans:
            # The parameters' rebuilt models are part of what the sensitivities cost.
            result.summary["sensitivities"]["model_builds_wall_time_s"] = t_plan
    finish(model, result)
    return result


def finish(model, result) -> None:
    """What every run of a deck ends with: the warnings of the keys it ignored, the resonance
    margins and the limits (also a usage spectrum combined from its records,
    :mod:`pydriver.sweep.spectrum`)."""
    # Keys this analysis does not read say so (pydriver/key_scope.py: &fatigue in a static run,
    # &solver floquet outside flight runs, ...).
    from pydriver.key_scope import warnings as ignored_key_warnings
    ignored = ignored_key_warnings(model.deck)
    if ignored:
        result.summary.setdefault("warnings", []).extend(ignored)
    # The one value of each headline quantity (converged with its error bar where refinement ran),
    # which the summary, report.html and the limits read (pydriver.quantities).
    from pydriver.quantities import headlines
    result.summary["headline"] = headlines(result.summary)
    if "reactions" in result.summary:
        from pydriver.analyses.common import loads_on_supports
        result.summary["loads_on_supports"] = loads_on_supports(result.summary["reactions"])
    from pydriver.analyses.resonance import attach_margins
    attach_margins(model, result)
    from pydriver.analyses.limits import attach_limits
    attach_limits(model, result)


def _with_sensitivities(model, plans):
    """A refined run's analysis of one level with that level's sensitivities; after the finest
    level, their extrapolation (:mod:`pydriver.analyses.refined_sensitivities`)."""
    from pydriver.analyses.refined_sensitivities import refine_sensitivities
    from pydriver.analyses.sensitivities import attach_sensitivities, plan
    levels, ns = [], []

    def analyse(m, run_dir):
        result = run_single(m, run_dir)
        # Each level's parameters are rebuilt at its own n (the deck's plans at the deck's n).
        attach_sensitivities(m, result, plans if m.n_bodies == model.n_bodies else plan(m))
        levels.append(result.summary["sensitivities"])
        ns.append(m.n_bodies)
        if len(levels) == int(model.deck["refinement.levels"]):
            refined, rows, warnings = refine_sensitivities(levels, ns, float(model.deck["refinement.expected_order"]))
            result.summary["sensitivities"]["refined"] = refined
            result.summary.setdefault("warnings", []).extend(warnings)
            result.extra["tables"]["sensitivities_refined.csv"] = rows
            result.extra.setdefault("units", {})["sensitivities_refined.csv"] = {
                key: "*" for key in rows if key.startswith("n") or key in ("extrapolated", "error_estimate")}
        return result
    return analyse


def run_single(model, run_dir=None):
    """Run the deck's analysis at the deck's n (its registry entry's run function)."""
    from pydriver.analyses.registry import analysis_of
    return analysis_of(model).run(model, run_dir)
