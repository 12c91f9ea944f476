"""The design optimiser on a usage spectrum (issue 38, item 6; pydriver/analyses/spectrum_design.py):
the objective 'max_spectrum_damage_per_hour' and its gradient against central differences of whole
spectrum runs, and the run-up's part of it against differences of whole run-ups; an optimisation
that lowers it, whose optimum.nml, run as a plain spectrum, gives the optimum's damage; bad design
decks refused naming the key.

The decks are test_spectrum.py's 4-body cable at 16 samples per revolution with two regimes (one of
them at a load factor of 1.3), two flights per hour with a short run-up and two start-stops per
flight, at one refinement level: every term of the spectrum's damage (regimes, ground-air-ground
cycle, start-stops) is present, and a whole spectrum run takes well under a second.
"""

from __future__ import annotations

import numpy as np
import pytest

import pydriver
from pydriver.analyses.dynamic_sensitivities import dynamic_sensitivities
from pydriver.analyses.optimiser import Evaluator
from pydriver.analyses.sensitivities import plan
from pydriver.analyses.spectrum_records import regime_result
from pydriver.deckfile import deck_from_text, deck_text
from pydriver.design_problem import problem
from pydriver.errors import DeckError
from pydriver.model import Model
from pydriver.report_text import design_lines
from pydriver.usage_spectrum import spectrum_of
from test_spectrum import CABLE, TWO_KEYS, spectrum_group

KEYS = dict(TWO_KEYS, start_stops_per_flight="2.0")
PARAMETERS = {"cable.ei": (1.0, 0.5, 2.0), "chain.total_length": (0.6, 0.5, 0.7), "rotor.rpm": (120.0, 100.0, 140.0)}


def design_text(parameters: dict = PARAMETERS, spectrum: dict | None = KEYS, extra: str = "") -> str:
    names = ", ".join(f"'{name}'" for name in parameters)
    lower = ", ".join(str(lo) for _, lo, _ in parameters.values())
    upper = ", ".join(str(hi) for _, _, hi in parameters.values())
    return (CABLE.format(analysis="design", levels=1) + (spectrum_group(spectrum) if spectrum else "")
            + f"&design parameters = {names}, lower = {lower}, upper = {upper}, "
              f"objective = 'max_spectrum_damage_per_hour'{extra} /\n")


def whole_spectrum_damage(evaluate: Evaluator, p, tmp_path) -> float:
    """The damage per flight hour at the worst point of a plain spectrum run of the design at ``p``."""
    path = tmp_path / "spectrum.nml"
    path.write_text(deck_text(evaluate.deck_at(np.asarray(p, float))))
    return pydriver.run_deck(path).summary["spectrum"]["damage_per_flight_hour"]


def test_gradient_matches_central_differences_of_whole_spectrum_runs(tmp_path):
    """The largest term's gradient (the worst point's damage: regimes, GAG cycle, start-stops) in
    the cable's stiffness, its length and the rotor speed (every run takes all three) against
    central differences of whole spectrum runs with a step of 1e-3 of each value.  Tolerance 5e-3
    relative: the differences carry the runs' integration error (rtol = 1e-6 of the damage over a
    step of 2e-3, about 5e-4) and their truncation error (h^2, 1e-6); they were within 4.5e-4 here,
    and a gradient that missed a term (the GAG cycle is a fifth of the damage, the speed enters
    every regime's records per hour) would be off by 1e-1 or more."""
    deck = deck_from_text(design_text(), str(tmp_path / "design.nml"))
    evaluate = Evaluator(deck, problem(deck))
    p0 = np.array([v for v, _, _ in PARAMETERS.values()])
    ev = evaluate(p0)
    worst = max(ev.values, key=ev.values.get)
    # The objective is the spectrum's own damage at its worst point, bit for bit: the same runs.
    assert ev.values[worst] == whole_spectrum_damage(evaluate, p0, tmp_path)
    assert ev.details["damage_shares"]["ground-air-ground"] > 0.1
    assert ev.details["damage_shares"]["start-stops"] > 0.0
    for i, name in enumerate(PARAMETERS):
        h = 1.0e-3 * p0[i]
        up, down = p0.copy(), p0.copy()
        up[i] += h
        down[i] -= h
        fd = (whole_spectrum_damage(evaluate, up, tmp_path) - whole_spectrum_damage(evaluate, down, tmp_path)) / (2 * h)
        assert ev.gradients[worst][i] == pytest.approx(fd, rel=5.0e-3), name


