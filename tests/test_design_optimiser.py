"""The design optimiser (&case analysis = 'design'; issue 24, item 3).

The known optimum is that of a dense 1-D scan of WHOLE runs (a new Newton solve per point): the
UH-60 part 2 cable, clamp B's height z_B in [-0.2, -0.07] m, objective the largest joint moment.
The scan's minimum lies inside the range (measured: z_B = -0.1035 m, 26.7885 Nm; the objective
is smooth there, one joint's moment dominating, and curved by f'' ~ 1.8e3 Nm/m^2).

Tolerances.  SLSQP stops when the scaled objective (divided by its start value, 27.79 Nm) changes
by less than ftol = 1e-6, so its objective is within ~1e-6 relative of the minimum; the scan's
best point is no lower than the true minimum and no higher than it by f'' dz^2 / 8 at grid step
dz (1e-9 relative at dz = 1.3e-4 m).  Hence optimiser <= scan * (1 + 2e-6).  The location of a
smooth minimum is known only to sqrt(2 ftol f / f'') = 1.7e-4 m from the objective's flatness:
the optimum must lie within that plus one grid step of the scan's best point.
"""

from __future__ import annotations

import json
import re
import subprocess
import sys

import numpy as np
import pytest

import pydriver
from conftest import INPUTS
from pydriver.analyses.modal import modal_analysis
from pydriver.analyses.statics import static_analysis
from pydriver.model import Model
from pydriver.output import read_csv

FTOL = 1.0e-6
LOW, HIGH = -0.2, -0.07


def design(objective: str, extra: dict | None = None, deck: str = "uh60_part2") -> Model:
    return Model.from_deck(INPUTS / f"{deck}.nml").with_changes({
        "case.analysis": "design", "design.parameters": ["clamp_b.position(3)"],
        "design.objective": f"'{objective}'", "design.lower": [LOW], "design.upper": [HIGH],
        "design.tolerance": FTOL, **(extra or {})})


def largest_joint_moment(table) -> float:
    return float(np.max(np.hypot(table["bending_Nm"], table["torsion_Nm"])))


def with_height(base: Model, z: float) -> Model:
    position = np.array(base.deck["clamp_b.position"], float)
    position[2] = z
    return base.with_changes({"clamp_b.position": position})


def scan(analysis, n: int):
    """(z, objective, result) of whole runs at n heights in [LOW, HIGH]."""
    base = Model.from_deck(INPUTS / "uh60_part2.nml")
    out = []
    for z in np.linspace(LOW, HIGH, n):
        r = analysis(with_height(base, z))
        out.append((z, largest_joint_moment(r.table), r))
    return out


def test_optimum_matches_a_dense_scan_of_whole_runs():
    points = scan(static_analysis, 1001)
    z_scan, f_scan, _ = min(points, key=lambda p: p[1])
    assert LOW + 0.01 < z_scan < HIGH - 0.01                   # an interior optimum, not a bound
    result = pydriver.run_deck(design("max_joint_moment"))
    d = result.summary["design"]
    z_opt = d["parameters"]["clamp_b.position(3)"]["optimum"]
    f_opt = d["objective"]["optimum"]
    step = (HIGH - LOW) / 1000
    curvature = 1.8e3                                           # Nm/m^2, measured (module docstring)
    print(f"scan z = {z_scan:.5f} m, {f_scan:.6f} Nm; optimiser z = {z_opt:.5f} m, {f_opt:.6f} Nm, "
          f"{d['iterations']} iterations, {d['runs']} runs")
    assert d["converged"] and d["parameters"]["clamp_b.position(3)"]["at_bound"] is None
    assert f_opt <= f_scan * (1.0 + 2.0 * FTOL)
    assert abs(z_opt - z_scan) <= step + np.sqrt(2.0 * FTOL * f_scan / curvature)
    # the history starts at the deck and ends at the optimum, the objective falling
    h = result.extra["tables"]["design_history.csv"]
    assert h["clamp_b.position(3)"][0] == -0.135 and h["clamp_b.position(3)"][-1] == z_opt
    assert h["objective"][-1] == f_opt < h["objective"][0]


def test_trust_constr_finds_the_same_optimum():
    d = pydriver.run_deck(design("max_joint_moment", {"design.method": "'trust-constr'"})).summary["design"]
    ref = pydriver.run_deck(design("max_joint_moment")).summary["design"]
    assert d["objective"]["optimum"] == pytest.approx(ref["objective"]["optimum"], rel=1e-5)


