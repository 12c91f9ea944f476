"""Design optimisation (``&case analysis = 'design'``; issue 24, item 3; docs/model.md, "Design
optimisation").

Each evaluation is a whole run of the deck's base analysis at the trial parameters (the static
equilibrium, solved from the deck's start shape; with a first frequency about it when the
objective or the frequency margin needs one) and its exact design sensitivities
(:mod:`pydriver.analyses.sensitivities`): the gradients of the objective and the constraints
come from the implicit function theorem and Fox-Kapoor, not from differences of whole runs.
scipy.optimize.minimize (SLSQP, Kraft 1988, or trust-constr) takes them with ``jac=True`` and
constraint Jacobians, on a scaled problem: each parameter mapped to [0, 1] between its bounds,
the objective divided by its start value, the frequency constraints by the rotor frequency.

A flight objective (the largest damage per flight hour, the largest strain amplitude) evaluates
a whole flight run to its periodic revolution with its flight sensitivities
(:mod:`pydriver.analyses.flight_sensitivities`: forward sensitivities through the DAE, the
periodic start by the monodromy, damage with the cycle set held fixed); its frequency margin is
that of the hover state at the flight's rotor speed (:mod:`pydriver.analyses.hover_modes`), whose
first frequency has the modal sensitivities.

A largest-of-several objective (the largest support force, the largest joint moment) is
minimised in the epigraph form: minimise t subject to t >= term_i.  The frequency margin keeps
the first frequency in the gap between the forbidden bands k Omega (1 +- margin) where it starts
(:func:`pydriver.design_measures.allowed_gap`).
"""

from __future__ import annotations

import time
import warnings

import numpy as np

from pydriver.analyses.flight import flight_analysis
from pydriver.analyses.flight_sensitivities import flight_sensitivities, worst_points_of
from pydriver.analyses.hover_modes import hover_model, hover_modes, require_periodic_reachable
from pydriver.analyses.registry import ANALYSES
from pydriver.analyses.resonance import harmonic_margin, operating_speeds
from pydriver.analyses.sensitivities import modal_sensitivities, plan, static_outputs, static_sensitivities
from pydriver.analyses.statics import drop_pulse, equilibrium
from pydriver.deckfile import Deck, deck_text, validate
from pydriver.design_measures import Evaluation, allowed_gap, forbidden_bands
from pydriver.design_problem import OPTIMISER_KEYS, Problem, problem
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
    (the objective, the constraints and the history ask for the same point: solved once)."""

    def __init__(self, deck: Deck, prob: Problem, frequency_shift_hz: float = 0.0):
        self.prob = prob
        self.frequency_shift_hz = frequency_shift_hz
        self.deck = base_deck(deck, prob.base_analysis)
        self.runs = 0
        self._cache: dict[bytes, Evaluation] = {}

    def model_at(self, p) -> Model:
        try:
            return Model(self.deck.with_values(parameter_changes(self.deck, self.prob.parameters, p)))
        except DeckError as err:
            where = ", ".join(f"{par.name} = {v:.6g}" for par, v in zip(self.prob.parameters, p))
            raise RunError(f"deck '{self.deck.name}': the design {where} is refused: {err}") from None

    def __call__(self, p) -> Evaluation:
        p = np.asarray(p, float)
        key = p.tobytes()
        if key not in self._cache:
            ev = self._evaluate(p)
            if "f1_hz" in ev.values:
                ev.values["f1_hz"] += self.frequency_shift_hz
            self._cache[key] = ev
        return self._cache[key]

    def _evaluate(self, p) -> Evaluation:
        self.runs += 1
        # Each evaluation's own progress (a flight's revolutions) says which design run it is.
        with stage(f"design run {self.runs}"):
            return self._evaluate_design(p)

    def _evaluate_design(self, p) -> Evaluation:
        if ANALYSES[self.prob.base_analysis].periodic:
            return self._evaluate_flight(p)
        model = drop_pulse(self.model_at(p))      # this design's own model
        q, lam, _ = equilibrium(model)
        plans = plan(model)
        names = [pl.parameter.name for pl in plans]
        values, gradients = {}, {}
        sens = []
        if self.prob.objective.needs == "static":
            y, outputs, _ = static_outputs(model, q)
            values.update(zip(outputs, (float(v) for v in y)))
            sens.append(static_sensitivities(model, plans, q, lam))
        if ANALYSES[self.prob.base_analysis].modes == "summary":
            modal = modal_sensitivities(model, plans, q, lam)
            if "f1_hz" not in modal["values"]:
                raise RunError(f"deck '{self.deck.name}': the first frequency has no sensitivity at this design "
                               f"({'; '.join(modal['warnings'])}): it cannot be optimised or constrained")
            values.update(modal["values"])
            sens.append(modal)
        for s in sens:
            for out, row in s["summary"]["d_output_d_parameter"].items():
                gradients[out] = np.array([row[n] for n in names])
        return Evaluation(p, values, gradients)

    def _evaluate_flight(self, p) -> Evaluation:
        """A flight run to its periodic revolution with its flight sensitivities; with a frequency
        margin, the first frequency of its hover state and that frequency's modal sensitivities."""
        model = self.model_at(p)
        plans = plan(model)                      # before the run: bad parameters refused first
        # A march that cannot end within max_revolutions is refused before it runs (issue 35).
        require_periodic_reachable(model, hover_modes(model))
        run = flight_analysis(model)
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
            hover = hover_model(model)
            q, lam, _ = equilibrium(hover)
            modal = modal_sensitivities(hover, plan(hover), q, lam)
            if "f1_hz" not in modal["values"]:
                raise RunError(f"deck '{self.deck.name}': the first frequency of the hover state has no sensitivity "
                               f"at this design ({'; '.join(modal['warnings'])}): it cannot be constrained")
            values["f1_hz"] = modal["values"]["f1_hz"]
            row = modal["summary"]["d_output_d_parameter"]["f1_hz"]
            gradients["f1_hz"] = np.array([row[n] for n in names])
        return Evaluation(p, values, gradients)


