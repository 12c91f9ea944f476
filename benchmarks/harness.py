"""What every benchmark measures the same way: one timed integration of a deck's model by
the Fortran core (the integration alone: no deck reading, no start equilibrium, no outputs),
and the check that the run did the work (steps taken, a finite answer).

The timed integration is a core probe (``pydriver.core_probes.integrate_timed``): it needs a build with the
meson option ``probes`` on (``bash .ci/setup``), not the product wheel."""

from __future__ import annotations

from pathlib import Path

import numpy as np

import pydriver
from pydriver import core_probes as probes
from pydriver.analyses.dynamics import start_state
from pydriver.model import resolve_linear_solver

METHODS = {"rotorcable-IDA": 1, "gsl-rk8pd": 2, "gsl-msbdf": 3}


class NoWorkDone(RuntimeError):
    """A benchmark run that took no steps or gave a non-finite answer: its time means nothing."""


def prepared(deck_or_model):
    """(model, consistent q0, v0, t_end) of a deck, the start state as the run would use it."""
    m = deck_or_model if isinstance(deck_or_model, pydriver.Model) else pydriver.Model.from_deck(deck_or_model)
    q0, v0 = start_state(m)
    start = m.core.consistent_start(q0, v0)
    return m, start["q"], start["v"], float(m.deck["solver.t_end"])


def timed_run(model, q0, v0, t_end: float, method: str = "rotorcable-IDA", rtol: float = 1e-6,
              atol: float | None = None, samples: int = 2, baumgarte: float = 50.0, **solver) -> dict:
    """One timed integration; raises NoWorkDone unless it took steps and ended finite."""
    settings = model.solver_settings()
    settings.update(rtol=rtol, atol=rtol * 1e-2 if atol is None else atol, **solver)
    settings["linear_solver"] = resolve_linear_solver(settings["linear_solver"], model.nq)
    out = probes.integrate_timed(model.core, METHODS[method], settings, 0.0, t_end, q0, v0, samples, baumgarte)
    if out["stats"]["steps"] <= 0 or not np.all(np.isfinite(out["cm_samples"])):
        raise NoWorkDone(f"{model.name}, {method}, rtol {rtol:g}: {out['stats']['steps']} steps; no work done")
    end = model.core.sample([t_end], out["q_end"][:, None], out["v_end"][:, None])
    out["reactions_end"] = end.wrenches.as_flat()[0]
    out["gmax_end"] = float(end.g_max[0])
    out["tip_end"] = end.joints[:, -1, 0]
    return out


def add_set_option(parser) -> None:
    """``--set group.key=value`` (repeatable): deck values every run of the benchmark gets, e.g.
    ``--set solver.linear_solver=chain``, so a script measures a new core option without
    being edited.  The values are namelist texts, validated by the deck schema like a deck's."""
    parser.add_argument("--set", dest="sets", action="append", default=[], metavar="GROUP.KEY=VALUE",
                        help="deck override for every run (repeatable), e.g. solver.linear_solver=chain")


def parse_sets(items) -> dict:
    """``["solver.rtol=1e-8", ...]`` -> ``{"solver.rtol": "1e-8"}``; a malformed item is an error."""
    out = {}
    for item in items or ():
        key, sep, value = item.partition("=")
        if not sep or "." not in key:
            raise SystemExit(f"--set {item!r}: expected GROUP.KEY=VALUE")
        out[key.strip().lower()] = value.strip()
    return out


def nested_sets(sets: dict) -> dict:
    """``{"solver.rtol": "1e-8"}`` -> ``{"solver": {"rtol": "1e-8"}}`` (pydriver.study.override_deck)."""
    out: dict = {}
    for dotted, value in sets.items():
        group, _, key = dotted.partition(".")
        out.setdefault(group, {})[key] = value
    return out


def set_args(sets: dict) -> list:
    """The command-line form of ``sets``, to hand on to a child process."""
    return [a for k, v in sets.items() for a in ("--set", f"{k}={v}")]


def open_chain_model(deck_path) -> pydriver.Model:
    """The deck's chain with clamp B removed (end B free), its start in its own equilibrium: the
    open-chain variant of a closed-chain deck, for peers that run the open chain (the MuJoCo
    RK4 peer, benchmarks/peers/mujoco_route.py) and rotorcable's reference of it."""
    from pydriver.deckfile import read_deck, validate
    d = read_deck(deck_path)
    raw = {g: dict(v) for g, v in d.raw.items() if g != "clamp_b"}
    starts = {g: dict(v) for g, v in d.starts.items() if g != "clamp_b"}
    deck = validate(raw, starts, f"{Path(deck_path).stem}_open")
    deck.path = d.path
    return pydriver.Model(deck)
