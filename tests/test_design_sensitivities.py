"""Design sensitivities (&design parameters; issue 24, first increment): static and modal runs.

The sensitivities come from the implicit function theorem at the converged equilibrium
(pydriver/analyses/sensitivities.py).  They are checked against

* central differences of WHOLE runs (a new Newton solve at p +- H) on the six-link static deck,
  the UH-60 part 2 static deck and the UH-60 part 2 modal deck;
* the independent maximal-coordinate reference (tests/reference_maximal.py) solved for its own
  equilibrium at L +- H (six-link reactions by the cable length).

Tolerance 1e-4 relative (issue 24).  What the comparison carries: the whole-run difference's
truncation, O(H^2) with H = 1e-5 of the parameter (measured 7e-8 of the largest UH-60 reaction
sensitivity; 7e-6 at H = 1e-4 and 7e-4 at 1e-3, so it is the reference difference's own error
falling as H^2), and the Newton solves' residual newton_tol = 1e-12 Nm over 2H (below 1e-9 of
the sensitivities here).  The sensitivities' own O(h^2) step error is ~1e-11 (pydriver.design.STEP).
Each output is compared against the largest sensitivity of its kind (forces, moments, axial,
shear, bending, torsion) for that parameter, and at least 1e-3 of the largest of all: a magnitude
that vanishes (a shear force of 0 in the symmetric six-link) has a kink there and no derivative,
and both differences carry an absolute round-off of ~eps |y|/h ~ 1e-9 of the largest output y
(measured 1.2e-9 N per m/s^2 against the largest, 7.7 N per m/s^2).
"""

from __future__ import annotations

import numpy as np
import pytest

import pydriver
import reference_maximal as ref
from conftest import INPUTS
from pydriver.analyses.common import REACTION_NAMES
from pydriver.analyses.modal import modal_analysis
from pydriver.analyses.statics import static_analysis
from pydriver.design import parameters
from pydriver.model import Model

TOL = 1.0e-4            # issue 24
H_REL = 1.0e-5          # whole-run difference step (see the module docstring)
TIGHT = {"solver.newton_tol": 1.0e-12}

SIX_LINK = ["chain.total_length", "chain.diameter", "chain.density", "loads.gravity(3)", "loads.gravity(1)"]
UH60 = ["chain.total_length", "springs.c_beta", "springs.c_gamma", "clamp_b.position(1)",
        "clamp_b.position(3)", "clamp_b.beta_deg", "chain.total_mass", "clamp_a.gamma_deg"]
UH60_MODAL = ["springs.c_beta", "chain.total_length", "clamp_b.position(3)", "chain.total_mass"]


def static_outputs(result) -> dict:
    """The outputs a static run's sensitivities cover, by their names in sensitivities.csv."""
    out = {}
    for support, r in result.summary["reactions"].items():
        for kind, values in r.items():
            for c, v in zip("xyz", values):
                out[f"{kind}{support}_{c}"] = v
    t = result.table
    for load, unit in (("axial", "N"), ("shear", "N"), ("bending", "Nm"), ("torsion", "Nm")):
        for j, v in enumerate(t[f"{load}_{unit}"]):
            out[f"{load}{j + 1}_{unit}"] = v
    return out


def kind(name: str) -> str:
    """The family an output is compared within (its scale)."""
    if name in REACTION_NAMES:
        return name[0]
    return name.rstrip("0123456789_Nm")


def whole_run_differences(model, analysis, scheme="central"):
    """d(output)/dp of every &design parameter by differences of whole runs (re-solved)."""
    out = {}
    for p in parameters(model.deck):
        h = H_REL * max(abs(p.value), 1.0)

        def at(s):          # the analysis alone: a whole run, re-solved, without sensitivities
            changes = {**p.changes(model.deck, p.value + s * h), **TIGHT}
            return analysis(model.with_changes(changes))
        if scheme == "central":
            plus, minus = at(1.0), at(-1.0)
            out[p.name] = {k: (plus[k] - minus[k]) / (2 * h) for k in plus}
        else:                                      # second-order forward: (-3 f0 + 4 f1 - f2) / 2h
            f0, f1, f2 = at(0.0), at(1.0), at(2.0)
            out[p.name] = {k: (-3 * f0[k] + 4 * f1[k] - f2[k]) / (2 * h) for k in f0}
    return out


def assert_agree(sens: dict, fd: dict):
    worst = 0.0
    for pname, fd_p in fd.items():
        scale = {}
        for name, v in fd_p.items():
            scale[kind(name)] = max(scale.get(kind(name), 0.0), abs(v))
        overall = max(scale.values())
        for name, v in fd_p.items():
            got = sens[name][pname]
            ref_scale = max(scale[kind(name)], 1e-3 * overall)
            err = abs(got - v) / ref_scale
            worst = max(worst, err)
            assert err < TOL, (pname, name, got, v)
    return worst