def design_run(model, run_dir=None) -> Result:
    """The registry's run of ``analysis = 'design'`` (pydriver.analyses.registry): the optimum of
    :func:`design_analysis` at the deck's n (``run_dir``: unused; its files are the result's)."""
    return design_analysis(model)


def design_analysis(model, frequency_shift_hz: float = 0.0) -> Result:
    """Minimise the deck's objective over its parameters within their bounds (and the frequency
    margin); the result is that of the base analysis at the optimum, with summary['design'],
    design_history.csv and optimum.nml.

    ``frequency_shift_hz`` is added to the first frequency wherever the margin judges it (the
    discretisation correction f1(converged) - f1(n) of :mod:`pydriver.design_study`, so that the
    converged cable, not the n-body model, keeps the margin); 0: the deck's n as it is."""
    from scipy.optimize import BFGS, Bounds, NonlinearConstraint, minimize

    t0 = time.perf_counter()
    prob = problem(model.deck)
    evaluate = Evaluator(model.deck, prob, frequency_shift_hz)
    lower, upper = prob.lower, prob.upper
    span = upper - lower
    n = len(prob.parameters)
    p0 = np.array([par.value for par in prob.parameters])
    start_model = evaluate.model_at(p0)
    speeds, harmonics, bands = [], 0, []
    if prob.frequency_margin_percent is not None:
        speeds = [r for r in operating_speeds(start_model) if r > 0.0]
        if not speeds:
            model.deck.fail("design", "frequency_margin_percent",
                            "needs an operating rotor speed: the deck's rotor does not turn; set &resonance "
                            "operating_rpm (or &loads rotor_rpm / &rotor rpm)")
        harmonics = int(model.deck["resonance.harmonics"])
        bands = forbidden_bands(speeds, harmonics, prob.frequency_margin_percent)

    def p_of(z):
        """The parameters of a scaled point; a bound is its deck value exactly (-0.181 + 0.04 is
        not -0.141 in floating point)."""
        x = z[:n]
        return np.where(x <= 0.0, lower, np.where(x >= 1.0, upper, lower + np.clip(x, 0.0, 1.0) * span))

    ev0 = evaluate(p0)
    objective0 = prob.objective.evaluate(ev0)[0]
    scale = abs(objective0) if objective0 != 0.0 else 1.0
    epigraph = len(prob.objective.terms(ev0)) > 1
    gap = allowed_gap(ev0.value("f1_hz"), bands) if bands else None
    f_scale = min(speeds) / 60.0 if speeds else 1.0
    width = n + (1 if epigraph else 0)

    def objective(z):
        if epigraph:
            grad = np.zeros(width)
            grad[n] = 1.0
            return float(z[n]), grad
        value, grad = prob.objective.evaluate(evaluate(p_of(z)))
        return value / scale, grad * span / scale

    def constraint_rows(z):
        """g(z) >= 0 and its Jacobian: the epigraph's t - term_i, then the frequency gap."""
        ev = evaluate(p_of(z))
        values, rows = [], []
        if epigraph:
            for v, g in prob.objective.terms(ev):
                values.append(z[n] - v / scale)
                rows.append(np.concatenate([-g * span / scale, [1.0]]))
        if gap is not None:
            f1, d_f1 = ev.value("f1_hz"), np.concatenate([ev.grad("f1_hz") * span, np.zeros(width - n)])
            if gap[0] > 0.0:
                values.append((f1 - gap[0]) / f_scale)
                rows.append(d_f1 / f_scale)
            if np.isfinite(gap[1]):
                values.append((gap[1] - f1) / f_scale)
                rows.append(-d_f1 / f_scale)
        return np.array(values), np.array(rows).reshape(len(values), width)

    def margin_percent(ev) -> float:
        return min(harmonic_margin(ev.value("f1_hz"), 0.0, r, harmonics)["margin_percent"] for r in speeds)

    history = []

    def record(z):
        ev = evaluate(p_of(z))
        if history and all(history[-1][p.name] == v for p, v in zip(prob.parameters, ev.p)):
            return                       # the same design again (the final callback): not a new row
        row = {"iteration": len(history), **dict(zip((p.name for p in prob.parameters), ev.p)),
               "objective": prob.objective.evaluate(ev)[0]}
        if speeds:
            row.update(f1_hz=ev.value("f1_hz"), frequency_margin_percent=margin_percent(ev))
        history.append(row)
        report(f"design: iteration {row['iteration']}, {prob.objective.name} = {row['objective']:.6g} "
               f"{prob.objective.unit}" + (f", frequency margin {row['frequency_margin_percent']:.2f} % (required "
                                           f"{prob.frequency_margin_percent:g} %)" if speeds else "")
               + f"; {evaluate.runs} runs so far")

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
    p_opt = p_of(res.x)
    ev_opt = evaluate(p_opt)
    record(res.x)

    from pydriver.analyses import run_single
    optimum_model = evaluate.model_at(p_opt)
    optimum = run_single(optimum_model)
    block = _summary_block(prob, res, ev0, ev_opt, evaluate.runs, int(getattr(res, "nit", len(history) - 1)))
    notes = list(optimum.summary.get("warnings", []))
    if speeds:
        block["frequency_margin"] = {
            "required_percent": prob.frequency_margin_percent, "operating_rpm": speeds, "harmonics": harmonics,
            "gap_hz": [gap[0], gap[1] if np.isfinite(gap[1]) else None],
            "start": {"f1_hz": ev0.value("f1_hz"), "margin_percent": margin_percent(ev0)},
            "optimum": {"f1_hz": ev_opt.value("f1_hz"), "margin_percent": margin_percent(ev_opt)},
            "discretisation_shift_hz": frequency_shift_hz}
        # The constraint as the optimiser holds it: the gap's edges to its feasibility tolerance
        # (SLSQP's acc, trust-constr's gtol) on the scaled frequency f / f_scale.
        slack = prob.tolerance * f_scale
        met = gap[0] - slack <= ev_opt.value("f1_hz") <= gap[1] + slack
        block["frequency_margin"]["satisfied"] = bool(met)
        if not met:
            block["converged"] = False
            notes.append(f"design: the first frequency {ev_opt.value('f1_hz'):.4g} Hz at the last design is "
                            f"only {margin_percent(ev_opt):.2f} % from a rotor harmonic, less than the required "
                            f"{prob.frequency_margin_percent:g} % (&design frequency_margin_percent)")
    if not res.success:
        notes.append(f"design: the optimiser ({prob.method}) did not converge in {block['iterations']} "
                        f"iterations ({block['message']}): optimum.nml holds its last design, which is not "
                        "shown to be an optimum (&design max_iterations, tolerance)")
    summary = dict(optimum.summary)
    summary.update(analysis="design", base_analysis=prob.base_analysis, design=block,
                   wall_time_s=time.perf_counter() - t0)
    summary.pop("warnings", None)
    if notes:
        summary["warnings"] = notes
    header = (f"The optimum of design deck '{model.name}' (rotorcable, analysis = 'design'): objective "
              f"{prob.objective.name} = {block['objective']['optimum']:.10g} {prob.objective.unit}, converged: "
              f"{str(block['converged']).lower()}.\nA plain {prob.base_analysis} deck: rotorcable run optimum.nml")
    units = {"iteration": "-", "objective": prob.objective.unit, "f1_hz": "Hz", "frequency_margin_percent": "%"}
    units.update({p.name: p.unit for p in prob.parameters})
    columns = {k: np.array([row[k] for row in history]) for k in history[0]}
    extra = {k: v for k, v in optimum.extra.items() if k in ("q", "lambda", "modes", "mode_shapes_q")}
    extra.update(tables={"design_history.csv": columns}, units={"design_history.csv": units},
                 texts={"optimum.nml": deck_text(optimum_model.deck, header)})
    if optimum.timeseries is not None:
        extra["orbit"] = optimum.extra.get("orbit")
    return Result(summary=summary, table=optimum.table, timeseries=optimum.timeseries, extra=extra)


