"""Where each deck key acts: one table of scopes, and the warning for a key a run ignores.

A deck may set a key that its analysis never reads: ``&solver floquet = .true.`` on a static
deck, ``periodic_method = 'shooting'`` on a dynamic one, ``settle_tol`` without
``static_method = 'settle'``.  Such a run must not pass over the key in silence (issue 35):
either the key acts, or the run says that it does not apply.  :data:`SCOPES` is the one table
of where keys act; :func:`ignored_keys` reads a deck against it, and :func:`warnings` turns what
it finds into the summary's warnings (``analyses.run`` adds them to every run), one line per
group and reason, e.g. ``&solver floquet, periodic_method apply to flight runs only: ignored in
this static run``.

Reading the table:

* a key with no :class:`Scope` acts in every analysis (the chain, the springs, gravity, ...);
* a scope names a group (every key of it) or a ``group.key``, the analyses it can act in, and
  optionally a condition on the deck (``when``) with its words (``condition``); a key acts when
  every scope naming it or its group holds;
* ``analysis = 'design'`` evaluates its base analysis (static, modal or flight:
  :attr:`pydriver.design_problem.Problem.base_analysis`) and ``analysis = 'spectrum'`` is made of
  flight runs (its registry row's ``evaluates``), so a key acts in such a composite run when it
  acts in that analysis, unless its scope says otherwise (``Scope.acts_in``: the optimiser's own
  keys act in design runs only, ``&spectrum`` in spectrum runs; ``Scope.ignored_in``: a spectrum
  reports no resonance margins);
* only keys the deck sets to a value other than their default are reported (a deck that spells
  out a default says nothing), and a group the deck opens without keys (``&drag /``, which
  switches drag on) is judged by its group's scope.

Keys whose misuse the deck rules already refuse (:mod:`pydriver.deck_rules`: clamp B's pose
without ``active``, a checkpoint interval outside dynamic runs, the optimiser's keys outside
design runs, ...) raise before this table is read; their scopes are here all the same, so that
the table alone says where every key acts.  ``tests/test_keys_apply.py`` holds the table to the
runs: every key and every analysis, a key either changes the result or is named by a warning
or an error.
"""

from __future__ import annotations

from dataclasses import dataclass
from types import SimpleNamespace
from typing import Callable

import numpy as np

from pydriver.analyses.registry import ANALYSES as REGISTERED
from pydriver.deckfile import Deck, default_value
from pydriver.schema import GROUPS, lookup

#: Every analysis of ``&case analysis`` (pydriver.analyses.registry).
ANALYSES = tuple(REGISTERED)
#: The analyses made of runs of another (an optimiser evaluates one of them again and again; a
#: usage spectrum runs a flight per regime): a key acts in them as in that base analysis.
COMPOSITE = tuple(a.name for a in REGISTERED.values() if a.optimises or a.evaluates is not None)
#: The analyses that are one run each.
RUNS = tuple(a for a in REGISTERED if a not in COMPOSITE)
#: Analyses with a time integration (a static or modal one only when it settles; a diagram over
#: speeds solves each equilibrium by Newton).
INTEGRATING = tuple(a for a in RUNS if not REGISTERED[a].sweeps_speed)


