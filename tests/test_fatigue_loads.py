"""Fatigue of a run per joint (issue 13): the signed joint components the core samples, the
critical-plane counting around the jacket against closed forms, and the flight deck's outputs.

The counting and Miner sum themselves are checked in tests/test_fatigue.py (ASTM E1049
example, sine closed form); here what the run adds on top of them."""

from __future__ import annotations

import csv

import numpy as np
import pytest

import pydriver
from conftest import INPUTS
from pydriver.analyses.fatigue_loads import circumferential_histories, fatigue_of_run
from pydriver.deckfile import deck_from_text, read_deck
from pydriver.errors import DeckError
from pydriver.output_columns import bare_name

FF = INPUTS / "uh60_part2_forward_flight.nml"


@pytest.fixture(scope="module")
def flight(tmp_path_factory):
    out = tmp_path_factory.mktemp("ff") / "run"
    return pydriver.run_deck(FF, out=out, plots=True), out


def test_signed_components_match_the_joint_geometry(flight):
    """|bend vector| is the angle between successive bodies, computed here from the joint
    points alone (no body frames); |moment_xy| is the bending moment's magnitude.  Round-off
    of unit vectors and acos near small angles: 1e-9 rad and 1e-9 relative."""
    res, _ = flight
    ts = res.timeseries
    pts = res.extra["shape_joints"]                            # (3, n + 1, samples)
    model = pydriver.Model.from_deck(FF)
    e = np.diff(pts, axis=1)
    e /= np.linalg.norm(e, axis=0)
    from pydriver.analyses.common import joint_geometry
    ell = joint_geometry(model)["length"]
    for j in range(1, model.n_bodies):                         # joint j + 1 between bodies j, j + 1
        angle = np.arctan2(np.linalg.norm(np.cross(e[:, j - 1], e[:, j], axis=0), axis=0),
                           np.sum(e[:, j - 1] * e[:, j], axis=0))
        kappa = np.hypot(ts[f"kappa_x{j + 1}_1pm"], ts[f"kappa_y{j + 1}_1pm"])
        assert np.max(np.abs(kappa * ell[j] - angle)) < 1e-9
        m = np.hypot(ts[f"moment_x{j + 1}_Nm"], ts[f"moment_y{j + 1}_Nm"])
        assert np.max(np.abs(m - ts[f"bending{j + 1}_Nm"])) <= 1e-9 * np.max(ts[f"bending{j + 1}_Nm"])


def test_the_worst_point_around_the_jacket_carries_the_strain_magnitude(flight):
    """max over the circumference of eps(phi) = r (kx sin phi - ky cos phi) is r |kappa|: with
    3600 points to within 1 - cos(0.05 deg) = 3.8e-7 relative, at every sample and joint."""
    res, _ = flight
    ts = res.timeseries
    model = pydriver.Model.from_deck(FF)
    from pydriver.analyses.common import joint_geometry
    r = 0.5 * joint_geometry(model)["diameter"]
    for j in (2, 6, 11):
        _, hist = circumferential_histories(ts, j, "strain", r[j - 1], 3600)
        worst = hist.max(axis=0)
        assert np.allclose(worst, ts[f"strain{j}"], rtol=4e-7, atol=0.0)


def _synthetic(kx, ky, sn="sn_exponent = 5.0, sn_reference_amplitude = 1.0e-2, sn_reference_cycles = 1.0e6"):
    """A small flight model and a time series whose joint 2 has the given curvature history
    (one rotor revolution); every other joint is still."""
    model = pydriver.Model(deck_from_text(f"""&case analysis = 'flight' /
&chain n_bodies = 3, total_length = 0.3, diameter = 0.01, total_mass = 0.1, joint = 'xy' /
&shape gamma_deg = 0.0, beta_deg = 0.0 /
&springs c_beta = 1.0 /
&rotor rpm = 300.0 /
&fatigue {sn} /""", "synthetic.nml"))
    nt = len(kx)
    ts = {"t": np.linspace(0.0, 0.2, nt)}
    for j in range(1, 4):
        for name in ("kappa_x", "kappa_y"):
            ts[f"{name}{j}_1pm"] = np.zeros(nt)
        for name in ("moment_x", "moment_y", "bending", "torsion"):
            ts[f"{name}{j}_Nm"] = np.zeros(nt)
        ts[f"axial{j}_N"] = np.zeros(nt)
        ts[f"strain{j}"] = np.zeros(nt)
    ts["kappa_x2_1pm"], ts["kappa_y2_1pm"] = kx, ky
    ts["strain2"] = 0.005 * np.hypot(kx, ky)
    for name in ("FA_x", "FA_y", "FA_z", "MA_x", "MA_y", "MA_z"):
        ts[name] = np.zeros(nt)
    return model, ts


