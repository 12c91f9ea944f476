"""UH-60 cable: rest and hover shapes against the thesis's appendix Tables A.3-A.6."""

import numpy as np
import pytest

import pydriver
from conftest import INPUTS
from thesis_tables import bending_vectors, canonical_angles, thesis_table

CASES = {
    # deck: (table, CM tolerance [m], angle tolerance [deg])
    # Static: the thesis prints 4 decimals (0.05 mm rounding) after an ODE settling run;
    # 0.15 mm / 0.02 deg as the issue states.
    "uh60_part1": ("A.3", 0.15e-3, 0.02),
    "uh60_part2": ("A.4", 0.15e-3, 0.02),
    # Hover: the thesis's hover tables miss their own end clamp by ~1 mm (its ODE drifted),
    # so 1.2 mm / 0.4 deg (issue 3).
    "uh60_part1_hover": ("A.5", 1.2e-3, 0.4),
    "uh60_part2_hover": ("A.6", 1.2e-3, 0.4),
}


@pytest.fixture(scope="module", params=sorted(CASES))
def case(request):
    deck = request.param
    return deck, pydriver.run_deck(INPUTS / f"{deck}.nml"), CASES[deck]


def test_centres_of_mass(case):
    deck, res, (table, tol_cm, _) = case
    ref = thesis_table(table)
    t = res.table
    ours = np.column_stack([t["x_m"], t["y_m"], t["z_m"]])
    assert ours.shape == ref[:, 3:].shape
    assert np.max(np.abs(ours - ref[:, 3:])) < tol_cm


def test_angles_as_orientations(case):
    deck, res, (table, _, tol_deg) = case
    ref = thesis_table(table)
    _, beta_ours = canonical_angles(res.table["gamma_deg"], res.table["beta_deg"])
    _, beta_ref = canonical_angles(ref[:, 1], ref[:, 2])
    assert np.max(np.abs(beta_ours - beta_ref)) < tol_deg
    # The bend of every joint as a rotation vector (direction gamma and size beta) agrees
    # too; this compares gamma wherever it has a meaning (beta not ~0).
    bend = np.abs(bending_vectors(res.table["gamma_deg"], res.table["beta_deg"])
                  - bending_vectors(ref[:, 1], ref[:, 2]))
    assert np.max(bend) < max(tol_deg, 0.05)


def test_half_turn_pairs_are_the_same_orientation():
    # Table A.5 prints gamma = 180.01, beta = -10.97 for body 2: canonically (0.01, 10.97).
    ref = thesis_table("A.5")
    g, b = canonical_angles(ref[:, 1], ref[:, 2])
    assert g[1] == pytest.approx(0.01, abs=1e-9) and b[1] == pytest.approx(10.97)
    assert np.all(np.abs(g) <= 90.0)


def clamp_cm(deck_table):
    """CM of the last body implied by the clamp of Table A.1/A.2 (position and orientation)."""
    from thesis_tables import thesis_table as _  # noqa: F401 (same data file)
    import json
    from conftest import DATA
    a = json.loads((DATA / "thesis_appendix_A.json").read_text())[deck_table]
    g, b = np.radians([a["last_gamma_deg"], a["last_beta_deg"]])
    axis = np.array([np.cos(g) * np.sin(b), np.sin(g) * np.sin(b), np.cos(b)])
    half = a["total_length_m"] / a["n_bodies"] / 2
    return np.array(a["clamp_position_m"]) - half * axis


@pytest.mark.parametrize("deck,params,table", [("uh60_part1_hover", "A.1", "A.5"),
                                               ("uh60_part2_hover", "A.2", "A.6")])
def test_clamp_is_met_here_but_not_in_the_thesis_hover_tables(deck, params, table):
    res = pydriver.run_deck(INPUTS / f"{deck}.nml")
    assert res.summary["max_constraint_violation_m"] < 1e-9
    want = clamp_cm(params)
    ours = np.array([res.table[k][-1] for k in ("x_m", "y_m", "z_m")])
    assert np.linalg.norm(ours - want) < 1e-9
    # The thesis's last body sits about 1 mm away from where its own clamp puts it.
    thesis_last = thesis_table(table)[-1, 3:]
    assert 0.5e-3 < np.linalg.norm(thesis_last - want) < 1.5e-3


def test_static_shape_is_insensitive_to_the_two_printed_c_y(deck_copy):
    # Table A.1 lists c_y = 40.449, the caption of Table A.3 40.40: the rest shape moves by
    # less than 1 micrometre between them (docs/model.md), so the table cannot decide.
    a = pydriver.run_deck(INPUTS / "uh60_part1.nml").table
    b = pydriver.run_deck(deck_copy("uh60_part1", "springs", {"c_beta": "40.40"})).table
    for k in ("x_m", "y_m", "z_m"):
        assert np.max(np.abs(a[k] - b[k])) < 1e-6
