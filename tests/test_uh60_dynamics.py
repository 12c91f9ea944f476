"""UH-60 part 2: natural frequency two ways, Figure 5.9, refinement, settling, cantilever.

Reference numbers from the thesis are in tests/data/thesis_appendix_A.json ("5.4").
"""

import json

import numpy as np
import pytest

import pydriver
from pydriver.output_columns import bare_name
from conftest import DATA, INPUTS
from pydriver.study import (cy_at_frequency, frequency_vs_cy, observed_order, override_deck,
                            refined_changes)

REF = json.loads((DATA / "thesis_appendix_A.json").read_text())["5.4"]


@pytest.fixture(scope="module")
def modal():
    return pydriver.run_deck(INPUTS / "uh60_part2_modal.nml").summary


@pytest.fixture(scope="module")
def decay():
    return pydriver.run_deck(INPUTS / "uh60_part2_decay.nml")


def test_first_frequency_modal_and_decay(modal, decay):
    f_modal = modal["damped_frequencies_hz"][0]
    d = decay.summary["decay"]
    f_decay = d["f_damped_hz"]
    # The thesis reads 26.32 Hz off four periods of its decay signal: 0.1 Hz (issue 3).
    assert f_modal == pytest.approx(REF["f_damped_part2_Hz"], abs=0.1)
    assert f_decay == pytest.approx(REF["f_damped_part2_Hz"], abs=0.1)
    # Two independent routes (eigenvalues of the linearisation / zero crossings of a
    # nonlinear time integration): 0.5 % (issue 3); measured 1e-5.
    assert f_decay == pytest.approx(f_modal, rel=5e-3)
    # Damping ratio from the logarithmic decrement against the eigenvalue's: 5 %.
    assert d["zeta"] == pytest.approx(modal["damping_ratios"][0], rel=0.05)
    # Undamped, damped and zeta are all reported; the light damping moves f by < 1 %.
    assert modal["frequencies_hz"][0] == pytest.approx(f_modal, rel=0.01)
    assert 0.0 < modal["damping_ratios"][0] < 0.1
    assert decay.summary["max_constraint_violation_m"] < 1e-9


def test_modes_file(tmp_path):
    res = pydriver.run_deck(INPUTS / "uh60_part2_modal.nml", out=tmp_path)
    header = [bare_name(c) for c in (tmp_path / "modes.csv").open().readline().strip().split(",")]
    assert header[:4] == ["mode", "f_undamped_hz", "f_damped_hz", "zeta"]
    assert header[4:7] == ["dx1", "dy1", "dz1"] and len(header) == 4 + 3 * 11
    data = np.loadtxt(tmp_path / "modes.csv", delimiter=",", skiprows=1)
    assert data.shape[0] == res.summary["n_coords"] - res.summary["n_constraints"]
    assert np.all(np.diff(data[:, 1]) >= 0)                  # ascending undamped frequencies
    # Clamped bodies do not move in any mode.  Shapes are central differences of the CM
    # positions along each mode, scaled to a largest component of 1: round-off ~eps/h
    # (h = 1e-6) amplified by that scaling in twist-dominated modes stays below 1e-5.
    assert np.max(np.abs(data[:, 4:7])) < 1e-9 and np.max(np.abs(data[:, -3:])) < 1e-5


def test_frequency_against_cy_figure_5_9():
    c = np.array([1.0, 5.0, 10.0, 20.0, 35.531, 50.0, 70.0])
    res = frequency_vs_cy(INPUTS / "uh60_part2_modal.nml", c)
    f = res["f_damped_hz"]
    assert np.all(np.diff(f) > 0)                            # stiffer cable, higher frequency
    # Nearly f ~ sqrt(c_y): the bending of the installed cable is forced by the clamps.
    assert f[-1] / f[2] == pytest.approx(np.sqrt(7.0), rel=0.05)
    # Where the first frequency meets the 4.33 Hz flap frequency (our model, not the text):
    c_cross = cy_at_frequency(INPUTS / "uh60_part2_modal.nml", REF["flap_frequency_Hz"], 0.5, 5.0)
    f_cross = frequency_vs_cy(INPUTS / "uh60_part2_modal.nml", [c_cross])["f_damped_hz"][0]
    assert f_cross == pytest.approx(REF["flap_frequency_Hz"], abs=0.01)
    assert 0.8 < c_cross < 1.2
    # The thesis reads about 8 Nm/rad off its Figure 5.9; with its own 26.32 Hz at 35.53 and
    # f ~ sqrt(c_y) that would be 12.5 Hz, which is what this model gives (docs/model.md).
    assert frequency_vs_cy(INPUTS / "uh60_part2_modal.nml", [REF["c_y_min_read_from_fig_5_9_Nm_per_rad"]])[
        "f_damped_hz"][0] == pytest.approx(26.32 * np.sqrt(8.0 / 35.53), rel=0.05)