@dataclass(frozen=True)
class Scope:
    """Where some keys act.

    Attributes
    ----------
    keys : tuple of str
        ``'group'`` (every key of that group) or ``'group.key'``.
    analyses : tuple of str
        The analyses of :data:`RUNS` in which they can act.
    when : callable or None
        ``when(deck, analysis) -> bool``: they act only when it holds (None: always).
    condition : str
        ``when`` in words, completing "acts only ...": ``"with &solver static_method = 'settle'"``.
    acts_in : tuple of str
        Analyses of :data:`COMPOSITE` in whose runs the keys act themselves (``when`` is asked
        with that analysis): the optimiser's keys in a design run, ``&spectrum`` in a spectrum
        run.
    ignored_in : tuple of str
        Analyses of :data:`COMPOSITE` that ignore the keys although their base analysis reads
        them (a usage spectrum reports no resonance margins of its regimes).

    In any other analysis of :data:`COMPOSITE` the keys act as in its base analysis (whose runs
    it is made of).
    """

    keys: tuple
    analyses: tuple = RUNS
    when: Callable | None = None
    condition: str = ""
    acts_in: tuple = ()
    ignored_in: tuple = ()

    def names(self, group: str, key: str | None) -> bool:
        """Whether this scope covers ``group.key`` (``key`` None: the group itself)."""
        return group in self.keys or (key is not None and f"{group}.{key}" in self.keys)

    def reason(self, deck: Deck, analysis: str, base: str) -> str | None:
        """Why the keys do not act in an ``analysis`` run (None: they do); ``base`` is the base
        analysis of a composite run (design, spectrum), else ``analysis`` itself."""
        if analysis in COMPOSITE and (analysis in self.acts_in or analysis in self.ignored_in):
            acting = analysis in self.acts_in
        else:
            analysis = base
            acting = analysis in self.analyses
        if not acting:
            return f"to {_runs(self.analyses + self.acts_in)} only"
        if self.when is not None and not self.when(deck, analysis):
            return f"only {self.condition}"
        return None


def _runs(analyses: tuple) -> str:
    names = [{"campbell": "Campbell"}.get(a, a) for a in analyses]
    text = names[0] if len(names) == 1 else ", ".join(names[:-1]) + " and " + names[-1]
    return f"{text} runs"


# -- conditions (each on the deck and the analysis that runs) ----------------------------------

def _settles(deck: Deck, analysis: str) -> bool:
    """The equilibrium is found by damped dynamic settling (not the Campbell diagram's Newton)."""
    return deck["solver.static_method"] == "settle" and _equilibrium(deck, analysis) and \
        not REGISTERED[analysis].sweeps_speed


def _equilibrium(deck: Deck, analysis: str) -> bool:
    """An equilibrium is solved: every run but one from t = 0 that starts from its deck's shape."""
    return analysis in RUNS and (REGISTERED[analysis].time_axis != "t_end" or deck["case.start"] == "equilibrium")


def _newton(deck: Deck, analysis: str) -> bool:
    # The Campbell diagram solves every speed's equilibrium by Newton (analyses/campbell.py).
    return REGISTERED[analysis].sweeps_speed or (_equilibrium(deck, analysis)
                                                 and deck["solver.static_method"] == "newton")


def _integrates(deck: Deck, analysis: str) -> bool:
    return REGISTERED[analysis].integrates or _settles(deck, analysis)


def _coordinates(deck: Deck) -> int:
    """The model's number of coordinates, from the deck alone (for 'auto' linear solvers)."""
    from pydriver.assembly import bodies
    per_joint = {"zy": 2, "xy": 2, "xyz": 3}[deck["chain.joint"]]
    return per_joint * int(np.count_nonzero(~bodies(deck).locked))


def _iteration_matrix(deck: Deck, analysis: str) -> bool:
    """An integration whose linear solver forms the iteration matrix (block or dense), which is
    what &solver jacobian computes; the chain solver forms none."""
    if not _integrates(deck, analysis):
        return False
    from pydriver.model import AUTO_SENSITIVITY_CHAIN_MIN_COORDS, resolve_linear_solver
    choice, nq = deck["solver.linear_solver"], _coordinates(deck)
    solvers = {resolve_linear_solver(choice, nq)}
    if REGISTERED[analysis].periodic and deck["design.parameters"] is not None and choice == "auto":
        solvers.add("chain" if nq >= AUTO_SENSITIVITY_CHAIN_MIN_COORDS else "block")   # Model.sensitivity_solver_settings
    return bool(solvers & {"block", "dense"})


def _support_b(deck: Deck, analysis: str) -> bool:
    return bool(deck["clamp_b.active"] or deck["ball_b.active"])


