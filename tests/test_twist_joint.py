"""The Cardan bending + twist joint (``&chain joint = 'xyz'``, issue 4: the thesis's outlook,
chapter 6): R_rel = Rx(phi) Ry(theta) Rz(psi), with a torsion spring c_twist on psi.

Its joint axes and bias accelerations are new code, so they are checked against what they
must be derivatives of (finite differences of g(q), which uses only the rotations), against
the Jourdain mass matrix, against energy conservation, and against the two-angle Cardan joint
it must become when the twist spring is stiff."""

from __future__ import annotations

import numpy as np
import pytest

import pydriver
from pydriver import core_probes as probes
from conftest import INPUTS
from pydriver.study import override_deck

RNG = np.random.default_rng(6)


def xyz_deck(tmp_path, stem, name, **groups):
    changes = {"chain": {"joint": "'xyz'"}, "springs": {"c_gamma": "0.0", "d_gamma": "0.0",
                                                        "c_twist": "2.0"}}
    for group, keys in groups.items():
        changes.setdefault(group, {}).update(keys)
    return str(override_deck(INPUTS / f"{stem}.nml", tmp_path / f"{name}.nml", changes))


def rel_err(a, b):
    return np.max(np.abs(np.asarray(a) - np.asarray(b))) / max(np.max(np.abs(b)), 1e-300)