def test_active_frequency_margin_matches_a_scan_of_feasible_designs():
    # At 350 rpm with harmonics 1 ... 4 and a 10 % margin the first frequency must stay above
    # 4.4 x 350/60 = 25.667 Hz (it starts at 26.25 Hz); the unconstrained optimum (25.1 Hz) is not
    # allowed, so the constraint is active: the optimum is the feasible scan point of least moment.
    extra = {"resonance.operating_rpm": [350.0], "resonance.harmonics": 4, "design.frequency_margin_percent": 10.0}
    result = pydriver.run_deck(design("max_joint_moment", extra))
    d = result.summary["design"]
    edge = 4 * 1.1 * 350.0 / 60.0
    assert d["frequency_margin"]["gap_hz"] == [pytest.approx(edge), None]
    assert d["converged"] and d["frequency_margin"]["satisfied"]
    f1 = d["frequency_margin"]["optimum"]["f1_hz"]
    assert f1 == pytest.approx(edge, rel=1e-6)                 # on the constraint
    points = [(z, f, r.summary["frequencies_hz"][0]) for z, f, r in scan(modal_analysis, 131)]
    feasible = [(z, f) for z, f, fr in points if fr >= edge]
    z_scan, f_scan = min(feasible, key=lambda p: p[1])
    z_opt = d["parameters"]["clamp_b.position(3)"]["optimum"]
    step = (HIGH - LOW) / 130
    print(f"constrained: scan z = {z_scan:.4f} m, {f_scan:.5f} Nm; optimiser z = {z_opt:.5f} m, "
          f"{d['objective']['optimum']:.5f} Nm, f1 = {f1:.5f} Hz")
    assert abs(z_opt - z_scan) <= step
    assert d["objective"]["optimum"] <= f_scan * (1.0 + 2.0 * FTOL)   # the boundary lies between grid points