def _rotor(deck: Deck):
    from pydriver.motions import rotor
    return rotor(deck)


def _turning(deck: Deck, analysis: str) -> bool:
    rot = _rotor(deck)
    return rot is not None and rot["omega_max"] > 0.0


def _stream_or_turning(deck: Deck, analysis: str) -> bool:
    """Drag does work on a cable at rest only in a stream or when the rotor carries it round
    (the drag is quadratic in the relative velocity: without either, it and its tangent vanish)."""
    if REGISTERED[analysis].integrates or REGISTERED[analysis].sweeps_speed:
        return True
    stream = np.any(np.asarray(deck["drag.stream_velocity"], float) != 0.0) or deck["drag.forward_speed"] != 0.0
    return bool(stream) or _turning(deck, analysis)


def _operating_speed(deck: Deck, analysis: str) -> bool:
    from pydriver.analyses.resonance import operating_speeds
    return bool(operating_speeds(SimpleNamespace(deck=deck, analysis=analysis)))


def _profile(*names: str) -> Callable:
    return lambda deck, analysis: "rotor" in deck.groups and deck["rotor.profile"] in names


def _rotor_rpm(deck: Deck, analysis: str) -> bool:
    profile = deck["rotor.profile"]
    if profile == "runup":
        # A static or modal analysis takes the speed at t = 0, rpm_start (flight and Campbell runs
        # refuse a run-up: deck_rules).
        return REGISTERED[analysis].time_axis == "t_end"
    return profile == "constant"


def _blade(*motions: str) -> Callable:
    return lambda deck, analysis: deck["blade.motion"] in motions


def _extra_lag(deck: Deck, analysis: str) -> bool:
    """The extra lead-lag oscillation A sin(w t + phi): in a dynamic run; otherwise the analysis
    takes the blade at t = 0, where it is A sin(phi) and moves at A w cos(phi) (the support's
    motion enters the reactions)."""
    if deck["blade.motion"] != "fourier":
        return False
    moving = np.sin(np.radians(deck["blade.lag_extra_phase_deg"])) != 0.0 or deck["blade.lag_extra_hz"] != 0.0
    return REGISTERED[analysis].time_axis == "t_end" or bool(moving)


def _extra_lag_amplitude(deck: Deck, analysis: str) -> bool:
    return deck["blade.motion"] == "fourier" and deck["blade.lag_extra_deg"] != 0.0


def _blade_azimuth(deck: Deck, analysis: str) -> bool:
    # The Fourier series are in the blade azimuth; a table motion is in time, where the azimuth
    # only labels the time series.
    return _rotor(deck) is not None and (deck["blade.motion"] == "fourier" or REGISTERED[analysis].integrates)


