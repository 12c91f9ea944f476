"""The analyses a deck can ask for, as registered components (issue 36).

Loads and supports declare themselves once (:mod:`pydriver.components`); so do the analyses.
Each entry of :data:`ANALYSES` names its run function and says what it needs and what it
reports; every caller that behaves differently by analysis (dispatch, the deck rules,
restarts, refinement, sensitivities, resonance margins, reports, plots, frames, exports) asks
the entry instead of comparing the analysis's name, as SciPy's ``solve_ivp`` looks its
integrators up in one table (``scipy/integrate/_ivp/ivp.py``, ``METHODS``).

A new analysis is its module (a run function ``(model, run_dir) -> Result``), one
:class:`Analysis` row here and its schema rows (docs/architecture.md, "Add an analysis").

The run functions are named by ``"module:function"`` and imported when called: the analysis
modules import much of the package, and this table is read by modules they import (the deck
rules, the schema's choices).
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass


@dataclass(frozen=True)
class Analysis:
    """One analysis kind: what runs it and what it needs and reports."""

    name: str                                #: the ``&case analysis`` value
    doc: str                                 #: one line for the reference
    runner: str                              #: ``"module:function"``, (model, run_dir) -> Result at the deck's n
    #: its result is a time history: ``"t_end"`` (a run from t = 0 to ``&solver t_end``) or
    #: ``"revolutions"`` (revolutions until periodic in the turning hub frame); None: no time axis
    time_axis: str | None = None
    needs_rotor: bool = False                #: a turning rotor at a constant speed (``&rotor rpm``)
    sweeps_speed: bool = False               #: it sets the rotor's speed itself, over a range (&campbell)
    restartable: bool = False                #: ``--restart`` continues it from its checkpoint.npz
    #: where its resonance margins take their modes: ``"summary"`` (the damped frequencies in its
    #: summary, refined like every number), ``"diagram"`` (a Campbell grid over speeds); None: none
    modes: str | None = None
    modes_about: str = ""                    #: what those modes are about (the resonance table's words)
    #: ``"module:function"`` differentiating a finished run, (model, plans, result) -> dict; None:
    #: ``&design parameters`` is refused on it
    sensitivities: str | None = None
    #: how refinement extrapolates: ``"scalars"``, ``"diagram"``, or ``"own"`` (the run function
    #: refines what it runs itself, at the deck's levels: ``run_refined`` does not wrap it)
    refinement: str = "scalars"
    #: the report's and the plots' sections beyond the common ones, in order (named in
    #: pydriver/report_html.py and pydriver/plots.py)
    sections: tuple[str, ...] = ()
    optimises: bool = False                  #: an optimiser over runs of another analysis (&design)
    playback_s: float = 0.0                  #: the report animation's length [s] (0: no animation)
    #: the analysis whose runs it is made of, when that is one fixed analysis (a usage spectrum:
    #: flight runs of its regimes): the deck's keys act in it as in that analysis
    #: (pydriver/key_scope.py), unless their scope names it
    evaluates: str | None = None
    #: ``--vtk`` has a cable to draw (a time series, an equilibrium or modes); a usage spectrum
    #: combines runs it does not keep, and refuses the flag before it runs
    draws: bool = True
    #: ``"module:function"`` checking the deck's keys of this analysis that the schema's ranges
    #: cannot (pydriver/deck_rules.py calls it for the deck's analysis), (deck) -> None
    rules: str | None = None

    def run(self, model, run_dir=None):
        """Run this analysis on ``model`` at its n; time series stream into ``run_dir``."""
        return _call(self.runner, model, run_dir)

    def check_deck(self, deck) -> None:
        """Its own deck rules (a DeckError for a violation); nothing if it has none."""
        if self.rules is not None:
            _call(self.rules, deck)

    def differentiate(self, model, plans, result) -> dict:
        """The design sensitivities of a finished run of this analysis."""
        return _call(self.sensitivities, model, plans, result)

    @property
    def periodic(self) -> bool:
        """Its result is one periodic revolution (flight)."""
        return self.time_axis == "revolutions"

    @property
    def integrates(self) -> bool:
        """Its result is a time integration (dynamic, flight): tolerances, an integration error
        estimate, a time series, an animation."""
        return self.time_axis is not None


def _call(target: str, *args):
    module, function = target.split(":")
    return getattr(importlib.import_module(module), function)(*args)


ANALYSES: dict[str, Analysis] = {a.name: a for a in (
    Analysis("static", "equilibrium (Newton on the constraint manifold, or damped settling)",
             "pydriver.analyses.statics:static_analysis",
             sensitivities="pydriver.analyses.sensitivities:static_result_sensitivities",
             sections=("equilibrium",)),
    Analysis("modal", "modes about the equilibrium", "pydriver.analyses.modal:modal_analysis",
             modes="summary", modes_about="the equilibrium of the deck",
             sensitivities="pydriver.analyses.sensitivities:modal_result_sensitivities",
             sections=("equilibrium", "modes")),
    Analysis("dynamic", "time integration (IDA) from t = 0 to t_end",
             "pydriver.analyses.dynamics:dynamic_run", time_axis="t_end", restartable=True,
             sensitivities="pydriver.analyses.dynamic_sensitivities:dynamic_result_sensitivities",
             sections=("time series",), playback_s=10.0),
    Analysis("flight", "forward flight: revolutions until periodic in the turning hub frame",
             "pydriver.analyses.flight:flight_run", time_axis="revolutions", needs_rotor=True,
             modes="summary", modes_about="the hover equilibrium at the flight's rotor speed and n (blade at its mean "
                                          "angles, no stream)",
             sensitivities="pydriver.analyses.flight_sensitivities:flight_result_sensitivities",
             sections=("revolution",), playback_s=6.0),
    Analysis("campbell", "modes against rotor speed, crossings with the k/rev harmonics",
             "pydriver.analyses.campbell:campbell_analysis", needs_rotor=True, sweeps_speed=True, modes="diagram",
             modes_about="the equilibrium at each speed of the diagram", refinement="diagram",
             sections=("campbell",)),
    Analysis("design", "an optimiser over runs of the deck's static, modal or flight analysis",
             "pydriver.analyses.optimiser:design_run", optimises=True, sections=("design",)),
    Analysis("spectrum", "life over a usage spectrum: flight runs of its regimes, the rotor's run-up and the "
                         "ground-air-ground cycles, Miner's rule at every jacket point (&spectrum)",
             "pydriver.analyses.spectrum:spectrum_run", needs_rotor=True, refinement="own", evaluates="flight",
             rules="pydriver.usage_spectrum:check", draws=False, sections=("spectrum",)),
)}


def analysis_of(model) -> Analysis:
    """The registry entry of a model's (or a deck's) ``&case analysis``."""
    deck = getattr(model, "deck", model)
    return ANALYSES[deck["case.analysis"]]


def reported(summary: dict) -> Analysis:
    """The entry whose run a summary reports: a design run's is its base analysis's at the
    optimum (its own sections come on top, :func:`sections_of`)."""
    name = summary.get("base_analysis") if ANALYSES[summary["analysis"]].optimises else summary["analysis"]
    return ANALYSES[name or summary["analysis"]]


def sections_of(summary: dict) -> tuple[str, ...]:
    """The report and plot sections of a summary's run, a design's own after its base's."""
    own = ANALYSES[summary["analysis"]]
    return reported(summary).sections + (own.sections if own.optimises else ())