def test_optimum_lowers_the_damage_and_reruns_as_a_plain_spectrum(tmp_path):
    """One start from the deck's values: the optimum's damage per flight hour is lower than the
    start's (its life longer), the design block says so in flight hours, and optimum.nml run as a
    plain spectrum gives the optimum's damage bit for bit: the optimum's values are written
    exactly (repr) and it is the same deck the last evaluation ran, through the same code.  The
    terminal summary and report.html show the life over the spectrum and the damage's sources
    before and after."""
    path = tmp_path / "design.nml"
    path.write_text(design_text(extra=", starts = 1"))
    out = tmp_path / "out"
    result = pydriver.run_deck(path, out=out, report=True)
    d = result.summary["design"]
    assert d["objective"]["optimum"] < 0.9 * d["objective"]["start"]
    # Every key of the spectrum deck acts in its design run (none is reported ignored).
    assert not [w for w in result.summary.get("warnings", []) if "ignored" in w]
    assert d["life_hours"]["optimum"] == pytest.approx(1.0 / d["objective"]["optimum"], rel=1e-15)
    assert d["life_hours"]["quantity"] == "life over the usage spectrum"
    assert set(d["spectrum"]) == {"start", "optimum"}
    assert d["spectrum"]["optimum"]["damage_per_flight_hour"] == d["objective"]["optimum"]
    # The report's before and after: the life over the spectrum and where its damage comes from.
    lines = "\n".join(design_lines(d))
    assert "life over the usage spectrum" in lines and "optimum: worst point joint" in lines
    page = (out / "report.html").read_text()
    assert "life over the usage spectrum [h]" in page and "damage share: ground-air-ground [%]" in page
    text = (out / "optimum.nml").read_text()
    assert "&design" not in text and "'spectrum'" in text
    plain = pydriver.run_deck(out / "optimum.nml", out=tmp_path / "plain")
    assert plain.summary["spectrum"]["damage_per_flight_hour"] == d["objective"]["optimum"]
    assert result.summary["spectrum"]["damage_per_flight_hour"] == d["objective"]["optimum"]


SPECTRUM_DESIGN = "&design parameters = {names}, lower = {lower}, upper = {upper}, " \
                  "objective = 'max_spectrum_damage_per_hour' /\n"


@pytest.mark.parametrize("spectrum, names, lower, upper, key, reason", [
    (None, "'cable.ei'", "0.5", "2.0", "objective", "needs the deck's usage spectrum"),
    # the load factor 1.3 of regime 'fast' scales the gravity: it enters changed
    (KEYS, "'loads.gravity(3)'", "-12.0", "-8.0", "parameters", "enters regime 'fast'"),
    # every regime sets its forward speed and the run-up has none
    (KEYS, "'drag.forward_speed'", "0.0", "20.0", "parameters", "acts in no regime"),
    (KEYS, "'cable.ei'", "2.0", "0.5", "upper", ""),                 # reversed
    (KEYS, "'cable.ei'", "0.5", "1e400", "upper", ""),               # huge
    (KEYS, "'cable.ei'", "1e-300", "1e-299", "lower", ""),           # tiny: the deck's 1.0 outside
    (KEYS, "'cable.ei'", "0.5, 0.6", "2.0", "lower", ""),            # wrong count
], ids=["no-spectrum", "scaled-by-load-factor", "in-no-run", "reversed", "huge", "tiny", "wrong-count"])
def test_bad_spectrum_design_refused_naming_the_key(tmp_path, spectrum, names, lower, upper, key, reason):
    """A spectrum design the program cannot run is refused before any run, naming &design and the
    key, and leaves no output behind."""
    text = (CABLE.format(analysis="design", levels=1) + (spectrum_group(spectrum) if spectrum else "")
            + SPECTRUM_DESIGN.format(names=names, lower=lower, upper=upper))
    path = tmp_path / "bad.nml"
    path.write_text(text)
    with pytest.raises(DeckError) as err:
        pydriver.run_deck(path, out=tmp_path / "out")
    assert "&design" in str(err.value) and f"'{key}'" in str(err.value) and reason in str(err.value)
    assert not (tmp_path / "out").exists()


def test_runup_extremes_match_central_differences_of_runups(tmp_path):
    """The run-up's part of the gradient: the largest, smallest and first value of a jacket point's
    history in the run-up (the ground-air-ground and ground cycles' ends when the run-up or the
    rest state holds them) against central differences of whole run-ups, step 1e-3 of each value,
    at every joint's point 5 of 24.  Tolerance 2e-3 of the largest of the three per parameter: the
    held sample's derivative is exact, the differences carry the run-ups' integration error
    (rtol = 1e-6 over a step of 2e-3, about 5e-4 of the value); they agreed within 1.7e-4 here."""
    deck = deck_from_text(design_text(), str(tmp_path / "design.nml"))
    evaluate = Evaluator(deck, problem(deck))
    names = list(PARAMETERS)
    p0 = np.array([v for v, _, _ in PARAMETERS.values()])

    def runup(p):
        spec = spectrum_of(evaluate.deck_at(p).with_values({"refinement.levels": 1}))
        return spec.runup, regime_result(spec.runup)

    deck0, run0 = runup(p0)
    k = 5
    model = Model(deck0.with_values({"design.parameters": names}))
    sens = dynamic_sensitivities(model, plan(model), run0.timeseries, worst_points=[k] * model.n_bodies,
                                 jacket_extremes=True)
    table = sens["summary"]["d_output_d_parameter"]
    points = run0.extra["fatigue_points"]
    for i, name in enumerate(names):
        h = 1.0e-3 * p0[i]
        up, down = p0.copy(), p0.copy()
        up[i] += h
        down[i] -= h
        a, b = runup(up)[1].extra["fatigue_points"], runup(down)[1].extra["fatigue_points"]
        for j in range(1, model.n_bodies + 1):
            point = int(np.flatnonzero(points.joint == j)[k])
            exact = {out: table[f"{out}{j}"][name] for out in ("jacket_max", "jacket_min", "jacket_first")}
            scale = max(abs(v) for v in exact.values())
            assert scale > 0.0
            for out, attr in (("jacket_max", "maximum"), ("jacket_min", "minimum"), ("jacket_first", "first")):
                fd = (getattr(a, attr)[point] - getattr(b, attr)[point]) / (2 * h)
                assert exact[out] == pytest.approx(fd, abs=2.0e-3 * scale), (name, j, out)