#: Where the keys act that do not act everywhere.  A new key acts everywhere unless it gets a
#: row here (tests/test_keys_apply.py finds a key that is silently ignored).
SCOPES: tuple[Scope, ...] = (
    # &case
    Scope(("case.start",), ("dynamic",)),
    # &shape: start rates
    Scope(("shape.gamma_rate_deg", "shape.beta_rate_deg"), ("dynamic",),
          lambda deck, a: deck["case.start"] == "shape", "with &case start = 'shape' (a run from the equilibrium "
                                                         "starts at rest)"),
    # dampers: they do not move an equilibrium, but act in its stability (the damped growth rate of
    # every static result, pydriver/analyses/stability.py), its modes, in time and while settling:
    # every run reads them (no row).
    # rest angles: of a spring (the thesis's zy joint; a Cardan chain rests straight, deck_rules)
    Scope(("springs.rest_gamma_deg",), when=lambda deck, a: bool(np.any(deck["springs.c_gamma"] != 0.0)),
          condition="with a spring on gamma (&springs c_gamma)"),
    Scope(("springs.rest_beta_deg",), when=lambda deck, a: bool(np.any(deck["springs.c_beta"] != 0.0)),
          condition="with a spring on beta (&springs c_beta)"),
    Scope(("cable.spring_measure",), when=lambda deck, a: deck["chain.joint"] == "xyz",
          condition="with &chain joint = 'xyz' (the bending joint 'xy' has no rotation vector to choose)"),
    Scope(("ball_b.position",), when=lambda deck, a: bool(deck["ball_b.active"]), condition="with &ball_b active = .true."),
    Scope(("clamp_b.position", "clamp_b.gamma_deg", "clamp_b.beta_deg"), when=lambda deck, a: not deck["clamp_b.from_start"],
          condition="with &clamp_b from_start = .false. (from_start takes clamp B's pose from the start shape)"),
    # &loads
    Scope(("loads.pulse_body", "loads.pulse_force", "loads.pulse_start", "loads.pulse_end"), ("dynamic", "flight")),
    Scope(("loads.pulse_force", "loads.pulse_start", "loads.pulse_end"),
          when=lambda deck, a: deck["loads.pulse_body"] > 0, condition="with &loads pulse_body > 0 (the pulsed body)"),
    Scope(("loads.rotor_offset",), when=lambda deck, a: _turning(deck, a) and not deck.has("rotor.centre"),
          condition="with a turning rotor and without &rotor centre"),
    # &rotor
    Scope(("rotor.centre", "rotor.frame"), when=_turning, condition="with a turning rotor"),
    Scope(("rotor.body_couples",), when=lambda deck, a: _turning(deck, a) and deck["rotor.frame"] == "hub",
          condition="with a turning rotor in the hub frame (&rotor frame = 'hub': the frame terms)"),
    Scope(("rotor.rpm",), when=_rotor_rpm,
          condition="with &rotor profile = 'constant', or as the end of a run-up in a dynamic run (a static or "
                    "modal analysis takes the speed at t = 0, rpm_start)"),
    Scope(("rotor.rpm_start",), ("static", "modal", "dynamic"), _profile("runup"),
          "with &rotor profile = 'runup'"),
    Scope(("rotor.runup_start", "rotor.runup_time"), ("dynamic",), _profile("runup"),
          "with &rotor profile = 'runup'"),
    Scope(("rotor.table_t",), ("dynamic",), _profile("table"), "with &rotor profile = 'table'"),
    Scope(("rotor.table_rpm",), ("static", "modal", "dynamic"), _profile("table"),
          "with &rotor profile = 'table'"),
    # &blade
    Scope(("blade.flap_deg", "blade.lag_deg", "blade.pitch_deg"), when=_blade("fourier"),
          condition="with &blade motion = 'fourier'"),
    Scope(("blade.table_flap_deg", "blade.table_lag_deg", "blade.table_pitch_deg"), when=_blade("table"),
          condition="with &blade motion = 'table'"),
    # The times set the angles' rates: at t = 0 the blade's rate, which the reactions of a static
    # or modal run include (as a Fourier motion's), and the motion of a dynamic run.
    Scope(("blade.table_t",), ("static", "modal", "dynamic"), _blade("table"), "with &blade motion = 'table'"),
    Scope(("blade.lag_extra_deg",), when=_extra_lag,
          condition="with &blade motion = 'fourier', in a dynamic run or, taken at t = 0, with a frequency "
                    "lag_extra_hz or a phase lag_extra_phase_deg whose sine is not 0"),
    Scope(("blade.lag_extra_hz", "blade.lag_extra_phase_deg"), when=_extra_lag_amplitude,
          condition="with &blade motion = 'fourier' and an amplitude lag_extra_deg"),
    # At t = 0 the frequency sets only the blade's rate, which the reactions of a static or modal
    # run include and a Campbell diagram, which reports no reactions, does not.
    Scope(("blade.lag_extra_hz",), ("static", "modal", "dynamic", "flight")),
    Scope(("blade.azimuth0_deg",), when=_blade_azimuth,
          condition="with a rotor, and a Fourier motion (a table motion: in dynamic and flight runs)"),
    # A Campbell diagram is of the hover state: the blade at its mean angles, no extra lead-lag
    # (pydriver.analyses.hover_modes.hover_changes), so neither the phase of the motion nor the
    # extra oscillation enters it.
    Scope(("blade.lag_extra_deg", "blade.lag_extra_phase_deg", "blade.azimuth0_deg"),
          ("static", "modal", "dynamic", "flight")),
    # result groups
    Scope(("campbell",), ("campbell",)),
    # resonance margins (modal, Campbell, flight); a design run's frequency margin takes the
    # harmonics and operating speed, not the margins' own margin_percent
    Scope(("resonance",), ("modal", "campbell", "flight"),
          lambda deck, a: a == "design" or REGISTERED[a].sweeps_speed or _operating_speed(deck, a),
          "in modal, Campbell and flight runs with an operating speed (a turning rotor at a constant speed, "
          "&resonance operating_rpm or, in a Campbell run, &campbell operating_rpm)", acts_in=("design",),
          ignored_in=("spectrum",)),
    # the margins themselves need an operating speed; which harmonics excite also picks a Campbell
    # diagram's crossings, which it reports over its operating range (0 ... rpm_max by default)
    Scope(("resonance.margin_percent", "resonance.harmonics", "resonance.operating_rpm"),
          ("modal", "campbell", "flight"), lambda deck, a: a == "design" or _operating_speed(deck, a),
          "in modal, Campbell and flight runs with an operating speed (a turning rotor at a constant speed, "
          "&resonance operating_rpm or, in a Campbell run, &campbell operating_rpm)", acts_in=("design",),
          ignored_in=("spectrum",)),
    Scope(("resonance.margin_percent",), ("modal", "campbell", "flight"), ignored_in=("design", "spectrum")),
    Scope(("resonance.harmonics", "resonance.operating_rpm", "resonance.excitation", "resonance.blades"),
          ("modal", "campbell", "flight"),
          lambda deck, a: a != "design" or deck["design.frequency_margin_percent"] is not None,
          "with &design frequency_margin_percent in a design run", acts_in=("design",), ignored_in=("spectrum",)),
    Scope(("resonance.blades",), when=lambda deck, a: deck["resonance.excitation"] == "blade_passage",
          condition="with &resonance excitation = 'blade_passage'", acts_in=("design",)),
    Scope(("drag",), when=_stream_or_turning,
          condition="in a static or modal run with a stream (stream_velocity, forward_speed) or a turning "
                    "rotor (drag is quadratic in the velocity through the air)"),
    Scope(("fatigue",), ("dynamic", "flight")),
    Scope(("fatigue.ultimate",), when=lambda deck, a: deck["fatigue.mean_stress"] in ("goodman", "gerber"),
          condition="with &fatigue mean_stress = 'goodman' or 'gerber'"),
    Scope(("fatigue.walker_gamma",), when=lambda deck, a: deck["fatigue.mean_stress"] == "walker",
          condition="with &fatigue mean_stress = 'walker'"),
    Scope(("limits.jacket_strain",), ("static", "modal", "dynamic", "flight")),
    Scope(("limits.fatigue_life_hours",), ("dynamic", "flight")),
    Scope(("design.parameters",), ("static", "modal", "dynamic", "flight"), acts_in=("design",),
          ignored_in=("spectrum",)),
    Scope(("design.objective", "design.lower", "design.upper", "design.frequency_margin_percent", "design.method",
           "design.max_iterations", "design.tolerance", "design.starts", "design.frequency_levels"), (),
          acts_in=("design",)),
    Scope(("design.frequency_levels",), (), lambda deck, a: deck["design.frequency_margin_percent"] is not None,
          "with &design frequency_margin_percent", acts_in=("design",)),
    # A usage spectrum's own keys; its regimes are flight runs, its start a dynamic run of its own
    # (pydriver/usage_spectrum.py).
    Scope(("spectrum",), (), acts_in=("spectrum",)),
    Scope(("spectrum.blade_harmonics", "spectrum.blade_fit_tolerance_deg"), (),
          lambda deck, a: deck["spectrum.blade_file"] is not None and any(str(f).strip()
                                                                          for f in deck["spectrum.blade_file"]),
          "with a blade table (&spectrum blade_file)", acts_in=("spectrum",)),
    Scope(("spectrum.start_stops_per_flight", "spectrum.runup_time"), (),
          lambda deck, a: bool(deck["spectrum.flights_per_hour"]), "with flights (&spectrum flights_per_hour > 0)",
          acts_in=("spectrum",)),
    Scope(("refinement.expected_order",), when=lambda deck, a: deck["refinement.levels"] > 1,
          condition="with &refinement levels > 1"),
    Scope(("output.table_language",), ("static", "modal")),
    # &solver: what each analysis solves
    Scope(("solver.t_end",), INTEGRATING, lambda deck, a: REGISTERED[a].time_axis == "t_end" or _settles(deck, a),
          "as the end of a dynamic run, or the settling time with &solver static_method = 'settle'"),
    Scope(("solver.dt_out", "solver.checkpoint_interval", "solver.output_format"), ("dynamic",)),
    Scope(("solver.error_estimate",), ("dynamic", "flight")),
    Scope(("solver.rtol", "solver.atol", "solver.h_max", "solver.max_steps", "solver.linear_solver",
           "solver.jacobian_max_age", "solver.vector_kernels"), INTEGRATING, _integrates,
          "in a time integration: dynamic and flight runs, or settling (&solver static_method = 'settle')"),
    Scope(("solver.atol_multiplier",), INTEGRATING, lambda deck, a: _integrates(deck, a) and _support_b(deck, a),
          "in a time integration of a chain held by support B (the multipliers are its constraint forces)"),
    Scope(("solver.jacobian",), INTEGRATING, _iteration_matrix,
          "in a time integration with the block or dense linear solver (&solver linear_solver; 'auto' is the "
          "chain solver from 32 coordinates on, which forms no iteration matrix)"),
    Scope(("solver.newton_tol", "solver.newton_max_iter"), RUNS, _newton,
          "where an equilibrium is solved by Newton (&solver static_method = 'newton'; a dynamic run only with "
          "&case start = 'equilibrium')"),
    Scope(("solver.static_method",), ("static", "modal", "dynamic", "flight"), _equilibrium,
          "where an equilibrium is solved (a dynamic run only with &case start = 'equilibrium')"),
    Scope(("solver.settle_tol",), ("static", "modal", "dynamic", "flight"), _settles,
          "with &solver static_method = 'settle'"),
    Scope(("solver.periodic_method", "solver.floquet", "solver.periodic_tol", "solver.max_revolutions",
           "solver.samples_per_rev"), ("flight",)),
    # A regime reports its damage, not its stability (pydriver/usage_spectrum.py, base_flight_deck).
    Scope(("solver.floquet",), ("flight",), ignored_in=("spectrum",)),
)