def test_optimum_deck_runs_and_reproduces_the_objective(tmp_path):
    out = tmp_path / "design"
    result = pydriver.run_deck(INPUTS / "uh60_part2_design.nml", out=out, report=True)
    d = result.summary["design"]
    assert d["converged"]
    assert {"design_history.csv", "optimum.nml", "report.html", "summary.json"} <= {p.name for p in out.iterdir()}
    assert "Design optimisation: before and after" in (out / "report.html").read_text()
    proc = subprocess.run([sys.executable, "-m", "pydriver", "run", str(out / "optimum.nml")], cwd=tmp_path,
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    rerun = tmp_path / "results" / "optimum"
    summary = json.loads((rerun / "summary.json").read_text())
    assert summary["analysis"] == "modal"
    # The deck holds the optimum to 17 digits and the run starts from the same shape: the same
    # Newton solve, so the same numbers to round-off.
    table = read_csv(rerun / "table.csv")
    assert largest_joint_moment(table) == pytest.approx(d["objective"]["optimum"], rel=1e-9)
    assert summary["frequencies_hz"][0] == pytest.approx(d["frequency_margin"]["optimum"]["f1_hz"], rel=1e-9)


def test_objective_registry_largest_reaction_force():
    result = pydriver.run_deck(design("max_reaction_force"))
    d = result.summary["design"]
    largest = max(np.linalg.norm(w["F"]) for w in result.summary["reactions"].values())
    assert d["converged"] and d["objective"]["optimum"] == pytest.approx(largest, rel=1e-12)
    assert d["objective"]["optimum"] < d["objective"]["start"]


def test_iteration_limit_is_reported_as_not_converged(tmp_path):
    result = pydriver.run_deck(design("max_joint_moment", {"design.max_iterations": 1}), out=tmp_path / "o")
    d = result.summary["design"]
    assert d["converged"] is False
    assert any("did not converge" in w for w in result.summary["warnings"])
    assert "converged: false" in (tmp_path / "o" / "optimum.nml").read_text()


@pytest.mark.parametrize("text,key,reason", [
    ("objective = 'least_mass'", "objective", "max_reaction_force"),
    ("lower = -0.2, -0.1", "lower", "2 values for 1 parameters"),
    ("upper = -0.3", "upper", "is not above lower(1)"),
    ("upper = -0.14", "lower", "outside its bounds"),
    ("frequency_margin_percent = 150.0", "frequency_margin_percent", ""),
    ("frequency_margin_percent = 10.0", "frequency_margin_percent", "operating rotor speed"),
    ("method = 'nelder-mead'", "method", "slsqp"),
    ("max_iterations = 0", "max_iterations", ""),
    ("tolerance = 0.0", "tolerance", ""),
])
def test_bad_design_keys_name_group_and_key(deck_copy, text, key, reason):
    path = deck_copy("uh60_part2")
    body = path.read_text().replace("analysis = 'static'", "analysis = 'design'")
    settings = {"objective": "'max_joint_moment'", "lower": "-0.2", "upper": "-0.07"}
    name = text.split("=")[0].strip()
    settings[name] = text.split("=", 1)[1].strip()
    lines = "\n".join(f"  {k} = {v}" for k, v in settings.items())
    path.write_text(body + f"\n&design\n  parameters = 'clamp_b.position(3)'\n{lines}\n/\n")
    with pytest.raises(pydriver.DeckError) as err:
        pydriver.run_deck(path, out=path.parent / "out")
    assert (err.value.group, err.value.key) == ("design", key), str(err.value)
    assert reason in err.value.reason, str(err.value)
    assert not (path.parent / "out").exists()


def test_optimiser_keys_refused_outside_a_design_run(deck_copy):
    path = deck_copy("uh60_part2")
    path.write_text(path.read_text() + "\n&design\n  parameters = 'chain.total_length'\n  objective = "
                                       "'max_joint_moment'\n/\n")
    with pytest.raises(pydriver.DeckError) as err:
        pydriver.run_deck(path)
    assert (err.value.group, err.value.key) == ("design", "objective")
    assert "only with &case analysis = 'design'" in err.value.reason


# -- a flight objective -------------------------------------------------------------------------

def hover_f1(model: Model) -> float:
    """The first undamped frequency of a flight deck's hover state (the margin's frequency)."""
    from pydriver.analyses.hover_modes import hover_model
    return float(modal_analysis(hover_model(model)).summary["frequencies_hz"][0])


def test_flight_damage_optimum_sits_on_the_frequency_edge():
    # The main job's cable (uh60_part2_design_flight.nml), the length alone in [0.5605, 0.6195] m,
    # objective the largest damage per flight hour under a 10 % margin from 1/rev ... 8/rev at
    # 260 rpm.  The damage rises with the length over the whole range (measured on whole flight
    # runs: 0.0155 at 0.5605 m, 0.0357 at 0.590 m, 0.0669 1/h at 0.6195 m) and the first
    # frequency falls with it (19.55 Hz at 0.5605 m, 16.37 Hz at 0.590 m, 14.15 Hz at 0.6195 m).
    # From the deck's 0.590 m (16.37 Hz, inside the 4/rev band 15.60-19.07 Hz, nearer its lower
    # edge) the optimum is the shortest cable below the band: f1 = 0.9 x 4 x 260/60 = 15.6 Hz
    # exactly.  The reference is that length by bisection on the hover state's modal analysis
    # (no optimiser, no sensitivities).  SLSQP holds the constraint to its tolerance 1e-6 on
    # f1 / (260/60 Hz), 4.3e-6 Hz, which is 4e-8 m at df1/dL ~ -1e2 Hz/m: bound 1e-6 m.
    model = Model.from_deck(INPUTS / "uh60_part2_design_flight.nml").with_changes(
        {"design.parameters": ["chain.total_length"], "design.lower": [0.5605], "design.upper": [0.6195],
         "design.tolerance": FTOL})
    result = pydriver.run_deck(model)
    d = result.summary["design"]
    assert d["converged"] and d["frequency_margin"]["satisfied"]
    length = d["parameters"]["chain.total_length"]["optimum"]
    edge = 0.9 * 4 * 260.0 / 60.0
    flight = Model.from_deck(INPUTS / "uh60_part2_forward_flight_cable.nml").with_changes({"refinement.levels": 1})
    lo, hi = 0.590, 0.6195
    assert hover_f1(flight.with_changes({"chain.total_length": lo})) > edge > \
        hover_f1(flight.with_changes({"chain.total_length": hi}))
    while hi - lo > 1e-9:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if hover_f1(flight.with_changes({"chain.total_length": mid})) > edge else (lo, mid)
    print(f"optimum length {length:.9f} m, bisection {0.5 * (lo + hi):.9f} m; damage "
          f"{d['objective']['start']:.5g} -> {d['objective']['optimum']:.5g} 1/h in {d['runs']} runs")
    assert abs(length - 0.5 * (lo + hi)) < 1e-6
    # The start breaks the margin: holding it costs damage (a longer cable).
    assert d["objective"]["optimum"] > d["objective"]["start"]
    # The design's damage is that of its own flight run (summary of the optimum).
    hot = result.summary["fatigue"]["hotspots"][0]
    assert hot["damage_per_hour"] == pytest.approx(d["objective"]["optimum"], rel=1e-9)


def test_damage_objective_needs_an_sn_curve(tmp_path):
    text = (INPUTS / "uh60_part2_design_flight.nml").read_text()
    # The group up to its own '/' line (a comment's "docs/model.md" is not its end; issue 37).
    group = re.search(r"&fatigue\b.*?\n\s*/", text, re.S)
    deck = tmp_path / "no_fatigue.nml"
    deck.write_text(text[:group.start()] + text[group.end():])
    with pytest.raises(pydriver.DeckError, match="S-N curve") as err:
        pydriver.run_deck(deck)
    assert (err.value.group, err.value.key) == ("design", "objective")