def test_refinement_converges(tmp_path):
    ns = [11, 22, 44, 88]
    f = []
    for n in ns:
        changes = refined_changes(n, 11, 35.531, 1e-4, 0.05, 1e-4, (90.0, 70.0), 12.0, 90.0)
        p = override_deck(INPUTS / "uh60_part2_modal.nml", tmp_path / f"n{n}.nml", changes)
        f.append(pydriver.run_deck(p).summary["frequencies_hz"][0])
    diffs = np.abs(np.diff(f))
    assert np.all(diffs[1:] < 0.5 * diffs[:-1])             # the corrections shrink geometrically
    order = observed_order(1.0 / np.array(ns), f)
    assert order > 1.0
    print(f"first frequency n={ns}: {np.round(f, 3)} Hz, observed order {order:.2f}")


def test_cantilever_converges_to_euler_bernoulli(tmp_path):
    ei, length, mass, force = REF["EI_Nm2"], 0.59, 0.313, 1.0e-3
    f_eb = 1.8751040687**2 / (2 * np.pi) * np.sqrt(ei / (mass / length * length**4))
    d_eb = force * length**3 / (3 * ei)
    errs_f, errs_d = [], []
    for n in (11, 22, 44, 88):
        ell = length / n
        p = override_deck(INPUTS / "cantilever_check.nml", tmp_path / f"c{n}.nml", {
            "chain": {"n_bodies": str(n)},
            "shape": {"gamma_deg": f"0.0, {n - 1}*0.0", "beta_deg": f"90.0, {n - 1}*0.0"},
            "springs": {"c_beta": repr(ei / ell), "c_gamma": repr(ei / 1.3 / ell),
                        "rest_beta_deg": f"90.0, {n - 1}*0.0"}})
        res = pydriver.run_deck(p)
        tip = pydriver.shape(p, res.extra["q"])["joints"][-1]
        errs_f.append(res.summary["frequencies_hz"][0] / f_eb - 1)
        errs_d.append(-tip[2] / d_eb - 1 if force < 0 else tip[2] / d_eb - 1)
    errs_f, errs_d = np.abs(errs_f), np.abs(errs_d)
    # Rigid segments with joint springs converge at first order in 1/n: every doubling
    # halves the error (ratio 2 +- 0.3), and at n = 88 both are within 2 %.
    assert np.all(np.abs(errs_f[:-1] / errs_f[1:] - 2) < 0.3)
    assert np.all(np.abs(errs_d[:-1] / errs_d[1:] - 2) < 0.3)
    assert errs_f[-1] < 0.02 and errs_d[-1] < 0.02
    # Discrete theory for the deflection: 1 + 3/(2n) + 1/(2n^2) (springs at 0, l, ..., (n-1) l).
    assert errs_d[0] == pytest.approx(3 / 22 + 1 / (2 * 121), rel=0.02)


def test_dynamic_settling_agrees_with_newton(tmp_path):
    # The thesis's own route (section 5.3): damped dynamics until the velocity vanishes.
    a = pydriver.run_deck(INPUTS / "uh60_part1.nml")
    p = override_deck(INPUTS / "uh60_part1.nml", tmp_path / "settle.nml",
                      {"solver": {"static_method": "'settle'", "t_end": "3.0", "dt_out": "0.01",
                                  "settle_tol": "1.0e-5"}})
    b = pydriver.run_deck(p)
    assert b.summary["solver"]["steps"] > 100                  # IDA steps, not Newton
    for k in ("x_m", "y_m", "z_m"):
        assert np.max(np.abs(a.table[k] - b.table[k])) < 1e-6  # issue 3: 1e-6 m