def run_with(stem: str, names: list) -> tuple:
    model = Model.from_deck(INPUTS / f"{stem}.nml").with_changes({"design.parameters": names, **TIGHT})
    return model, pydriver.run_deck(model)


def static_fn(m):
    return static_outputs(static_analysis(m))


@pytest.mark.parametrize("stem,names", [("six_link_static", SIX_LINK), ("uh60_part2", UH60)])
def test_static_sensitivities_match_whole_run_differences(stem, names):
    model, result = run_with(stem, names)
    sens = result.summary["sensitivities"]["d_output_d_parameter"]
    assert set(sens["FB_z"]) == set(names)
    worst = assert_agree(sens, whole_run_differences(model, static_fn))
    print(f"{stem}: worst relative disagreement {worst:.1e}")


def test_one_sided_difference_at_a_range_bound():
    # The six-link deck has no springs: c_beta = 0 is the bound of its range [0, 1e9], so the
    # sensitivity takes the second-order forward formula; checked against the same on whole runs.
    model, result = run_with("six_link_static", ["springs.c_beta"])
    assert result.summary["sensitivities"]["parameters"]["springs.c_beta"]["difference"] == "forward"
    sens = result.summary["sensitivities"]["d_output_d_parameter"]
    assert_agree(sens, whole_run_differences(model, static_fn, scheme="forward"))


def modal_frequencies(m) -> dict:
    """The first six undamped (f{k}_hz) and damped (fd{k}_hz) frequencies of a whole modal run."""
    s = modal_analysis(m).summary
    out = {f"f{k + 1}_hz": f for k, f in enumerate(s["frequencies_hz"][:6])}
    out.update({f"fd{k + 1}_hz": f for k, f in enumerate(s["damped_frequencies_hz"][:6])})
    return out


def test_modal_frequency_sensitivities_match_whole_run_differences():
    # Undamped (Fox-Kapoor) and damped (the state matrix's left and right eigenvectors) frequencies.
    model, result = run_with("uh60_part2_modal", UH60_MODAL)
    sens = result.summary["sensitivities"]["d_output_d_parameter"]
    assert "f1_hz" in sens and "fd1_hz" in sens
    fd = whole_run_differences(model, modal_frequencies)
    for pname, fd_p in fd.items():
        for name, v in fd_p.items():       # every frequency is its own scale (none is near 0)
            assert sens[name][pname] == pytest.approx(v, rel=TOL), (pname, name)


def test_damped_frequency_sensitivities_in_the_turning_hover_match_whole_run_differences():
    # The main job's cable in hover at 260 rpm (the state its design margin judges): the damped
    # roots carry the Coriolis coupling and the cable's damping (mode 1: 16.22 Hz damped, 16.37 Hz
    # undamped), so d(fd)/dp differs from d(f)/dp; the rotor speed moves the gyroscopic matrix D_r
    # itself.  Against central differences of whole modal runs of the hover state, to 1e-4.
    from pydriver.analyses.hover_modes import hover_model
    flight = Model.from_deck(INPUTS / "uh60_part2_forward_flight_cable.nml").with_changes({"refinement.levels": 1})
    model = hover_model(flight).with_changes({"design.parameters": ["chain.total_length", "clamp_b.position(1)",
                                                                     "cable.ei", "rotor.rpm"], **TIGHT})
    sens = pydriver.run_deck(model).summary["sensitivities"]["d_output_d_parameter"]
    fd = whole_run_differences(model, modal_frequencies)
    worst = 0.0
    for pname, fd_p in fd.items():
        for name, v in fd_p.items():
            if name.startswith("fd"):
                worst = max(worst, abs(sens[name][pname] - v) / abs(v))
                assert sens[name][pname] == pytest.approx(v, rel=TOL), (pname, name)
    print(f"hover damped frequencies: worst relative disagreement {worst:.1e}")