def test_one_plane_bending_sine_against_the_closed_form():
    """kappa_x = A sin(wt) over one revolution: one cycle of strain amplitude r A at the point
    phi = 90 deg (a point of the 24), damage per hour = 60 rpm (r A / S_ref)^m / N_ref; the
    DEL (1/rev) is r A.  Float round-off only: 1e-12."""
    a, r = 2.0, 0.005
    phase = np.linspace(0.0, 2.0 * np.pi, 361)
    model, ts = _synthetic(a * np.sin(phase), np.zeros_like(phase))
    summary, columns = fatigue_of_run(model, ts, periodic=True)
    top = summary["hotspots"][0]
    expected = 300.0 * 60.0 * (r * a / 1.0e-2) ** 5 / 1.0e6
    assert top["joint"] == 2
    assert top["damage_per_hour"] == pytest.approx(expected, rel=1e-12)
    assert top["life_hours"] == pytest.approx(1.0 / expected, rel=1e-12)
    assert top["del_amplitude"] == pytest.approx(r * a, rel=1e-12)
    assert columns["life_hours"][0] is None and columns["life_hours"][2] is None    # still joints


def test_a_rotating_bending_plane_is_a_full_cycle_that_a_magnitude_misses():
    """kappa = A (cos wt, sin wt): the magnitude is constant (no cycle), yet every fibre goes
    from +r A to -r A once per revolution.  The critical-plane count gives exactly the
    one-plane sine's damage (same amplitude at every point); counting |kappa| would give 0."""
    a, r = 2.0, 0.005
    phase = np.linspace(0.0, 2.0 * np.pi, 361)
    model, ts = _synthetic(a * np.cos(phase), a * np.sin(phase))
    summary, _ = fatigue_of_run(model, ts, periodic=True)
    expected = 300.0 * 60.0 * (r * a / 1.0e-2) ** 5 / 1.0e6
    assert summary["hotspots"][0]["damage_per_hour"] == pytest.approx(expected, rel=1e-9)
    from pydriver import fatigue
    from pydriver.analyses.fatigue_loads import sn_curve
    # The magnitude only wobbles by round-off (ranges ~1e-18): no damage to speak of.
    magnitude = fatigue.miner_damage(fatigue.cycles(ts["strain2"], periodic=True), sn_curve(model.deck))
    assert magnitude * 300.0 * 60.0 < 1e-50 * expected


def test_flight_deck_writes_a_ranked_fatigue_table(flight):
    """fatigue.csv: one row per joint with arc length, damage, life (empty where there is no
    damage), DEL and envelopes; hotspots ranked by damage; envelopes.png written."""
    res, out = flight
    f = res.summary["fatigue"]
    damage = [h["damage_per_hour"] for h in f["hotspots"]]
    assert damage == sorted(damage, reverse=True) and damage[0] > 0.0
    rows = [{bare_name(k): v for k, v in r.items()} for r in csv.DictReader(open(out / "fatigue.csv"))]
    assert len(rows) == res.summary["n_bodies"]
    worst = max(rows, key=lambda row: float(row["damage_per_hour"]))
    assert int(worst["joint"]) == f["hotspots"][0]["joint"]
    for row in rows:
        if float(row["damage_per_hour"]) > 0:
            assert float(row["life_hours"]) == pytest.approx(1.0 / float(row["damage_per_hour"]), rel=1e-12)
        assert float(row["bending_Nm_min"]) <= float(row["bending_Nm_mean"]) <= float(row["bending_Nm_max"])
    assert len(f["clamp_loads"]) == 12 and all(c["del_amplitude"] >= 0 for c in f["clamp_loads"])
    assert (out / "envelopes.png").is_file()


def test_fatigue_needs_its_sn_curve():
    deck = read_deck(FF)
    text = FF.read_text().replace("  sn_exponent = 5.0\n", "")
    with pytest.raises(DeckError, match=r"fatigue.*sn_exponent.*required"):
        pydriver.Model(deck_from_text(text, deck.name))
