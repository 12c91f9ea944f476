"""Design optimisation (``&case analysis = 'design'``; issue 24, item 3; issue 36, item 5;
docs/model.md, "Design optimisation").

Each evaluation is a whole run of the deck's base analysis at the trial parameters (the static
equilibrium, solved from the deck's start shape; with the modes about it when the objective or
the frequency margin needs them) and its exact design sensitivities
(:mod:`pydriver.analyses.sensitivities`): the gradients of the objective and the constraints
come from the implicit function theorem, Fox-Kapoor and the damped roots' left and right
eigenvectors, not from differences of whole runs.  scipy.optimize.minimize (SLSQP, Kraft 1988,
or trust-constr) takes them with ``jac=True`` and constraint Jacobians, on a scaled problem:
each parameter mapped to [0, 1] between its bounds, the objective divided by its start value,
the frequency constraints by the rotor frequency.

A flight objective (the largest damage per flight hour, the largest strain amplitude) evaluates
a whole flight run to its periodic revolution with its flight sensitivities
(:mod:`pydriver.analyses.flight_sensitivities`: forward sensitivities through the DAE, the
periodic start by the monodromy, damage with the cycle set held fixed); its frequency margin is
that of the hover state at the flight's rotor speed (:mod:`pydriver.analyses.hover_modes`).
The spectrum objective (the largest damage per flight hour over a usage spectrum) evaluates every
regime's flight and the run-up at the deck's n with their sensitivities at the spectrum's worst
points (:mod:`pydriver.analyses.spectrum_design`); its margin is that of the hover state of the
spectrum's base flight deck, and its optimum is a plain spectrum deck.

A largest-of-several objective (the largest support force, the largest joint moment) is
minimised in the epigraph form: minimise t subject to t >= term_i.  The frequency margin
(:mod:`pydriver.analyses.frequency_margin`) keeps every excited mode's damped frequency in the
gap between the forbidden bands k Omega (1 +- margin) where it starts.

**Several starts.**  A gradient method finds a local optimum, and with a frequency margin it
stays in the gaps its start lies in.  The optimiser runs from each of ``&design starts`` starts
(:func:`pydriver.design_problem.start_points`: the deck's values, every parameter at its lower
bound, every parameter at its upper bound); the best start that converged and holds the margin
wins, and every start is in the summary and in design_history.csv.  The optimum is the best of
those local optima, which the summary says, with the parameters that sit on a bound.
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, field

import numpy as np

from pydriver.analyses.flight import flight_analysis
from pydriver.analyses.flight_sensitivities import flight_sensitivities, worst_points_of
from pydriver.analyses.frequency_margin import FrequencyMargin, damped_name, discretisation_shift, error_bars, \
    modes_of
from pydriver.analyses.hover_modes import hover_model, require_periodic_reachable
from pydriver.analyses.modal import modal_analysis
from pydriver.analyses.registry import ANALYSES
from pydriver.analyses.sensitivities import N_FREQUENCIES, modal_sensitivities, plan, static_outputs, \
    static_sensitivities
from pydriver.analyses.spectrum_design import flight_deck, parameter_roles, spectrum_deck, spectrum_sensitivities
from pydriver.analyses.statics import drop_pulse, equilibrium
from pydriver.deckfile import Deck, deck_text, validate
from pydriver.design_measures import Evaluation
from pydriver.design_problem import OPTIMISER_KEYS, Problem, problem, start_points
from pydriver.errors import DeckError, RunError
from pydriver.model import Model
from pydriver.progress import report, stage
from pydriver.run_result import Result


def base_deck(deck: Deck, analysis: str) -> Deck:
    """The design deck as a plain deck of its base analysis: the optimiser's keys removed,
    ``&design parameters`` kept (a run of it also writes its sensitivities)."""
    raw = {g: dict(v) for g, v in deck.raw.items()}
    starts = {g: dict(v) for g, v in deck.starts.items()}
    for key in OPTIMISER_KEYS:
        raw["design"].pop(key, None)
        starts.get("design", {}).pop(key, None)
    raw["case"]["analysis"] = analysis
    starts.get("case", {}).pop("analysis", None)
    out = validate(raw, starts, deck.name)
    out.path = deck.path
    return out


def parameter_changes(deck: Deck, params: list, p) -> dict:
    """``{"group.key": value}`` setting every parameter (two elements of one array key compose)."""
    out = {}
    for par, value in zip(params, p):
        dotted = f"{par.group}.{par.key}"
        current = out.get(dotted, deck[dotted])
        if par.index is None and not isinstance(current, np.ndarray):
            out[dotted] = float(value)
            continue
        array = np.array(current, dtype=float)
        if par.index is None:
            array[:] = value
        else:
            array[par.index] = value
        out[dotted] = array
    return out


class Evaluator:
    """Whole runs of the base analysis with their sensitivities, one per distinct parameter vector
    (the objective, the constraints and the history ask for the same point: solved once).

    ``shifts`` ({mode: (shift, error)}) is added to each mode's damped frequency where the margin
    judges it (``&design frequency_levels``); ``top_hz``: every damped frequency below it is
    differentiated (the margin's modes), and so are the first ``modes``."""

    def __init__(self, deck: Deck, prob: Problem, top_hz: float | None = None):
        self.prob = prob
        self.spectrum = prob.base_analysis == "spectrum"
        # A spectrum takes no &design (its regimes would differentiate themselves): its plain deck.
        self.deck = spectrum_deck(deck) if self.spectrum else base_deck(deck, prob.base_analysis)
        self.top_hz = top_hz
        self.modes = N_FREQUENCIES
        self.shifts: dict = {}
        self.runs = 0
        self._cache: dict[bytes, tuple[int, Evaluation]] = {}
        #: The run at these parameters is kept (the deck's own design: the report's "before").
        self.keep_run_at: bytes | None = None
        self.start_run: Result | None = None
        #: which of a spectrum's runs take which parameter (checked before anything runs)
        self.roles = (parameter_roles(self.deck, prob.parameters, prob.lower, prob.upper, self.deck_at)
                      if self.spectrum else None)

    def _refused(self, p, err: DeckError) -> RunError:
        where = ", ".join(f"{par.name} = {v:.6g}" for par, v in zip(self.prob.parameters, p))
        return RunError(f"deck '{self.deck.name}': the design {where} is refused: {err}")

    def deck_at(self, p) -> Deck:
        """The base deck at the parameters ``p``."""
        try:
            return self.deck.with_values(parameter_changes(self.deck, self.prob.parameters, p))
        except DeckError as err:
            raise self._refused(p, err) from None

    def model_at(self, p) -> Model:
        deck = self.deck_at(p)
        try:
            return Model(deck)
        except DeckError as err:
            raise self._refused(p, err) from None

    def modal_model_at(self, p) -> Model:
        """The model whose modes the margin judges: the base modal deck, or a flight's hover state
        (a spectrum's: that of its base flight deck)."""
        if self.spectrum:
            try:
                return hover_model(Model(flight_deck(self.deck_at(p), self.prob.parameters)))
            except DeckError as err:
                raise self._refused(p, err) from None
        model = self.model_at(p)
        return hover_model(model) if ANALYSES[self.prob.base_analysis].periodic else model

    def __call__(self, p) -> Evaluation:
        p = np.asarray(p, float)
        key = p.tobytes()
        if key not in self._cache or self._cache[key][0] < self.modes:
            self._cache[key] = (self.modes, self._evaluate(p))
        ev = self._cache[key][1]
        if not self.shifts:
            return ev
        values = dict(ev.values)
        for mode, (shift, _) in self.shifts.items():
            if damped_name(mode) in values:
                values[damped_name(mode)] += shift
        return Evaluation(ev.p, values, ev.gradients, ev.details)

    def _modes(self, model, who: str, state=None, plans=None) -> dict:
        """The modal sensitivities about ``model``'s equilibrium ``state`` (q, lambda; solved here
        when None) with ``plans`` (made here when None): the margin's and a frequency objective's
        frequencies."""
        q, lam = state if state is not None else equilibrium(model)[:2]
        modal = modal_sensitivities(model, plans if plans is not None else plan(model), q, lam, self.modes,
                                    self.top_hz)
        if self.prob.objective.needs == "modal" and "f1_hz" not in modal["values"]:
            raise RunError(f"deck '{self.deck.name}': the first frequency {who}has no sensitivity at this design "
                           f"({'; '.join(modal['warnings'])}): it cannot be optimised")
        return modal

    def _evaluate(self, p) -> Evaluation:
        self.runs += 1
        # Each evaluation's own progress (a flight's revolutions) says which design run it is.
        with stage(f"design run {self.runs}"):
            return self._evaluate_design(p)

    def _evaluate_design(self, p) -> Evaluation:
        if self.spectrum:
            return self._evaluate_spectrum(p)
        if ANALYSES[self.prob.base_analysis].periodic:
            return self._evaluate_flight(p)
        model = drop_pulse(self.model_at(p))      # this design's own model
        plans = plan(model)
        names = [pl.parameter.name for pl in plans]
        values, gradients = {}, {}
        sens = []
        q, lam, _ = equilibrium(model)
        if self.prob.objective.needs == "static":
            y, outputs, _ = static_outputs(model, q)
            values.update(zip(outputs, (float(v) for v in y)))
            sens.append(static_sensitivities(model, plans, q, lam))
        if ANALYSES[self.prob.base_analysis].modes == "summary":
            modal = self._modes(model, "", (q, lam), plans)
            values.update(modal["values"])
            sens.append(modal)
        for s in sens:
            for out, row in s["summary"]["d_output_d_parameter"].items():
                gradients[out] = np.array([row[n] for n in names])
        return Evaluation(p, values, gradients)

    def _evaluate_flight(self, p) -> Evaluation:
        """A flight run to its periodic revolution with its flight sensitivities; with a frequency
        margin, the frequencies of its hover state with their modal sensitivities."""
        model = self.model_at(p)
        plans = plan(model)                      # before the run: bad parameters refused first
        # A march that cannot end within max_revolutions is refused before it runs (issue 35).
        hover = hover_model(model)
        hover_run = modal_analysis(hover)
        require_periodic_reachable(model, hover_run)
        run = flight_analysis(model)
        if p.tobytes() == self.keep_run_at:
            self.start_run = run
        orbit = run.extra["orbit"]
        # The run's own fatigue analysis found each joint's worst point around the jacket: the
        # outputs read it instead of repeating the rainflow counts at every point.
        sens = flight_sensitivities(model, plans, orbit["period_s"], orbit, run.timeseries,
                                    worst_points_of(model, run.extra.get("tables", {}).get("fatigue.csv")))
        names = [pl.parameter.name for pl in plans]
        values = dict(sens["values"])
        gradients = {out: np.array([row[n] for n in names])
                     for out, row in sens["summary"]["d_output_d_parameter"].items()}
        if self.prob.frequency_margin_percent is not None:
            modal = self._modes(hover, "of the hover state ", (hover_run.extra["q"], hover_run.extra["lambda"]))
            values.update(modal["values"])
            for out, row in modal["summary"]["d_output_d_parameter"].items():
                gradients[out] = np.array([row[n] for n in names])
        return Evaluation(p, values, gradients)

    def _evaluate_spectrum(self, p) -> Evaluation:
        """The usage spectrum at the deck's n with its damage sensitivities at its worst points;
        with a frequency margin, the frequencies of its base flight deck's hover state with their
        modal sensitivities."""
        deck = self.deck_at(p).with_values({"refinement.levels": 1})
        try:
            values, gradients, details = spectrum_sensitivities(deck, self.prob.parameters, self.roles)
        except DeckError as err:
            raise self._refused(p, err) from None
        if self.prob.frequency_margin_percent is not None:
            hover = self.modal_model_at(p)
            hover_run = modal_analysis(hover)
            modal = self._modes(hover, "of the hover state ", (hover_run.extra["q"], hover_run.extra["lambda"]))
            values.update(modal["values"])
            names = [par.name for par in self.prob.parameters]
            for out, row in modal["summary"]["d_output_d_parameter"].items():
                gradients[out] = np.array([row[n] for n in names])
        return Evaluation(p, values, gradients, details)


def design_run(model, run_dir=None) -> Result:
    """The registry's run of ``analysis = 'design'`` (pydriver.analyses.registry): the optimum of
    :func:`design_analysis` at the deck's n (``run_dir``: unused; its files are the result's)."""
    return design_analysis(model)


@dataclass
class StartRun:
    """One start's local optimisation (one pass, or two with ``&design frequency_levels`` > 1)."""

    label: str
    p_start: np.ndarray
    ev_start: Evaluation | None = None          #: at the start (the first pass's shifts)
    ev_opt: Evaluation | None = None            #: at its optimum (the last pass's shifts)
    gaps: dict = field(default_factory=dict)    #: {mode: (low, high)} the margin keeps
    shifts: list = field(default_factory=list)  #: each pass's {mode: (shift, error)}
    success: bool = False                       #: the optimiser's own verdict (the last pass)
    satisfied: bool = True                      #: the margin holds at its optimum
    message: str = ""
    iterations: int = 0
    runs: int = 0
    error: str | None = None                    #: a start that could not be run

    @property
    def converged(self) -> bool:
        return self.error is None and self.success and self.satisfied


def design_analysis(model) -> Result:
    """Minimise the deck's objective over its parameters within their bounds (and the frequency
    margin) from each of its starts; the result is that of the base analysis at the best local
    optimum, with summary['design'], design_history.csv and optimum.nml."""
    t0 = time.perf_counter()
    prob = problem(model.deck)
    evaluate = Evaluator(model.deck, prob)
    points = start_points(prob)
    evaluate.keep_run_at = np.asarray(points["deck"], float).tobytes()
    margin = None
    if prob.frequency_margin_percent is not None:
        margin = FrequencyMargin(evaluate.model_at(points["deck"]), prob.frequency_margin_percent)
        evaluate.top_hz = margin.top_hz
    history: list[dict] = []
    starts = []
    for label, p0 in points.items():
        run = StartRun(label, p0)
        runs_before = evaluate.runs
        try:
            _optimise_from(run, prob, evaluate, margin, model, history)
        except RunError as err:
            run.error = str(err)
        run.runs = evaluate.runs - runs_before
        starts.append(run)
    ran = [r for r in starts if r.error is None]
    if not ran:
        raise RunError(starts[0].error)
    best = _best(ran, prob)

    from pydriver.analyses import run_single
    from pydriver.analyses.resonance import attach_margins
    p_opt = best.ev_opt.p
    optimum_model = evaluate.model_at(p_opt)
    optimum = run_single(optimum_model)
    if margin is not None and best.shifts:
        attach_margins(optimum_model, optimum, shifts=best.shifts[-1])
    else:
        attach_margins(optimum_model, optimum)
    block = _summary_block(prob, starts, best, margin, evaluate.runs)
    notes = list(optimum.summary.get("warnings", []))
    notes += _notes(prob, starts, best, block)
    summary = dict(optimum.summary)
    summary.update(analysis="design", base_analysis=prob.base_analysis, design=block,
                   wall_time_s=time.perf_counter() - t0)
    summary.pop("warnings", None)
    if notes:
        summary["warnings"] = notes
    header = (f"The optimum of design deck '{model.name}' (rotorcable, analysis = 'design'): objective "
              f"{prob.objective.name} = {block['objective']['optimum']:.10g} {prob.objective.unit}, converged: "
              f"{str(block['converged']).lower()}; the best of {len(starts)} start(s) "
              f"({', '.join(r.label for r in starts)}): '{best.label}'.\n"
              f"A plain {prob.base_analysis} deck: rotorcable run optimum.nml")
    # The optimum's own run (its shapes for the plots and the report's animation), with the tables
    # a design writes: its history and the optimum's resonance margins (the design's margin).
    extra = dict(optimum.extra)
    # A spectrum's optimum keeps its damage by regime and its refined life.
    kept = ("resonance.csv",) + (("spectrum.csv", "refinement.csv") if evaluate.spectrum else ())
    extra["tables"] = {k: v for k, v in extra.get("tables", {}).items() if k in kept}
    extra["units"] = {k: v for k, v in extra.get("units", {}).items() if k in kept}
    columns, units = _history_columns(history, prob)
    extra["tables"]["design_history.csv"] = columns
    extra["units"]["design_history.csv"] = units
    extra["texts"] = {"optimum.nml": deck_text(optimum_model.deck, header)}
    if evaluate.start_run is not None:
        # The deck's own design as its first evaluation ran it: the report's animation shows
        # before and after together (issue 37).
        extra["design_start"] = Result(summary=evaluate.start_run.summary, timeseries=evaluate.start_run.timeseries,
                                       extra={"tables": {}})
    return Result(summary=summary, table=optimum.table, timeseries=optimum.timeseries, extra=extra)


def _optimise_from(run: StartRun, prob: Problem, evaluate: Evaluator, margin, model, history: list) -> None:
    """One start: the margin's modes and gaps at the start, then the optimiser; with
    ``frequency_levels`` > 1 each pass judges the margin with the discretisation shift taken at
    the pass's start (the second pass starts at the first's optimum, with the shift there)."""
    p = run.p_start
    passes = 2 if margin is not None and prob.frequency_levels > 1 else 1
    for k in range(passes):
        if margin is not None and prob.frequency_levels > 1:
            evaluate.shifts = {}
            modes = list(run.gaps) if run.gaps else modes_of(evaluate(p))
            evaluate.shifts = discretisation_shift(evaluate.modal_model_at(p), prob.frequency_levels, modes,
                                                   float(model.deck["refinement.expected_order"]))
            run.shifts.append(dict(evaluate.shifts))
        ev = evaluate(p)
        if k == 0:
            run.ev_start = ev
            if margin is not None:
                run.gaps = margin.gaps_at(ev)
                evaluate.modes = max([evaluate.modes, *run.gaps])
        res, p = _minimise(prob, evaluate, p, margin, run, history, k + 1)
        run.iterations += int(getattr(res, "nit", 0))
        run.success, run.message = bool(res.success), str(res.message)
    run.ev_opt = evaluate(p)
    if margin is not None:
        run.satisfied = margin.holds(run.ev_opt, run.gaps, error_bars(evaluate.shifts))
    evaluate.shifts = {}


def _minimise(prob: Problem, evaluate: Evaluator, p0, margin, run: StartRun, history: list, pass_no: int):
    """One scipy.optimize.minimize from ``p0``; returns its result and the parameters it ends at."""
    from scipy.optimize import BFGS, Bounds, NonlinearConstraint, minimize

    lower, upper = prob.lower, prob.upper
    span = upper - lower
    n = len(prob.parameters)

    def p_of(z):
        """The parameters of a scaled point; a bound is its deck value exactly (-0.181 + 0.04 is
        not -0.141 in floating point)."""
        x = z[:n]
        return np.where(x <= 0.0, lower, np.where(x >= 1.0, upper, lower + np.clip(x, 0.0, 1.0) * span))

    ev0 = evaluate(p0)
    objective0 = prob.objective.evaluate(ev0)[0]
    scale = abs(objective0) if objective0 != 0.0 else 1.0
    epigraph = len(prob.objective.terms(ev0)) > 1
    width = n + (1 if epigraph else 0)

    def objective(z):
        if epigraph:
            grad = np.zeros(width)
            grad[n] = 1.0
            return float(z[n]), grad
        value, grad = prob.objective.evaluate(evaluate(p_of(z)))
        return value / scale, grad * span / scale

    def constraint_rows(z):
        """g(z) >= 0 and its Jacobian: the epigraph's t - term_i, then each mode's frequency gap."""
        ev = evaluate(p_of(z))
        values, rows = [], []
        if epigraph:
            for v, g in prob.objective.terms(ev):
                values.append(z[n] - v / scale)
                rows.append(np.concatenate([-g * span / scale, [1.0]]))
        if margin is not None:
            v, r = margin.rows(ev, run.gaps, span, width, prob.tolerance, error_bars(evaluate.shifts))
            values += v
            rows += r
        return np.array(values), np.array(rows).reshape(len(values), width)

    def record(z):
        ev = evaluate(p_of(z))
        last = history[-1] if history else None
        if last is not None and last["start"] == run.label and last["pass"] == pass_no and \
                all(last[p.name] == v for p, v in zip(prob.parameters, ev.p)):
            return                       # the same design again (the final callback): not a new row
        iteration = sum(1 for row in history if row["start"] == run.label)
        row = {"start": run.label, "pass": pass_no, "iteration": iteration,
               **dict(zip((p.name for p in prob.parameters), ev.p)), "objective": prob.objective.evaluate(ev)[0]}
        if margin is not None:
            state = margin.state(ev, run.gaps)
            row["f1_hz"] = state.get("f1_undamped_hz")
            row.update({damped_name(int(m)): f for m, f in state["damped_hz"].items()})
            row["frequency_margin_percent"] = state.get("margin_percent")
            row["margin_mode"] = state.get("mode")
        history.append(row)
        margin_text = ""
        if row.get("frequency_margin_percent") is not None:
            margin_text = (f", frequency margin {row['frequency_margin_percent']:.2f} % (mode {row['margin_mode']}; "
                           f"required {prob.frequency_margin_percent:g} %)")
        report(f"design: start '{run.label}', iteration {row['iteration']}, {prob.objective.name} = "
               f"{row['objective']:.6g} {prob.objective.unit}{margin_text}; {evaluate.runs} runs so far")

    z0 = (p0 - lower) / span
    if epigraph:
        z0 = np.append(z0, objective0 / scale)
    record(z0)
    bounds = Bounds(np.r_[np.zeros(n), np.full(width - n, -np.inf)], np.r_[np.ones(n), np.full(width - n, np.inf)])
    n_cons = constraint_rows(z0)[0].size

    def callback(intermediate_result):
        record(intermediate_result.x)

    if prob.method == "slsqp":
        cons = [{"type": "ineq", "fun": lambda z: constraint_rows(z)[0], "jac": lambda z: constraint_rows(z)[1]}]
        res = minimize(objective, z0, jac=True, method="SLSQP", bounds=bounds, constraints=cons if n_cons else (),
                       callback=callback, options={"maxiter": prob.max_iterations, "ftol": prob.tolerance})
    else:
        cons = [NonlinearConstraint(lambda z: constraint_rows(z)[0], 0.0, np.inf,
                                    jac=lambda z: constraint_rows(z)[1], hess=BFGS())]
        with warnings.catch_warnings():
            # BFGS skips its update when a step leaves the gradient unchanged (at the optimum): not a fault.
            warnings.filterwarnings("ignore", message="delta_grad == 0.0", category=UserWarning)
            res = minimize(objective, z0, jac=True, hess=BFGS(), method="trust-constr", bounds=bounds,
                           constraints=cons if n_cons else (), callback=callback,
                           options={"maxiter": prob.max_iterations, "gtol": prob.tolerance,
                                    "xtol": prob.tolerance})
    record(res.x)
    return res, p_of(res.x)


def _best(ran: list, prob: Problem) -> StartRun:
    """The best converged start that holds the margin; else the best that holds it; else the
    first (the deck's)."""
    def value(r):
        return prob.objective.evaluate(r.ev_opt)[0]
    for pool in ([r for r in ran if r.converged], [r for r in ran if r.satisfied]):
        if pool:
            return min(pool, key=value)
    return ran[0]


def _history_columns(history: list, prob: Problem) -> tuple[dict, dict]:
    """design_history.csv's columns (every start's rows; a mode one start does not constrain is
    blank in its rows) and their units."""
    names = []
    for row in history:
        names += [k for k in row if k not in names]
    modes = sorted((k for k in names if k.startswith("fd")), key=lambda k: int(k[2:-3]))
    order = [k for k in names if not k.startswith("fd") and k not in ("frequency_margin_percent", "margin_mode")]
    order += modes + [k for k in ("frequency_margin_percent", "margin_mode") if k in names]
    columns = {k: [row.get(k) for row in history] for k in order}
    units = {"start": "-", "pass": "-", "iteration": "-", "objective": prob.objective.unit, "f1_hz": "Hz",
             "frequency_margin_percent": "%", "margin_mode": "-", **{k: "Hz" for k in modes}}
    units.update({p.name: p.unit for p in prob.parameters})
    return columns, units


def _parameters(prob: Problem, p) -> dict:
    return {par.name: float(v) for par, v in zip(prob.parameters, p)}


def _at_bound(prob: Problem, i: int, value: float) -> str | None:
    # Within 1e-9 of the range of a bound is on it (SLSQP stops at round-off from an active bound).
    near = 1.0e-9 * (prob.upper[i] - prob.lower[i])
    return ("lower" if value <= prob.lower[i] + near else "upper" if value >= prob.upper[i] - near else None)


def _life(damage: float) -> float | None:
    """The fatigue life [h] of a damage per flight hour (None: no damage, an infinite life)."""
    return 1.0 / damage if damage > 0.0 else None


def _start_block(prob: Problem, r: StartRun, margin) -> dict:
    """One start in summary['design']['starts']."""
    out = {"label": r.label, "start": _parameters(prob, r.p_start)}
    if r.error is not None:
        return {**out, "converged": False, "error": r.error, "runs": r.runs}
    out.update(optimum=_parameters(prob, r.ev_opt.p),
               objective={"start": float(prob.objective.evaluate(r.ev_start)[0]),
                          "optimum": float(prob.objective.evaluate(r.ev_opt)[0])},
               converged=r.converged, optimiser_converged=r.success, message=r.message, iterations=r.iterations,
               runs=r.runs,
               at_bound={par.name: b for i, par in enumerate(prob.parameters)
                         if (b := _at_bound(prob, i, r.ev_opt.p[i])) is not None})
    if margin is not None:
        out["frequency_margin"] = {"satisfied": r.satisfied, "start": margin.state(r.ev_start, r.gaps),
                                   "optimum": margin.state(r.ev_opt, r.gaps)}
    return out


def _summary_block(prob: Problem, starts: list, best: StartRun, margin, runs: int) -> dict:
    """summary['design']."""
    deck = starts[0]
    ev0, ev_opt = deck.ev_start, best.ev_opt
    if ev0 is None:                      # the deck's own start could not be run: the best one's start
        ev0 = best.ev_start
    params = {}
    for i, par in enumerate(prob.parameters):
        params[par.name] = {"unit": par.unit, "start": float(ev0.p[i]), "optimum": float(ev_opt.p[i]),
                            "lower": float(prob.lower[i]), "upper": float(prob.upper[i]),
                            "at_bound": _at_bound(prob, i, ev_opt.p[i])}
    objective = {"name": prob.objective.name, "unit": prob.objective.unit, "doc": prob.objective.doc,
                 "start": float(prob.objective.evaluate(ev0)[0]),
                 "optimum": float(prob.objective.evaluate(ev_opt)[0])}
    local = (f"the best of {len(starts)} local optima ({', '.join(r.label for r in starts)}; &design starts): "
             if len(starts) > 1 else "a local optimum from the deck's values alone (&design starts = 1): ")
    local += ("a gradient method finds a local optimum, and other starts may find a better one"
              if len(starts) == 1 else "other starts may still find a better one")
    block = {"objective": objective, "parameters": params,
             "at_bound": [name for name, p in params.items() if p["at_bound"]],
             "best_start": best.label, "optimum_is": local,
             "starts": [_start_block(prob, r, margin) for r in starts],
             "method": prob.method, "tolerance": prob.tolerance, "max_iterations": prob.max_iterations,
             "iterations": int(best.iterations), "runs": int(runs), "converged": bool(best.converged),
             "message": best.message,
             "gradients": "exact design sensitivities of the base analysis (implicit function theorem; Fox-Kapoor "
                          "for undamped and the state matrix's left and right eigenvectors for damped frequencies): "
                          "docs/model.md, \"Design sensitivities\""}
    if prob.objective.unit == "1/h":
        # A designer reads a life: the shortest fatigue life is 1 / the largest damage per flight hour.
        block["life_hours"] = {"start": _life(objective["start"]), "optimum": _life(objective["optimum"]),
                               "quantity": ("life over the usage spectrum" if prob.objective.needs == "spectrum"
                                            else "shortest fatigue life")}
    if ev0.details or ev_opt.details:
        # A spectrum's worst point and where its damage comes from, before and after.
        block["spectrum"] = {"start": ev0.details, "optimum": ev_opt.details}
    if margin is not None:
        fm = margin.summary()
        fm.update(constrained_modes=sorted(best.gaps),
                  gaps_hz={str(m): [lo, hi if np.isfinite(hi) else None] for m, (lo, hi) in sorted(best.gaps.items())},
                  start=margin.state(ev0, deck.gaps or best.gaps), optimum=margin.state(ev_opt, best.gaps),
                  satisfied=bool(best.satisfied), frequency_levels=prob.frequency_levels)
        fm["not_excited"] = {str(m): ev_opt.value(damped_name(m)) for m in modes_of(ev_opt)
                             if m not in best.gaps and ev_opt.value(damped_name(m)) > 0.0}
        if best.shifts:
            fm["discretisation_shift_hz"] = {str(m): v[0] for m, v in sorted(best.shifts[-1].items())}
            fm["discretisation_shift_error_hz"] = {str(m): v[1] for m, v in sorted(best.shifts[-1].items())}
        block["frequency_margin"] = fm
    return block


def _notes(prob: Problem, starts: list, best: StartRun, block: dict) -> list[str]:
    """The design's warnings: a start that failed, a margin not held, an optimiser that did not
    converge, an optimum that is one start's."""
    notes = []
    for r in starts:
        if r.error is not None:
            notes.append(f"design: start '{r.label}' could not be run: {r.error}")
    if len(starts) == 1:
        at = block["at_bound"]
        notes.append("design: the optimum is local (one start, &design starts = 1): other starts may find a better "
                     "one" + (f"; at a bound: {', '.join(at)}" if at else ""))
    if not best.satisfied:
        fm = block["frequency_margin"]["optimum"]
        notes.append(f"design: mode {fm['mode']} ({fm['damped_hz'][str(fm['mode'])]:.4g} Hz damped) at the last design "
                     f"is only {fm['margin_percent']:.2f} % from {fm['harmonic']}/rev, less than the required "
                     f"{prob.frequency_margin_percent:g} % (&design frequency_margin_percent)")
    if not best.success:
        notes.append(f"design: the optimiser ({prob.method}) did not converge from start '{best.label}' in "
                     f"{best.iterations} iterations ({best.message}): optimum.nml holds its last design, which is not "
                     "shown to be an optimum (&design max_iterations, tolerance)")
    elif not best.converged:
        notes.append("design: no start converged to a design that holds the frequency margin: optimum.nml holds "
                     f"start '{best.label}''s last design")
    return notes
