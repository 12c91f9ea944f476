"""Design sensitivities of a dynamic run (&design parameters with analysis = 'dynamic'; issue 24).

The sensitivities (pydriver/analyses/dynamic_sensitivities.py: forward sensitivities through the
DAE, restarted at pulse edges; the start from the equilibrium by the implicit function theorem or
from the deck's shape by the rebuilt models' own projected starts) are checked against central
differences of WHOLE dynamic runs at p +- H, each from its own start, on two scenes:

* the UH-60 part 2 decay (uh60_part2_decay.nml): rest in the equilibrium, a 1 N pulse on body 6
  over 0.1 s (a switch time inside the run), clamp B's height, the springs and the mass, with
  &fatigue on the bending moment (damage per hour and DELs of the record repeated);
* the six-link chain (six_link_dynamic.nml): from the deck's shape, clamp B's y, the dampers and
  the density.

Tolerance 1e-4 relative to the largest sensitivity of each output family (issue 24).  Both
sides integrate at rtol 1e-10 (atol 1e-12); a whole-run difference over 2 H = 2e-4 of the
parameter carries ~1e-10 / 1e-4 = 1e-6 of integration noise, more where the output is an
extreme at a sharp peak: an output whose differences at H and 3 H disagree by more than TOL / 2
is not a reference and is left out, at most 10 % of them.  The selection (the extreme's sample,
the rainflow cycle set) is the base run's, held in the differences (flight_outputs_frozen's
rule), which is what the sensitivities claim.  Families whose values are round-off (torsion of
the thesis's zy joints, ~1e-12 Nm) are not compared: their derivatives are noise on both sides.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import INPUTS

import pydriver
from pydriver.analyses.dynamics import dynamic_analysis
from pydriver.analyses.history_outputs import HistoryOutputs, history_signal
from pydriver.design import parameters
from pydriver.model import Model

TOL = 1.0e-4
H_REL = 1.0e-4
TIGHT = {"solver.rtol": 1.0e-10, "solver.atol": 1.0e-12, "solver.dt_out": 1.0e-3}
FATIGUE = {"fatigue.sn_quantity": "bending", "fatigue.sn_exponent": 5.0, "fatigue.sn_reference_amplitude": 1.0,
           "fatigue.sn_reference_cycles": 1.0e6}
CASES = {
    "decay": ("uh60_part2_decay.nml", {**TIGHT, **FATIGUE},
              ["springs.c_beta", "clamp_b.position(3)", "chain.total_mass"]),
    "six_link": ("six_link_dynamic.nml", TIGHT, ["springs.d_beta", "clamp_b.position(2)", "chain.density"]),
}


def family(name: str) -> str:
    """The family an output is compared within: reactions by force/moment and extreme, joint
    loads by quantity and kind (peak, amplitude, damage, DEL)."""
    if name.startswith(("F", "M")):
        return name[0] + name.split("_")[-1]
    return name.rstrip("0123456789").split("_")[0].rstrip("0123456789") + "_" + name.split("_")[-1].rstrip("0123456789")


def frozen_outputs(model, base_ts, other, other_ts) -> np.ndarray:
    return HistoryOutputs(model, base_ts, periodic=False).frozen(lambda spec: history_signal(other, other_ts, spec))


@pytest.mark.parametrize("case", list(CASES))
def test_dynamic_sensitivities_match_whole_run_differences(case):
    deck, changes, names = CASES[case]
    model = Model.from_deck(INPUTS / deck).with_changes(changes)
    result = pydriver.run_deck(model.with_changes({"design.parameters": names}))
    d = result.summary["sensitivities"]["d_output_d_parameter"]
    base = dynamic_analysis(model).timeseries
    outs = HistoryOutputs(model, base, periodic=False)
    noise = {family(n) for n, v in zip(outs.names, outs.values)
             if max(abs(x) for m, x in zip(outs.names, outs.values) if family(m) == family(n)) < 1e-9}
    if case == "decay":
        assert "damage_per_hour6" in d and "del_FB_z" in d
    worst = {}
    for p in parameters(model.with_changes({"design.parameters": names}).deck):
        h = H_REL * max(abs(p.value), 1e-2)
        runs = {}
        for s in (-3.0, -1.0, 1.0, 3.0):
            m = model.with_changes(p.changes(model.deck, p.value + s * h))
            runs[s] = frozen_outputs(model, base, m, dynamic_analysis(m).timeseries)
        fd = (runs[1.0] - runs[-1.0]) / (2 * h)
        fd3 = (runs[3.0] - runs[-3.0]) / (6 * h)
        scale = {}
        for n, v in zip(outs.names, fd):
            scale[family(n)] = max(scale.get(family(n), 0.0), abs(v))
        compared = [i for i, n in enumerate(outs.names) if family(n) not in noise and scale[family(n)] > 0.0]
        unsure = [i for i in compared if abs(fd3[i] - fd[i]) > 0.5 * TOL * scale[family(outs.names[i])]]
        assert len(unsure) <= 0.1 * len(compared), (p.name, [outs.names[i] for i in unsure])
        for i in compared:
            if i in unsure:
                continue
            n = outs.names[i]
            err = abs(d[n][p.name] - fd[i]) / scale[family(n)]
            worst[p.name] = max(worst.get(p.name, 0.0), err)
            assert err < TOL, (p.name, n, d[n][p.name], fd[i])
    print(case, "worst relative disagreement:", {k: f"{v:.1e}" for k, v in worst.items()})


def test_dynamic_sensitivities_are_written(tmp_path):
    model = Model.from_deck(INPUTS / "six_link_dynamic.nml").with_changes({"design.parameters": ["springs.d_beta"]})
    result = pydriver.run_deck(model, out=tmp_path / "run")
    assert (tmp_path / "run" / "sensitivities.csv").is_file()
    assert result.summary["sensitivities"]["solver"]["steps"] > 0
    assert "FB_y_max" in result.summary["sensitivities"]["d_output_d_parameter"]
