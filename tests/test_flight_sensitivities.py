"""Design sensitivities of a flight run (&design parameters; issue 24, flight increment).

The sensitivities (pydriver/analyses/flight_sensitivities.py: IDAS forward sensitivities with
parameter partials of the rebuilt models, periodic start by (I - Phi)^-1 dX(T)/dp) are checked
against central differences of WHOLE flight runs, each marched to its own periodic state at
p +- H, on the main job's cable (uh60_part2_forward_flight_cable.nml at n = 11, one level).

Tolerance 1e-4 relative (issue 24).  What the comparison carries:

* both sides integrate at rtol = 1e-10 (atol 1e-12) and the whole runs march to
  periodic_tol = 1e-10 m: their outputs carry ~1e-10 relative integration error, which the
  difference over 2H = 2e-4 of the parameter turns into ~1e-6 of the sensitivity (more where the
  output's change is small against the output: the damping time's); the reference difference's
  truncation is O(H^2) ~ 1e-8 relative;
* peaks, amplitudes, damage and DELs are piecewise smooth: exact between changes of the
  sample that holds an extreme, of the rainflow cycle set or of the worst point around the
  jacket (docs/model.md).  A whole-run difference across such a change measures the kink, not
  the derivative: where the selection (pydriver.analyses.flight_sensitivities.
  flight_selections) differs at p - H, p or p + H (damage and DELs of 3-4 of the 11 joints
  here, through cycles that carry 1e-9 ... 1e-6 of the damage) the reference is the difference
  of the whole runs' outputs with the base run's selection held (flight_outputs_frozen), which
  is what the sensitivities claim to be;
* the reference is checked against itself: an output whose differences at H and 3 H disagree by
  more than TOL/2 (an integration-noise floor or a kink the selection does not see) is left
  out, at most 10 % of them (measured: the damage and DEL of joint 9 for cable.damping_time, 2 of
  146; 10 of 146 for chain.total_length, whose H and 3 H differences part by their O(H^2)
  truncation; worst agreement of the rest 1.2e-6 (cable.ei), 4.6e-5 (cable.damping_time),
  2.7e-6 (drag.cd), 3.7e-5 and 3.1e-5 (clamp_b.position(1), (3)), 1.5e-5 (chain.total_length),
  2.6e-6 (rotor.rpm; 6 of 146 left out));
* each output is compared against the largest sensitivity of its family (reactions, each
  joint-load quantity, damage, DEL) for that parameter: an output whose own sensitivity is
  near zero carries the absolute integration error of the others.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import INPUTS

import pydriver
from pydriver import core_probes as probes
from pydriver.analyses.flight import flight_analysis
from pydriver.analyses.flight_sensitivities import (
    flight_outputs,
    flight_outputs_frozen,
    flight_selections,
    worst_points_of,
)
from pydriver.analyses.history_outputs import HistoryOutputs, history_signal
from pydriver.core import PartialKind
from pydriver.design import parameters
from pydriver.model import Model

TOL = 1.0e-4            # issue 24
H_REL = 1.0e-4          # whole-run difference step (module docstring)
TIGHT = {"refinement.levels": 1, "solver.rtol": 1.0e-10, "solver.atol": 1.0e-12, "solver.periodic_tol": 1.0e-10,
         "solver.max_revolutions": 200, "solver.floquet": False}
#: Loads, damping and drag; parameters that move the constraint: clamp B's position (it moves
#: with the blade) and the cable's length (clamp B relative to the cable's end); and the rotor
#: speed, which changes the period (outputs at fixed blade azimuth: the whole runs' sample k is
#: at azimuth 2 pi k / samples_per_rev at any speed).
NAMES = ["cable.ei", "cable.damping_time", "drag.cd", "clamp_b.position(1)", "clamp_b.position(3)",
         "chain.total_length", "rotor.rpm"]


def family(name: str) -> str:
    """The family an output is compared within (its scale)."""
    if name.startswith(("F", "M")):
        return name[0] + name.split("_")[-1]          # forces / moments, max / min
    stem = name.rstrip("0123456789_").split("_")[0]
    return stem.rstrip("0123456789") + "_" + name.split("_")[-1]


@pytest.fixture(scope="module")
def flight_case():
    model = Model.from_deck(INPUTS / "uh60_part2_forward_flight_cable.nml").with_changes(TIGHT)
    result = pydriver.run_deck(model.with_changes({"design.parameters": NAMES}))
    return model, result


def whole_run_differences(model):
    """{parameter: {output: whole-run central difference at H}} (with the base selection held
    where it changes within p +- H), the same at 3 H, and the outputs whose selection changes
    within p +- 3 H (no self-check there)."""
    out, out3, changed = {}, {}, {}
    base = flight_analysis(model).timeseries
    names = flight_outputs(model, base)[0]
    sel_0 = flight_selections(model, base)
    for p in parameters(model.with_changes({"design.parameters": NAMES}).deck):
        def at(s, p=p):
            m = model.with_changes(p.changes(model.deck, p.value + s * H_REL * abs(p.value)))
            ts = flight_analysis(m).timeseries
            return (dict(zip(names, flight_outputs(m, ts)[2])), flight_selections(m, ts),
                    dict(zip(names, flight_outputs_frozen(model, base, m, ts))))
        runs = {s: at(s) for s in (-3.0, -1.0, 1.0, 3.0)}
        h = H_REL * abs(p.value)
        moved_h = {k for k in names if runs[1.0][1][k] != sel_0[k] or runs[-1.0][1][k] != sel_0[k]}
        moved_3h = {k for k in names if runs[3.0][1][k] != sel_0[k] or runs[-3.0][1][k] != sel_0[k]}
        out[p.name] = {k: (runs[1.0][2 if k in moved_h else 0][k] - runs[-1.0][2 if k in moved_h else 0][k]) / (2 * h)
                       for k in names}
        out3[p.name] = {k: (runs[3.0][2 if k in moved_h else 0][k] - runs[-3.0][2 if k in moved_h else 0][k])
                        / (6 * h) for k in names}
        changed[p.name] = moved_3h - moved_h
    return out, out3, changed


def test_flight_sensitivities_match_whole_run_differences(flight_case):
    model, result = flight_case
    sens = result.summary["sensitivities"]
    d = sens["d_output_d_parameter"]
    assert set(d["FA_z_max"]) == set(NAMES)
    assert sens["periodicity_residual"] < 1e-5           # s(T) = s(0) on the periodic orbit
    fd, fd3, changed = whole_run_differences(model)
    worst, unsure = {}, {}
    for pname, fd_p in fd.items():
        scale = {}
        for name, v in fd_p.items():
            scale[family(name)] = max(scale.get(family(name), 0.0), abs(v))
        # The reference is a reference where it is smooth (same selection) and its differences at
        # H and 3 H agree (module docstring).
        unsure[pname] = {n for n, v in fd_p.items()
                         if n not in changed[pname] and abs(fd3[pname][n] - v) > 0.5 * TOL * scale[family(n)]}
        assert len(unsure[pname]) <= 0.1 * len(fd_p), (pname, sorted(unsure[pname]))
        for name, v in fd_p.items():
            if name in unsure[pname]:
                continue
            err = abs(d[name][pname] - v) / scale[family(name)]
            worst[pname] = max(worst.get(pname, 0.0), err)
            assert err < TOL, (pname, name, d[name][pname], v)
    print("worst relative disagreement per parameter:", {k: f"{v:.1e}" for k, v in worst.items()},
          "outputs left out:", {k: sorted(v) for k, v in unsure.items()})


def test_flight_sensitivities_are_written(flight_case):
    _, result = flight_case
    rows = result.extra["tables"]["sensitivities.csv"]
    assert len(rows["output"]) == len(rows["value"]) == len(NAMES) * len(result.summary["sensitivities"]["d_output_d_parameter"])
    assert "damage_per_hour1" in rows["output"] and "del_FB_x" in rows["output"]


def test_monodromy_and_krylov_periodic_starts_agree():
    # The periodic start's sensitivity by the monodromy's direct solve (floquet on: Phi is there)
    # and by GMRES on one-revolution products (floquet off; with shooting too, whose Newton-Picard
    # keeps no whole Phi, from the orbit shooting found instead of marching's).  The three are different integrations, so they differ by integration error: at the
    # deck's rtol 1e-6 that was 4.4e-5 of the largest of a family, and a round-off change of a
    # load (the rotation springs' kernels, 2026-11-26) moved it to 1.3e-4 -- the comparison then
    # measures the integrator's path, not the periodic start.  At rtol 1e-8 (atol 1e-10) and
    # periodic_tol 1e-9 m the integration error is ~100x smaller, far below the bound; what is
    # left is what the test is about: the two ways of solving (I - Psi) s* = dX(T)/dp.
    model = Model.from_deck(INPUTS / "uh60_part2_forward_flight_cable.nml").with_changes(
        {"refinement.levels": 1, "design.parameters": ["drag.cd"], "solver.periodic_tol": 1.0e-9,
         "solver.rtol": 1.0e-8, "solver.atol": 1.0e-10})
    cases = {"floquet": {"solver.floquet": True}, "krylov": {"solver.floquet": False},
             "shooting": {"solver.floquet": False, "solver.periodic_method": "shooting"}}
    runs = {k: pydriver.run_deck(model.with_changes(c)).summary["sensitivities"] for k, c in cases.items()}
    assert [runs[k]["solver"]["periodic_start"] for k in cases] == ["monodromy", "krylov", "krylov"]
    # s(T) = s(0), relative to the start sensitivity (the integration error of one revolution):
    # measured 4.0e-7, 1.5e-13 (GMRES closes the loop by construction), 4.2e-7.
    print("periodicity residuals:", {k: f"{r['periodicity_residual']:.1e}" for k, r in runs.items()})
    assert all(r["periodicity_residual"] < 1e-5 for r in runs.values())
    ref = runs["krylov"]["d_output_d_parameter"]
    scale = {}
    for name in ref:
        scale[family(name)] = max(scale.get(family(name), 0.0), abs(ref[name]["drag.cd"]))
    for k in ("floquet", "shooting"):
        d = runs[k]["d_output_d_parameter"]
        errs = [abs(d[n]["drag.cd"] - ref[n]["drag.cd"]) / scale[family(n)] for n in ref]
        print(f"{k} against Krylov periodic start: worst relative difference {max(errs):.1e}")
        # Measured 8.2e-8 (floquet) and 7.1e-7 (shooting): the bound 1e-5 leaves a factor 14 for
        # another CPU's rounding and integration path, and is 10x inside the 1e-4.
        assert max(errs) < 1e-5, (k, max(errs))


def test_periodic_start_of_constraint_and_speed_parameters_by_monodromy_and_krylov():
    # A parameter that moves clamp B changes the constraint manifold: the start sensitivity has a
    # particular part normal to it (the core's least-norm correction G s_q = -g_p, orthogonal to
    # the monodromy's basis N), and both periodic starts must carry it; the rotor speed's right-
    # hand side carries the secular term (T/p) y'(0).  At rtol 1e-9 and periodic_tol 1e-9 m they
    # agree to the integration error of two different integrations: the monodromy's Phi comes
    # from the run's own linear solver (the chain solver at these 33 coordinates), dX(T)/dp from
    # the sensitivity integrations' (the block solver), and their errors no longer cancel.
    # Measured 1.1e-5, 2.5e-6, 7.4e-6 (clamp B's x, the length, the speed); 1.5e-6, 2.8e-7,
    # 2.0e-6 when every integration used the chain solver; 3.2e-4 and 4.1e-5 at the deck's rtol
    # 1e-6 for the first two, which shows the difference is integration error.  Against a run at
    # rtol 1e-11, the periodic start of clamp B's x alone is within 6e-7 ... 4.2e-6 by either
    # method and either solver.  Bound 1e-4: ten times the largest integration error seen.
    names = ["clamp_b.position(1)", "chain.total_length", "rotor.rpm"]
    model = Model.from_deck(INPUTS / "uh60_part2_forward_flight_cable.nml").with_changes(
        {"refinement.levels": 1, "design.parameters": names, "solver.periodic_tol": 1.0e-9, "solver.rtol": 1.0e-9,
         "solver.atol": 1.0e-11})
    runs = {k: pydriver.run_deck(model.with_changes({"solver.floquet": f})).summary["sensitivities"]
            for k, f in (("monodromy", True), ("krylov", False))}
    assert [runs[k]["solver"]["periodic_start"] for k in runs] == ["monodromy", "krylov"]
    ref, d = runs["krylov"]["d_output_d_parameter"], runs["monodromy"]["d_output_d_parameter"]
    for p in names:
        scale = {}
        for n in ref:
            scale[family(n)] = max(scale.get(family(n), 0.0), abs(ref[n][p]))
        worst = max(abs(d[n][p] - ref[n][p]) / scale[family(n)] for n in ref)
        print(f"{p}: monodromy against Krylov periodic start, worst relative difference {worst:.1e}")
        assert worst < 1e-4, (p, worst)



def test_loads_only_partials_match_whole_residual_partials():
    # A parameter that moves the loads only (the plan decides it from what was built) has its
    # F_p from the loads' generalized forces on the run's kinematics: the rebuilt models' loads
    # mapped by one backward J^T pass (rotorcable_parameter_sensitivity, loads_partial; model.f90
    # applied_generalized_forces) instead of the rebuilt models' whole residuals.  Both are the
    # same central difference of the same terms, so they agree to round-off: eps |F| / h
    # relative to F_p, with the centrifugal and inertia terms in |F| (h = eps^(1/3) |p|):
    # measured 0 (the springs, joint torques: bit for bit), 2.9e-11 and 5.1e-11 (drag), 8.2e-10
    # (gravity); bound 1e-8.
    # The springs act through joint torques, drag and gravity through forces at the CMs: the two
    # paths of the mapping.  A state a third of a revolution in, with rates, so every term is
    # alive.
    import pydriver.analyses.sensitivities as sensitivities

    names = ["cable.ei", "cable.damping_time", "drag.cd", "drag.forward_speed", "loads.gravity(3)",
             "cable.mass_per_length"]
    model = Model.from_deck(INPUTS / "uh60_part2_forward_flight_cable.nml").with_changes(
        {"refinement.levels": 1, "design.parameters": names})
    plans = sensitivities.plan(model)
    assert {pl.parameter.name: pl.loads_only for pl in plans} == {n: n != "cable.mass_per_length" for n in names}
    # Each difference takes only the load slots its parameter changes; the others cancel.
    assert list(model.description["loads"]) == ["rotation_springs", "gravity", "drag"]
    springs, gravity, drag = [True, False, False], [False, True, False], [False, False, True]
    assert {pl.parameter.name: pl.changed_loads for pl in plans[:-1]} == {
        "cable.ei": springs, "cable.damping_time": springs, "drag.cd": drag, "drag.forward_speed": drag,
        "loads.gravity(3)": gravity}
    t = 0.07                                            # a third of a revolution at 258 rpm
    rates = np.random.default_rng(24).normal(0.0, 1.0, model.nq)
    y, yd = probes.consistent_ggl_state(model.core, model.q0, model.v0 + rates, t)
    assert np.max(np.abs(y[model.nq:2 * model.nq])) > 0.1
    for pl in plans[:-1]:
        models = [None if m is None else m.core for _, _, m in pl.points]
        weights = [w for _, w, _ in pl.points]
        whole = probes.parameter_partial(model.core, models, weights, pl.h, y, yd, t)
        fast = probes.parameter_partial(model.core, models, weights, pl.h, y, yd, t, partial=PartialKind.LOADS_ONLY)
        masked = probes.parameter_partial(model.core, models, weights, pl.h, y, yd, t,
                                          partial=PartialKind.LOADS_ONLY, changed_loads=pl.changed_loads)
        err = np.max(np.abs(fast - whole)) / np.max(np.abs(whole))
        err_masked = np.max(np.abs(masked - whole)) / np.max(np.abs(whole))
        print(pl.parameter.name, f"{err:.1e} {err_masked:.1e}")
        assert np.max(np.abs(whole)) > 0.0 and err < 1e-8, (pl.parameter.name, err)
        assert err_masked < 1e-8, (pl.parameter.name, err_masked)


def test_bodies_and_loads_partials_match_whole_residual_partials():
    # A parameter whose rebuilt models keep the run's kinematics and change the bodies' masses
    # or radii (and loads) has its F_p from the rebuilt models' Newton-Euler passes on the run's
    # motion (rotorcable_parameter_sensitivity, bodies_partial; model.f90 other_bodies_residual):
    # no kinematics, constraint rows or unchanged springs per point.  Gravity reads the masses
    # and drag was built from the radii (load_term%depends_on_bodies), so they are taken although
    # their own parameters are the same.  The same central difference of the same terms as the
    # whole residuals', so they agree to round-off (eps |F| / h relative to F_p): measured
    # 1.4e-11 (the mass per length), 7.0e-13 (the diameter); bound 1e-8.  A parameter that
    # moves the geometry (the length) takes whole residuals.  A state a third of a revolution
    # in, with rates.
    import pydriver.analyses.sensitivities as sensitivities

    names = ["cable.mass_per_length", "chain.diameter", "chain.total_length"]
    model = Model.from_deck(INPUTS / "uh60_part2_forward_flight_cable.nml").with_changes(
        {"refinement.levels": 1, "design.parameters": names})
    plans = sensitivities.plan(model)
    assert {pl.parameter.name: (pl.loads_only, pl.bodies_and_loads) for pl in plans} == {
        "cable.mass_per_length": (False, True), "chain.diameter": (False, True), "chain.total_length": (False, False)}
    t = 0.07
    rates = np.random.default_rng(24).normal(0.0, 1.0, model.nq)
    y, yd = probes.consistent_ggl_state(model.core, model.q0, model.v0 + rates, t)
    for pl in plans[:2]:
        models = [None if m is None else m.core for _, _, m in pl.points]
        weights = [w for _, w, _ in pl.points]
        whole = probes.parameter_partial(model.core, models, weights, pl.h, y, yd, t)
        fast = probes.parameter_partial(model.core, models, weights, pl.h, y, yd, t,
                                        partial=PartialKind.BODIES_AND_LOADS, changed_loads=pl.changed_loads)
        err = np.max(np.abs(fast - whole)) / np.max(np.abs(whole))
        print(pl.parameter.name, f"{err:.1e}")
        assert np.max(np.abs(whole)) > 0.0 and err < 1e-8, (pl.parameter.name, err)


def test_outputs_from_the_runs_worst_points_and_used_samples(flight_case):
    # Two shortcuts of the sensitivities must not change which outputs they differentiate:
    # (1) each joint's worst point around the jacket is taken from the run's own fatigue table
    # (worst_points_of) instead of being searched again: the same rule on the same series, so
    # the same names, values and rules (exactly); (2) the outputs' derivatives difference the
    # sample function only at the samples the rules read (samples_used): every sample, extreme
    # and cycle reversal a rule reads is among them, and no other.

    model, result = flight_case
    ts = result.timeseries
    table = result.extra["tables"]["fatigue.csv"]
    points = worst_points_of(model, table)
    assert len(points) == model.n_bodies and len(set(points)) > 1   # not all at one angle
    searched, handed = HistoryOutputs(model, ts), HistoryOutputs(model, ts, worst_points=points)
    assert handed.names == searched.names and handed.values == searched.values
    used = set(searched.samples_used().tolist())
    read = set()
    for rule in searched.rules:
        read.update([rule[2]] if rule[0] == "sample" else rule[2:4] if rule[0] == "range"
                    else list(rule[2].start) + list(rule[2].end))
    assert used == read and len(used) < len(ts["t"])
    # A derivative signal that is NaN outside the used samples still gives finite outputs.
    d = searched.derivatives(lambda spec: history_signal(model, ts, spec),
                             lambda spec: np.where(np.isin(np.arange(len(ts["t"])), sorted(used)), 1.0, np.nan))
    assert np.all(np.isfinite(d))