@dataclass(frozen=True)
class Ignored:
    """Keys of one group that a run ignores, for one reason."""

    group: str
    keys: tuple                   #: key names (empty: the group, opened without keys)
    reason: str                   #: "to flight runs only", "only with &solver static_method = 'settle'"
    analysis: str

    def message(self) -> str:
        """The warning: ``&solver floquet applies to flight runs only: ignored in this static run``."""
        names = f"&{self.group} " + ", ".join(self.keys) if self.keys else f"&{self.group}"
        verb = "apply" if len(self.keys) > 1 else "applies"
        return f"{names} {verb} {self.reason}: ignored in this {_runs((self.analysis,))[:-1]}"


def describe(group: str, key: str) -> str:
    """Where ``&group key`` acts, in words for the deck reference (empty: everywhere), e.g.
    ``"Acts in flight runs only."`` (:func:`pydriver.deck_reference.reference_markdown`)."""
    where, conditions = set(ANALYSES), []
    for scope in SCOPES:
        if scope.names(group, key):
            # A composite run takes part where the key acts in its base analysis: a spectrum's is
            # flight; a design run's varies (static, modal, flight), so it takes part where every
            # run does.
            composite = {a for a in COMPOSITE if a not in scope.ignored_in and (
                REGISTERED[a].evaluates in scope.analyses if REGISTERED[a].evaluates is not None
                else set(scope.analyses) == set(RUNS))}
            where &= set(scope.analyses) | set(scope.acts_in) | composite
            conditions += [scope.condition] if scope.condition else []
    runs = _runs(tuple(a for a in ANALYSES if a in where)) if where else "no runs"
    if conditions:
        text = f"Acts only {'; '.join(conditions)}" + (f" (in {runs})" if where != set(ANALYSES) else "")
        return text if text.endswith(".") else text + "."
    return f"Acts in {runs} only." if where != set(ANALYSES) else ""