@pytest.fixture(scope="module")
def closed_xyz(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("xyz")
    return xyz_deck(tmp, "six_link_dynamic", "closed",
                    springs={"c_beta": "5.0", "d_beta": "0.25", "d_twist": "0.1"})


def test_three_coordinates_per_free_joint(closed_xyz):
    info = pydriver.deck_info(closed_xyz)
    assert info["n_coords"] == 3 * (info["n_bodies"] - 1)      # body 1 clamped


def test_axes_and_bias_against_finite_differences(closed_xyz):
    """G from the joint axes against central differences of g(q) (positions and rotations
    only), and Gdot v (the bias accelerations) against d/dt (G v).  Same tolerances as the
    thesis joint's test in test_model_kernels: truncation ~1e-12, round-off ~1e-10."""
    nq = pydriver.deck_info(closed_xyz)["n_coords"]
    h = 1e-6
    for _ in range(3):
        q = RNG.uniform(-np.pi, np.pi, nq)
        v = RNG.normal(0, 2, nq)
        e = probes.evaluate_model(closed_xyz, q, v)
        fd = np.column_stack([(probes.evaluate_model(closed_xyz, q + h * ei)["g"]
                               - probes.evaluate_model(closed_xyz, q - h * ei)["g"]) / (2 * h)
                              for ei in np.eye(nq)])
        assert np.max(np.abs(e["G"] - fd)) < 1e-8
        gp = probes.evaluate_model(closed_xyz, q + h * v)["G"]
        gm = probes.evaluate_model(closed_xyz, q - h * v)["G"]
        fd_bias = (gp - gm) @ v / (2 * h)
        assert np.max(np.abs(e["Gdot_v"] - fd_bias)) < 1e-7 * max(1.0, np.max(np.abs(fd_bias)))


def test_mass_matrix_and_inverse_dynamics(closed_xyz):
    """CRBA against the Jourdain form (1e-12: same sums in another order), symmetric and
    positive definite; the O(n) residual equals M vdot - k - G^T lambda (1e-10)."""
    nq = pydriver.deck_info(closed_xyz)["n_coords"]
    for _ in range(4):
        q, v, vdot, lam = (RNG.uniform(-3, 3, nq), RNG.normal(0, 2, nq), RNG.normal(0, 20, nq),
                           RNG.normal(0, 50, 6))
        e = probes.evaluate_model(closed_xyz, q, v, vdot, lam)
        assert rel_err(e["M"], e["M_jourdain"]) < 1e-12
        assert rel_err(e["M"], e["M"].T) < 1e-14
        assert np.linalg.eigvalsh(e["M"]).min() > 0.0
        assert rel_err(e["residual"], e["M"] @ vdot - e["k"] - e["G"].T @ lam) < 1e-10


def test_energy_is_conserved_without_dampers(tmp_path):
    """The three-body pendulum with twisting joints (soft twist spring, no dampers) swinging
    in 3-D at rtol 1e-10: energy drift < 1e-8 relative (measured 1.3e-12); a wrong bias or
    axis term would show at the 1e-2 level.

    The scene stays far from the Cardan singularity (|cos theta| >= 0.5 is asserted; measured
    0.86): the six-link shapes have right-angle kinks, i.e. theta = +-90 deg, where the
    joint rates grow without bound and the energy drift jumps by amounts that depend on the
    CPU's floating-point paths (1e-6 on AMD EPYC, issue 10)."""
    p = xyz_deck(tmp_path, "three_body", "energy",
                 shape={"gamma_deg": "90.0, 20.0, -30.0", "beta_deg": "153.0, 25.0, 20.0"},
                 springs={"c_twist": "0.5", "d_beta": "0.0", "d_twist": "0.0",
                          "rest_gamma_deg": "3*0.0", "rest_beta_deg": "3*0.0"},
                 solver={"rtol": "1.0e-10", "atol": "1.0e-12"})
    res = pydriver.run_deck(p)
    theta = res.extra["q"][:, 1::3]
    assert np.min(np.abs(np.cos(theta))) > 0.5
    assert np.ptp(res.extra["q"][:, 2::3]) > 1e-5     # the twist coordinate moves (5e-4 rad)
    e = res.extra["energy"]
    assert np.max(np.abs(e - e[0])) / abs(e[0]) < 1e-8
    assert np.ptp(res.timeseries["z3"]) > 1e-2


def test_cardan_singularity_is_named_when_a_run_fails(tmp_path):
    """The undamped six-link swing with Cardan joints runs into theta = +-90 deg (its shape has
    right-angle kinks).  Wherever the step size collapses, the error must say which joint and
    why, not only IDA's generic flag.  If a CPU's arithmetic carries it through, the run must
    not claim more than it did: then the answer is finite and the constraint holds."""
    p = override_deck(INPUTS / "six_link_dynamic.nml", tmp_path / "xy.nml", {
        "chain": {"joint": "'xy'"}, "springs": {"c_gamma": "0.0", "d_gamma": "0.0", "d_beta": "0.0"}})
    try:
        res = pydriver.run_deck(p)
    except pydriver.RunError as exc:
        assert "theta = +-90 deg" in str(exc) and "joint" in str(exc)
    else:
        assert np.all(np.isfinite(res.extra["q"]))
        assert res.summary["max_constraint_violation_m"] < 1e-6


@pytest.mark.parametrize("c_twist", ["1.0e-2", "1.0e6"])
def test_untwisted_load_gives_the_two_angle_cardan_shape(tmp_path, c_twist):
    """A clamped cantilever under an oblique tip force bends in both planes but is not
    twisted by it, so at any twist stiffness the xyz chain takes the xy chain's shape (to
    Newton's tolerance, 1e-10 relative; measured 4e-15 m)."""
    load = {"case": {"analysis": "'static'"}, "loads": {"tip_force": "0.0, 2.0e-2, 3.0e-2"}}
    xy = pydriver.run_deck(str(override_deck(INPUTS / "cantilever_check.nml", tmp_path / "xy.nml", {
        **load, "chain": {"first_body": "'clamped'", "joint": "'xy'"},
        "springs": {"c_gamma": "0.0", "rest_beta_deg": "11*0.0"}})))
    xyz = pydriver.run_deck(xyz_deck(tmp_path, "cantilever_check", "xyz", **load,
                                     chain={"first_body": "'clamped'"},
                                     springs={"c_twist": c_twist, "rest_beta_deg": "11*0.0"}))
    assert abs(xy.table["y_m"][-1]) > 1e-3 and abs(xy.table["z_m"][-1]) > 1e-3   # both planes bent
    for key in ("x_m", "y_m", "z_m"):
        assert np.max(np.abs(xyz.table[key] - xy.table[key])) < 1e-9


def test_stiff_twist_limit_and_soft_twist_in_the_closed_cable(tmp_path):
    """UH-60 part 2 between its clamps, where the clamps impose a twist.

    * c_twist = 1e6 Nm/rad: the equilibrium is one of the xy joint's (which cannot twist):
      the xy chain started from it stays there (Newton converges at once) and differs only
      by the twist compliance, ~|M| / c_twist = 4e-5 rad (measured 1.6e-5 m; bound 1e-4 m).
      The closed cable has several equilibria: the xy chain started from the deck's shape
      finds another one, 10 cm away with |M_B| ~ 100 Nm (docs/model.md).
    * c_twist = 1e-4 (the thesis's c_z): the cable untwists and moves by centimetres, i.e.
      the twist coordinate is really there."""
    stiff = pydriver.run_deck(xyz_deck(tmp_path, "uh60_part2", "stiff", springs={"c_twist": "1.0e6"}))
    soft = pydriver.run_deck(xyz_deck(tmp_path, "uh60_part2", "soft", springs={"c_twist": "1.0e-4"}))
    fmt = ", ".join
    xy = pydriver.run_deck(str(override_deck(INPUTS / "uh60_part2.nml", tmp_path / "xy.nml", {
        "chain": {"joint": "'xy'"}, "springs": {"c_gamma": "0.0", "d_gamma": "0.0"},
        "shape": {"gamma_deg": fmt(f"{x:.12f}" for x in stiff.table["gamma_deg"]),
                  "beta_deg": fmt(f"{x:.12f}" for x in stiff.table["beta_deg"])}})))
    assert xy.summary["solver"]["newton_iterations"] <= 3
    for key in ("x_m", "y_m", "z_m"):
        assert np.max(np.abs(stiff.table[key] - xy.table[key])) < 1e-4
    moved = max(np.max(np.abs(soft.table[k] - stiff.table[k])) for k in ("x_m", "y_m", "z_m"))
    assert moved > 1e-2


@pytest.mark.parametrize("changes,key,words", [
    ({"chain": {"joint": "'xyz'"}, "springs": {"c_gamma": "0.0", "d_gamma": "0.0"}}, "c_twist", "required"),
    ({"springs": {"c_twist": "1.0"}}, "c_twist", "xyz"),
])
def test_twist_spring_errors(tmp_path, changes, key, words):
    p = override_deck(INPUTS / "six_link_dynamic.nml", tmp_path / "bad.nml", changes)
    with pytest.raises(pydriver.DeckError) as exc:
        pydriver.run_deck(p)
    assert exc.value.key == key and words in str(exc.value)