# -- (b) the maximal-coordinate reference ------------------------------------------------------
def reference_reactions(length: float) -> tuple[float, float]:
    """F_B,z and M_A,y of the six-link chain (inputs/six_link_static.nml) at total length L,
    from the reference's own equilibrium: Newton on (residual, clamp) = 0 in the reference's
    coordinates with a central-difference Jacobian of the reference, B held where the start shape
    puts it (the deck's from_start), then the maximal system's reactions."""
    n, d, rho = 5, 0.05, 7801.0
    L = np.full(n, length / n)
    R = np.full(n, d / 2)
    m = rho * np.pi * R**2 * L
    gamma = np.radians([0.0, 0.0, 90.0, 0.0, 90.0])
    beta = np.radians([90.0, 90.0, 90.0, 90.0, -90.0])
    locked = np.array([True] + [False] * (n - 1))
    q0 = np.column_stack([gamma, beta])[1:].reshape(-1)
    common = dict(L=L, R=R, m=m, locked=locked, locked_angles=np.column_stack([gamma, beta]),
                  c=np.zeros((n, 2)), d=np.zeros((n, 2)), rest=np.zeros((n, 2)), clamp_B=True)
    pose = ref._poses(ref.ChainModel(**common), q0, 0.0)
    tip, rot = np.asarray(pose["P"][-1], float), np.asarray(pose["R"][-1], float)
    model = ref.ChainModel(**common, clamp_position=tip, clamp_rotation=rot)
    zero = np.zeros(model.nq)

    def eqs(x):
        q, lam = x[:model.nq], x[model.nq:]
        return np.concatenate([ref.residual(model, q, zero, zero, lam), ref.constraint(model, q)])
    x = np.concatenate([q0, np.zeros(6)])
    for _ in range(30):
        r = eqs(x)
        if np.abs(r).max() < 1e-12:
            break
        jac = np.column_stack([(eqs(x + e) - eqs(x - e)) / 2e-7 for e in np.eye(x.size) * 1e-7])
        x = x - np.linalg.lstsq(jac, r, rcond=None)[0]
    sol = ref.solve_accelerations(model, x[:model.nq], zero)
    return float(sol["F_B"][2]), float(sol["M_A"][1])


def test_six_link_length_sensitivity_matches_maximal_reference():
    _, result = run_with("six_link_static", ["chain.total_length"])
    sens = result.summary["sensitivities"]["d_output_d_parameter"]
    h = 1e-4
    plus, minus = reference_reactions(1.0 + h), reference_reactions(1.0 - h)
    d_fb = (plus[0] - minus[0]) / (2 * h)
    d_ma = (plus[1] - minus[1]) / (2 * h)
    # F_B grows with the mass (F_B = 2.5 rho pi d^2/4 L/5 g, eq. 4.112): 75.13 N per metre.
    assert d_fb == pytest.approx(75.131, rel=1e-4)
    assert sens["FB_z"]["chain.total_length"] == pytest.approx(d_fb, rel=TOL)
    assert sens["MA_y"]["chain.total_length"] == pytest.approx(d_ma, rel=TOL)


# -- files --------------------------------------------------------------------------------------
def test_sensitivities_file_and_summary(tmp_path):
    model = Model.from_deck(INPUTS / "six_link_static.nml").with_changes(
        {"design.parameters": ["chain.total_length"]})
    result = pydriver.run_deck(model, out=tmp_path / "out", report=True)   # the report lists the names
    text = (tmp_path / "out" / "sensitivities.csv").read_text().splitlines()
    assert text[0] == "output [-],parameter [-],value [*],unit [-]"
    row = next(r for r in text[1:] if r.startswith("FB_z,"))
    name, param, value, unit = row.split(",")
    assert param == "chain.total_length" and unit == "N/m"
    assert float(value) == pytest.approx(75.131, rel=1e-4)
    s = result.summary["sensitivities"]
    assert s["units"]["MA_y"]["chain.total_length"] == "Nm/m"
    assert s["parameters"]["chain.total_length"]["difference"] == "central"


# -- (c) bad input -------------------------------------------------------------------------------
@pytest.mark.parametrize("value,reason", [
    ("'chain.lenght'", "has no key"),
    ("'solver.rtol'", "not differentiable"),
    ("'shape.gamma_deg(2)'", "not differentiable"),
    ("'nosuch.key'", "no group"),
    ("'total_length'", "not a key name"),
    ("1.0", "not a string"),
    ("", "value"),
    ("''", "not a key name"),
    ("'chain.total_length(2)'", "not an array"),
    ("'loads.gravity(4)'", "out of range"),
    ("'loads.gravity'", "name one element"),
    ("'clamp_b.position(1)'", "from_start"),
    ("'chain.total_mass'", "no value"),
    ("'chain.density', 'chain.density'", "twice"),
])
def test_bad_design_input_names_group_and_key(deck_copy, value, reason):
    path = deck_copy("six_link_static")
    path.write_text(path.read_text() + f"\n&design\n  parameters = {value}\n/\n")
    with pytest.raises(pydriver.DeckError) as err:
        pydriver.run_deck(path)
    assert (err.value.group, err.value.key) == ("design", "parameters"), str(err.value)
    assert reason in err.value.reason, str(err.value)


def test_design_refused_for_analyses_without_sensitivities(deck_copy):
    path = deck_copy("uh60_part2_campbell")
    path.write_text(path.read_text() + "\n&design\n  parameters = 'chain.total_length'\n/\n")
    with pytest.raises(pydriver.DeckError) as err:
        pydriver.run_deck(path)
    assert (err.value.group, err.value.key) == ("design", "parameters")
    assert "not 'campbell'" in err.value.reason