def base_analysis(deck: Deck) -> str:
    """The analysis whose keys act: the deck's, or a composite run's base analysis (a design run's
    evaluations, a spectrum's flights)."""
    analysis = deck["case.analysis"]
    if REGISTERED[analysis].evaluates is not None:
        return REGISTERED[analysis].evaluates
    if not REGISTERED[analysis].optimises:
        return analysis
    from pydriver.design_problem import problem
    return problem(deck).base_analysis


def reason(deck: Deck, group: str, key: str | None, analysis: str | None = None) -> str | None:
    """Why ``&group key`` does not act in the deck's run (None: it acts).  ``key`` None asks
    about the group itself (opened without keys)."""
    analysis = analysis or deck["case.analysis"]
    base = base_analysis(deck) if analysis in COMPOSITE else analysis
    for scope in SCOPES:
        if scope.names(group, key):
            if base in COMPOSITE and analysis not in scope.acts_in + scope.ignored_in:
                # A design over a usage spectrum: beyond the optimiser's own keys, a key acts as
                # in the spectrum's own run (pydriver/analyses/spectrum_design.py).
                why = scope.reason(deck, base, REGISTERED[base].evaluates)
            else:
                why = scope.reason(deck, analysis, base)
            if why is not None:
                return why
    return None


def applies(deck: Deck, group: str, key: str | None = None) -> bool:
    """Whether ``&group key`` acts in the deck's run (:func:`reason` is None)."""
    return reason(deck, group, key) is None