def _summary_block(prob: Problem, res, ev0: Evaluation, ev_opt: Evaluation, runs: int, iterations: int) -> dict:
    """summary['design'] without the frequency margin."""
    params = {}
    for i, par in enumerate(prob.parameters):
        # Within 1e-9 of the range of a bound is on it (SLSQP stops at round-off from an active bound).
        near = 1.0e-9 * (prob.upper[i] - prob.lower[i])
        at = ("lower" if ev_opt.p[i] <= prob.lower[i] + near else
              "upper" if ev_opt.p[i] >= prob.upper[i] - near else None)
        params[par.name] = {"unit": par.unit, "start": float(ev0.p[i]), "optimum": float(ev_opt.p[i]),
                            "lower": float(prob.lower[i]), "upper": float(prob.upper[i]), "at_bound": at}
    return {"objective": {"name": prob.objective.name, "unit": prob.objective.unit, "doc": prob.objective.doc,
                          "start": float(prob.objective.evaluate(ev0)[0]),
                          "optimum": float(prob.objective.evaluate(ev_opt)[0])},
            "parameters": params, "method": prob.method, "tolerance": prob.tolerance,
            "max_iterations": prob.max_iterations, "iterations": int(iterations), "runs": int(runs),
            "converged": bool(res.success), "message": str(res.message),
            "gradients": "exact design sensitivities of the base analysis (implicit function theorem; "
                         "Fox-Kapoor for the frequency): docs/model.md, \"Design sensitivities\""}