def _set(deck: Deck, group: str, key: str) -> bool:
    """The deck sets the key to a value other than its default."""
    if (group, key) not in deck.given:
        return False
    schema_key = lookup(group, key)
    default = default_value(schema_key, deck.n_bodies)
    value = deck[f"{group}.{key}"]
    if default is None or value is None:
        return True
    try:
        return not np.array_equal(np.asarray(value), np.asarray(default))
    except (TypeError, ValueError):
        return True


def ignored_keys(deck: Deck) -> list[Ignored]:
    """The keys (and groups opened without keys) that the deck's run ignores, per group and reason.

    A group that does not act as a whole (``&fatigue`` in a static run) is one entry naming the
    keys it sets; otherwise each key set to a value other than its default is judged by itself."""
    analysis = deck["case.analysis"]
    out = []
    for group in GROUPS:
        if group not in deck.groups:
            continue
        keys = [k for k in GROUPS[group] if _set(deck, group, k)]
        opened_only = not any((group, k) in deck.given for k in GROUPS[group])
        why = reason(deck, group, None, analysis)
        if why is not None:
            if keys or opened_only:
                out.append(Ignored(group, tuple(keys), why, analysis))
            continue
        by_reason: dict[str, list[str]] = {}
        for key in keys:
            why = reason(deck, group, key, analysis)
            if why is not None:
                by_reason.setdefault(why, []).append(key)
        out += [Ignored(group, tuple(names), why, analysis) for why, names in by_reason.items()]
    return out


def warnings(deck: Deck) -> list[str]:
    """One warning per group and reason for the keys the deck's run ignores."""
    return [ignored.message() for ignored in ignored_keys(deck)]
