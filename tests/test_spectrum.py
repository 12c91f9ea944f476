"""Life over a usage spectrum (issue 38): the damage sum over regimes, the ground-air-ground (GAG)
cycle and the rotor's starts against closed forms; one regime of share 1 against the plain
flight run bit for bit; mean-stress corrections and the S-N table against hand values; blade
motion fitted from a table; a failing regime that names itself and is run again alone after a
fix; the pool, in-process and Slurm-task paths giving the same numbers bit for bit; bad values
of every new key refused naming it.

The runs use a 4-body cable (8 and 16 at the refinement levels) at 16 samples per revolution: the
spectrum's arithmetic does not depend on the cable's size, and the bit-for-bit comparisons hold
at any size or they do not hold at all.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

import pydriver
from pydriver import fatigue
from pydriver.analyses.fatigue_loads import fatigue_points
from pydriver.analyses.spectrum_damage import level_damage, spectrum_life
from pydriver.blade_fit import design_matrix, fit_angle, fit_blade_file
from pydriver.deckfile import deck_from_text
from pydriver.errors import DeckError, RunError
from pydriver.mean_stress import MeanStressCorrection, equivalent_amplitudes
from pydriver.schema import GROUPS

CABLE = """&case analysis = '{analysis}' /
&chain n_bodies = 4, total_length = 0.6, diameter = 0.015, joint = 'xy', first_body = 'clamped' /
&clamp_a beta_deg = 90.0 /
&shape gamma_deg = 4*0.0, beta_deg = 0.0, 3*40.0 /
&cable ei = 1.0, mass_per_length = 0.5, damping_time = 1.0e-3 /
&rotor rpm = 120.0, centre = 0.0, -0.5, 0.0 /
&clamp_b active = .true., from_start = .true., moves_with = 'blade' /
&blade flap_hinge = 0.0, -0.3, 0.0, flap_deg = 2.0, 0.3, 0.1 /
&fatigue sn_exponent = 5.0, sn_reference_amplitude = 1.0e-3, sn_reference_cycles = 1.0e6 /
&solver samples_per_rev = 16, periodic_tol = 1.0e-4, rtol = 1.0e-6, atol = 1.0e-8 /
&refinement levels = {levels} /
"""


def spectrum_text(spectrum: str, levels: int = 2, analysis: str = "spectrum") -> str:
    return CABLE.format(analysis=analysis, levels=levels) + spectrum


#: Two regimes, two flights per hour with a short run-up.
TWO_KEYS = {"regimes": "'slow', 'fast'", "share": "0.6, 0.4", "forward_speed": "5.0, 15.0", "load_factor": "1.0, 1.3",
            "flights_per_hour": "2.0", "runup_time": "0.5"}


def spectrum_group(keys: dict) -> str:
    return "&spectrum " + ", ".join(f"{k} = {v}" for k, v in keys.items()) + " /\n"


TWO = spectrum_group(TWO_KEYS)


def write(tmp_path, name: str, text: str):
    path = tmp_path / name
    path.write_text(text)
    return path


# -- the damage sum against closed forms ---------------------------------------------------------

R, S_REF, M, N_REF, RPM = 0.005, 1.0e-2, 5.0, 1.0e6, 300.0


def _model(mean_stress: str = ""):
    return pydriver.Model(deck_from_text(f"""&case analysis = 'flight' /
&chain n_bodies = 3, total_length = 0.3, diameter = 0.01, total_mass = 0.1, joint = 'xy' /
&shape gamma_deg = 0.0, beta_deg = 0.0 /
&springs c_beta = 1.0 /
&rotor rpm = {RPM} /
&fatigue sn_exponent = {M}, sn_reference_amplitude = {S_REF}, sn_reference_cycles = {N_REF} {mean_stress} /""",
                                         "synthetic.nml"))


def _series(kx, t_end: float = 0.2) -> dict:
    """A time series whose joint 2 bends with the curvature ``kx`` about its x axis; joints 1 and 3
    are still."""
    nt = len(kx)
    ts = {"t": np.linspace(0.0, t_end, nt)}
    for j in (1, 2, 3):
        for name in ("kappa_x", "kappa_y"):
            ts[f"{name}{j}_1pm"] = np.zeros(nt)
        for name in ("moment_x", "moment_y", "bending", "torsion"):
            ts[f"{name}{j}_Nm"] = np.zeros(nt)
        ts[f"axial{j}_N"] = np.zeros(nt)
        ts[f"strain{j}"] = np.zeros(nt)
    ts["kappa_x2_1pm"] = np.asarray(kx, float)
    ts["strain2"] = R * np.abs(ts["kappa_x2_1pm"])
    for name in ("FA_x", "FA_y", "FA_z", "MA_x", "MA_y", "MA_z"):
        ts[name] = np.zeros(nt)
    return ts


def _basquin(amplitude):
    return (amplitude / S_REF) ** M / N_REF


@pytest.mark.parametrize("ultimate", [None, 0.05])
def test_two_sinusoidal_regimes_a_runup_and_the_gag_cycle_by_hand(ultimate):
    """Regimes A and B bend joint 2 as c + a sin(psi) over a revolution: at the point 90 deg round
    (strain r kappa_x) one cycle per revolution of amplitude r a about r c.  The run-up climbs from
    rest e0 through e0 + 2u, back to e0 + u and up to e0 + 3u: one closed cycle of range r u, the
    rest is residue.  The GAG cycle spans the lowest and highest strain of rest, run-up and both
    regimes.  D = sA dA + sB dB + F g + F S 2 c + F (S - 1) g0 (module pydriver.analyses.
    spectrum_damage), each term Basquin's by hand; with Goodman (S_u = 0.05) each amplitude over
    (1 - mean/S_u).  Float round-off of the sums: 1e-12."""
    correction = MeanStressCorrection("goodman", ultimate) if ultimate else MeanStressCorrection()
    model = _model(f", mean_stress = 'goodman', ultimate = {ultimate}" if ultimate else "")
    psi = np.linspace(0.0, 2.0 * np.pi, 361)
    (aA, cA), (aB, cB) = (1.0, 0.5), (1.5, 0.2)
    regime_a = fatigue_points(model, _series(cA + aA * np.sin(psi)), periodic=True)
    regime_b = fatigue_points(model, _series(cB + aB * np.sin(psi)), periodic=True)
    e0, u = 0.1, 0.4
    climb = np.concatenate([np.linspace(e0, e0 + 2 * u, 50), np.linspace(e0 + 2 * u, e0 + u, 50)[1:],
                            np.linspace(e0 + u, e0 + 3 * u, 50)[1:]])
    runup = fatigue_points(model, _series(climb, t_end=8.0), periodic=False)
    shares, flights, starts = (0.7, 0.3), 2.0, 1.5
    level = level_damage(shares, [regime_a, regime_b], runup, flights, starts, fatigue.SNCurve(M, S_REF, N_REF),
                         correction)

    def damage(amplitude, mean):
        return _basquin(amplitude / (1.0 - max(mean, 0.0) / ultimate) if ultimate else amplitude)

    per_hour = 60.0 * RPM
    d_a, d_b = per_hour * damage(R * aA, R * cA), per_hour * damage(R * aB, R * cB)
    lo, hi = min(e0, cA - aA, cB - aB), max(e0 + 3 * u, cA + aA, cB + aB)
    gag = damage(R * (hi - lo) / 2, R * (hi + lo) / 2)
    closed = damage(R * u / 2, R * (e0 + 1.5 * u))
    ground = damage(R * 3 * u / 2, R * (e0 + 1.5 * u))
    expected = 0.7 * d_a + 0.3 * d_b + flights * gag + flights * starts * 2 * closed + flights * (starts - 1) * ground
    p = int(np.flatnonzero((level.joint == 2) & (level.angle_deg == 90.0))[0])
    assert level.total[p] == pytest.approx(expected, rel=1e-12)
    assert level.worst == p                                         # the most strained point
    assert level.gag[p] == pytest.approx(flights * gag, rel=1e-12)
    assert (level.gag_low[p], level.gag_high[p]) == pytest.approx((R * lo, R * hi), rel=1e-12)
    assert level.rest[p] == pytest.approx(R * e0, rel=1e-12)
    assert level.life_hours == pytest.approx(1.0 / expected, rel=1e-12)
    still = level.joint != 2
    assert np.all(level.total[still] == 0.0)                        # joints 1 and 3 never bend


def test_the_life_over_levels_is_richardsons():
    """Three levels whose lives converge at second order: the extrapolation is the limit (exact
    for f0 + C h^2: 1e-9) and the error bar |limit - finest|."""
    class Level:
        def __init__(self, life, n):
            self.life_hours, self.n_bodies = life, n
    lives = [100.0 + 64.0 / n ** 2 for n in (4, 8, 16)]
    out = spectrum_life([Level(x, n) for x, n in zip(lives, (4, 8, 16))], expected_order=2.0)
    assert out.extrapolated == pytest.approx(100.0, rel=1e-9)
    assert out.error_estimate == pytest.approx(lives[-1] - 100.0, rel=1e-9)
    assert out.observed_order == pytest.approx(2.0, rel=1e-9) and out.order_observed


# -- one regime of share 1 is the flight --------------------------------------------------------

def test_one_regime_of_share_one_without_flights_is_the_flight_run_bit_for_bit(tmp_path):
    """The same deck as a flight and as a spectrum of one regime (share 1, no flights): the damage
    per flight hour at the worst point, the life, and the life's Richardson extrapolation and error
    bar over n = 4, 8, 16 are the flight run's own numbers, compared with ==."""
    flight = pydriver.run_deck(write(tmp_path, "flight.nml", spectrum_text("", levels=3, analysis="flight")))
    spec = pydriver.run_deck(write(tmp_path, "one.nml", spectrum_text(
        "&spectrum regimes = 'only', share = 1.0, flights_per_hour = 0.0 /\n", levels=3)))
    top = flight.summary["fatigue"]["hotspots"][0]
    sp = spec.summary["spectrum"]
    assert sp["damage_per_flight_hour"] == top["damage_per_hour"]
    assert sp["life_hours"] == top["life_hours"]
    refined = flight.summary["refinement"]["quantities"]["fatigue life [h], shortest"]
    assert sp["life_extrapolated_hours"] == refined["extrapolated"]
    assert sp["life_error_hours"] == refined["error_estimate"]
    assert sp["worst_point"]["joint"] == top["joint"]
    assert sp["damage_shares"] == {"only": 1.0, "ground-air-ground": 0.0, "start-stops": 0.0}
    assert [lv["life_hours"] for lv in sp["levels"]] == refined["values"]


def test_the_regimes_in_reverse_order_give_the_same_life_bit_for_bit(tmp_path):
    """Regimes, shares and their values all reversed: the same decks, so the same damages; two
    terms of the sum commute exactly, the GAG extremes are a min and a max.  Compared with ==."""
    keys = {**TWO_KEYS, "flights_per_hour": "1.0"}
    reverse = {k: ", ".join(reversed(v.split(", "))) if k in ("regimes", "share", "forward_speed", "load_factor")
               else v for k, v in keys.items()}
    ahead = pydriver.run_deck(write(tmp_path, "ahead.nml", spectrum_text(spectrum_group(keys), levels=1)))
    back = pydriver.run_deck(write(tmp_path, "back.nml", spectrum_text(spectrum_group(reverse), levels=1)))
    a, b = ahead.summary["spectrum"], back.summary["spectrum"]
    assert (a["life_hours"], a["worst_point"]) == (b["life_hours"], b["worst_point"])
    assert a["damage_shares"] == b["damage_shares"]


# -- mean stress and the S-N table ----------------------------------------------------------------

def test_mean_stress_corrections_against_hand_values():
    """S_a = 1 about S_m = 0.5 with S_u = 2: Goodman 1/(1 - 1/4) = 4/3, Gerber 1/(1 - 1/16) =
    16/15, Walker gamma = 0.5 (SWT) sqrt(1.5 x 1); a compressive mean changes nothing in Goodman
    and Gerber; a cycle wholly in compression does no damage in Walker; a mean at the ultimate is
    refused.  Round-off: 1e-15."""
    a, m = np.array([1.0, 1.0, 1.0]), np.array([0.5, -0.5, -2.0])
    goodman = equivalent_amplitudes(a, m, MeanStressCorrection("goodman", 2.0))
    gerber = equivalent_amplitudes(a, m, MeanStressCorrection("gerber", 2.0))
    walker = equivalent_amplitudes(a, m, MeanStressCorrection("walker", walker_gamma=0.5))
    assert goodman == pytest.approx([4.0 / 3.0, 1.0, 1.0], rel=1e-15)
    assert gerber == pytest.approx([16.0 / 15.0, 1.0, 1.0], rel=1e-15)
    assert walker == pytest.approx([math.sqrt(1.5), math.sqrt(0.5), 0.0], rel=1e-15)
    assert equivalent_amplitudes(a, m, MeanStressCorrection("walker", walker_gamma=1.0)) == pytest.approx(
        [1.0, 1.0, 0.0], rel=1e-15)
    with pytest.raises(ValueError, match="ultimate"):
        equivalent_amplitudes([1.0], [2.0], MeanStressCorrection("goodman", 2.0))


def test_a_run_with_goodman_counts_the_corrected_amplitude(tmp_path):
    """A flight record of c + a sin(psi) at joint 2 with Goodman: the damage per hour is Basquin's
    of r a / (1 - r c / S_u) (1e-12), and the description names the correction."""
    from pydriver.analyses.fatigue_loads import fatigue_of_run
    model = _model(", mean_stress = 'goodman', ultimate = 0.02")
    psi = np.linspace(0.0, 2.0 * np.pi, 361)
    summary, _ = fatigue_of_run(model, _series(0.8 + 1.0 * np.sin(psi)), periodic=True)
    expected = 60.0 * RPM * _basquin(R * 1.0 / (1.0 - R * 0.8 / 0.02))
    assert summary["hotspots"][0]["damage_per_hour"] == pytest.approx(expected, rel=1e-12)
    assert "Goodman" in summary["description"]


def test_the_sn_table_interpolates_in_log_log_and_extends_its_end_segments():
    """Points (1e-2, 1e2), (1e-3, 1e6): at the log-midpoint amplitude 1e4 cycles; below the last
    point the segment's slope m = 4 goes on (1e-4: 1e10); at or below the cut-off no damage; the
    default DEL exponent is the table's slope.  A table sampled from a Basquin curve gives that
    curve's damage.  Round-off of logs and exps: 1e-12."""
    table = fatigue.TabulatedSNCurve([1e-3, 1e-2], [1e6, 1e2], endurance_amplitude=5e-5)
    assert table.exponent == pytest.approx(4.0, rel=1e-12)
    assert table.cycles_to_failure(math.sqrt(1e-5)) == pytest.approx(1e4, rel=1e-12)
    assert table.cycles_to_failure(1e-4) == pytest.approx(1e10, rel=1e-12)
    assert table.cycles_to_failure(3e-2) == pytest.approx(1e2 * 3.0 ** -4, rel=1e-12)
    assert np.isinf(table.cycles_to_failure(5e-5))
    basquin = fatigue.SNCurve(5.0, 1e-2, 1e6)
    amplitudes = np.array([2e-3, 5e-3, 1e-2, 2e-2])
    tab = fatigue.TabulatedSNCurve(amplitudes, basquin.cycles_to_failure(amplitudes))
    cyc = fatigue.Cycles(ranges=2 * np.array([2.5e-3, 7e-3, 1.5e-2, 1e-3]), means=np.zeros(4), counts=np.ones(4))
    assert fatigue.miner_damage(cyc, tab) == pytest.approx(fatigue.miner_damage(cyc, basquin), rel=1e-12)
    with pytest.raises(ValueError, match="fall strictly"):
        fatigue.TabulatedSNCurve([1e-3, 1e-2], [1e2, 1e6])


def test_a_deck_takes_its_sn_curve_from_a_table_file(tmp_path):
    """&fatigue sn_file: a two-point table of Basquin's curve gives Basquin's damage (1e-12); a
    missing file, a file without the columns and a table that rises are refused naming the key."""
    from pydriver.analyses.fatigue_loads import fatigue_of_run
    a = np.array([1e-3, 3e-2])
    write(tmp_path, "sn.csv", "amplitude [-],cycles [-]\n" + "".join(
        f"{float(x)!r},{float(n)!r}\n" for x, n in zip(a, N_REF * (a / S_REF) ** -M)))
    deck = pydriver.Model(deck_from_text(f"""&case analysis = 'flight' /
&chain n_bodies = 3, total_length = 0.3, diameter = 0.01, total_mass = 0.1, joint = 'xy' /
&shape gamma_deg = 0.0, beta_deg = 0.0 /
&springs c_beta = 1.0 /
&rotor rpm = {RPM} /
&fatigue sn_file = '{tmp_path / "sn.csv"}' /""", "table.nml"))
    psi = np.linspace(0.0, 2.0 * np.pi, 361)
    summary, _ = fatigue_of_run(deck, _series(np.sin(psi)), periodic=True)
    assert summary["hotspots"][0]["damage_per_hour"] == pytest.approx(60.0 * RPM * _basquin(R), rel=1e-12)
    for name, text in (("none.csv", None), ("cols.csv", "amp,n\n1,2\n3,4\n"),
                       ("rising.csv", "amplitude,cycles\n1e-3,1e2\n1e-2,1e6\n")):
        if text is not None:
            write(tmp_path, name, text)
        bad = deck.deck.with_values({"fatigue.sn_file": str(tmp_path / name)})
        with pytest.raises(DeckError) as err:
            fatigue_of_run(pydriver.Model(bad), _series(np.sin(psi)), periodic=True)
        assert (err.value.group, err.value.key) == ("fatigue", "sn_file")


# -- blade motion from a table --------------------------------------------------------------------

def _blade_table(path, psi_deg, flap):
    path.write_text("azimuth_deg [deg],flap_deg [deg]\n"
                    + "".join(f"{float(a)!r},{float(f)!r}\n" for a, f in zip(psi_deg, flap)))
    return path


def test_a_table_of_a_fourier_series_fits_back_exactly_and_noise_shows_as_its_residual(tmp_path):
    """Samples of a0 + a1c cos + ... + a3s sin 3psi at 72 azimuths: the fit with 3 harmonics returns
    the coefficients to 1e-12 deg and a residual below 1e-12 deg.  Add 0.03 deg cos 5psi: on an
    equispaced grid it is orthogonal to the fitted harmonics, so the coefficients stay and the
    residual is that term itself: rms 0.03/sqrt 2 and largest 0.03 deg (1e-12)."""
    coefficients = np.array([3.5, -1.0, 0.5, 0.2, 0.1, 0.05, -0.02])
    psi = np.arange(0.0, 360.0, 5.0)
    flap = design_matrix(psi, 3) @ coefficients
    fit = fit_blade_file(_blade_table(tmp_path / "exact.csv", psi, flap), 3)["flap"]
    assert np.max(np.abs(np.array(fit.coefficients) - coefficients)) < 1e-12
    assert fit.max_deg < 1e-12 and fit.rms_deg < 1e-12
    noisy = fit_angle(psi, flap + 0.03 * np.cos(np.radians(5 * psi)), 3)
    assert np.max(np.abs(np.array(noisy.coefficients) - coefficients)) < 1e-12
    assert noisy.rms_deg == pytest.approx(0.03 / math.sqrt(2.0), rel=1e-12)
    assert noisy.max_deg == pytest.approx(0.03, rel=1e-12)
    with pytest.raises(ValueError, match="cannot determine"):
        fit_angle(psi[:6], flap[:6], 3)
    with pytest.raises(ValueError, match="twice"):
        fit_angle([0.0, 360.0, 10.0, 20.0], [1.0, 1.0, 1.0, 1.0], 1)


def test_a_regime_takes_its_blade_motion_from_a_table(tmp_path):
    """A regime with blade_file: its flight deck's flap series is the fit (1e-12), the fit's residual
    is in the summary, and a tolerance below the residual refuses the regime, naming it and the
    key (before anything runs)."""
    from pydriver.deckfile import read_deck
    from pydriver.usage_spectrum import spectrum_of
    psi = np.arange(0.0, 360.0, 10.0)
    flap = 2.5 + 0.8 * np.cos(np.radians(psi)) - 0.3 * np.sin(np.radians(psi)) + 0.01 * np.cos(np.radians(3 * psi))
    _blade_table(tmp_path / "blade.csv", psi, flap)
    text = spectrum_text("&spectrum regimes = 'hover', 'table', share = 0.5, 0.5, blade_file = '', 'blade.csv', "
                         "blade_harmonics = 2, flights_per_hour = 0.0 /\n", levels=1)
    spec = spectrum_of(read_deck(write(tmp_path, "bt.nml", text)))
    series = spec.regimes[1].deck["blade.flap_deg"]
    assert np.max(np.abs(series - [2.5, 0.8, -0.3, 0.0, 0.0])) < 1e-12
    assert spec.regimes[0].deck["blade.flap_deg"].tolist() == [2.0, 0.3, 0.1]     # the deck's own
    assert spec.regimes[1].blade_fit["flap"].max_deg == pytest.approx(0.01, rel=1e-12)
    tight = write(tmp_path, "tight.nml", text.replace("blade_harmonics = 2", "blade_harmonics = 2, "
                                                                              "blade_fit_tolerance_deg = 0.005"))
    with pytest.raises(DeckError) as err:
        pydriver.run_deck(tight, out=tmp_path / "tight")
    assert (err.value.group, err.value.key) == ("spectrum", "blade_fit_tolerance_deg")
    assert "regime 'table'" in err.value.reason and not (tmp_path / "tight").exists()


# -- the spectrum run, on the engines -------------------------------------------------------------

def _without_times(summary: dict) -> str:
    return json.dumps(summary["spectrum"], sort_keys=True)


def test_the_pool_and_the_slurm_tasks_give_the_in_process_numbers_bit_for_bit(tmp_path):
    """Two regimes, a run-up, two levels: ``rotorcable run`` (in process), ``rotorcable spectrum
    --jobs 2`` (a pool of 2) and the Slurm array's tasks (run_point, then the combining command)
    give the same summary['spectrum'] and spectrum.csv, compared as text.  The spectrum is
    complete: its GAG and start-stops take part."""
    from pydriver.sweep import run_point
    from pydriver.sweep.spectrum import run_spectrum, write_spectrum_slurm
    deck = write(tmp_path, "two.nml", spectrum_text(TWO))
    in_process = pydriver.run_deck(deck, out=tmp_path / "run")
    pool = run_spectrum(deck, tmp_path / "pool", jobs=2)
    assert pool.ok and sorted(pool.ran) == ["fast", "run-up", "slow"], pool.line()
    assert _without_times(pool.summary) == _without_times(in_process.summary)
    assert (tmp_path / "pool" / "spectrum.csv").read_text() == (tmp_path / "run" / "spectrum.csv").read_text()
    shares = in_process.summary["spectrum"]["damage_shares"]
    assert shares["ground-air-ground"] > 0.0 and sum(shares.values()) == pytest.approx(1.0, rel=1e-12)
    script, commands = write_spectrum_slurm(deck, tmp_path / "slurm")
    assert "#SBATCH --array=0-2" in script.read_text() and "spectrum" in commands[1]
    for index in range(3):
        assert run_point(tmp_path / "slurm", index)["error"] is None
    after = run_spectrum(deck, tmp_path / "slurm")
    assert after.ok and after.ran == [] and len(after.skipped) == 3
    assert _without_times(after.summary) == _without_times(in_process.summary)


def test_a_failing_regime_names_itself_keeps_the_others_and_runs_again_alone_after_a_fix(tmp_path):
    """A regime whose flight cannot become periodic in its 2 revolutions: the in-process run fails
    naming it; the spectrum directory keeps the other regime's record, writes no result and names
    the regime; once the deck is fixed, only that regime runs again."""
    from pydriver.sweep.spectrum import run_spectrum
    broken = ("&spectrum regimes = 'good', 'bad', share = 0.5, 0.5, flights_per_hour = 0.0, "
              "changes = '', 'solver.max_revolutions = 2; solver.periodic_tol = 1.0e-12' /\n")
    deck = write(tmp_path, "spec.nml", spectrum_text(broken, levels=1))
    with pytest.raises((RunError, DeckError), match="regime 'bad'"):
        pydriver.run_deck(deck, out=tmp_path / "run")
    assert not (tmp_path / "run").exists()
    first = run_spectrum(deck, tmp_path / "dir", jobs=1)
    assert not first.ok and list(first.failed) == ["bad"] and first.missing == []
    assert "regime 'bad' failed" in first.line()
    assert (tmp_path / "dir" / "runs" / "0000" / "summary.json").is_file()
    assert not (tmp_path / "dir" / "summary.json").exists()
    deck.write_text(spectrum_text(broken.replace("'solver.max_revolutions = 2; solver.periodic_tol = 1.0e-12'", "''"),
                                  levels=1))
    second = run_spectrum(deck, tmp_path / "dir", jobs=1)
    assert second.ok and second.ran == ["bad"] and second.skipped == ["good"], second.line()
    assert (tmp_path / "dir" / "summary.json").is_file()


def test_a_killed_spectrum_resumes_with_the_regimes_that_have_no_record(tmp_path):
    """A kill leaves a regime without its record (a record appears whole, by a rename, or not at
    all) and the empty hidden directory its task was making: the next run removes that (its
    process is gone), runs that regime alone and gives the same spectrum bit for bit."""
    import shutil

    from pydriver.sweep.spectrum import run_spectrum
    deck = write(tmp_path, "two.nml", spectrum_text(TWO, levels=1))
    out = tmp_path / "dir"
    first = run_spectrum(deck, out, jobs=1)
    assert first.ok
    shutil.rmtree(out / "runs" / "0002")
    dead = int((Path("/proc/sys/kernel/pid_max")).read_text()) + 1
    making = out / "runs" / f".0002.{dead}.{'0' * 16}"
    making.mkdir()
    second = run_spectrum(deck, out, jobs=1)
    assert second.ran == ["fast"] and sorted(second.skipped) == ["run-up", "slow"], second.line()
    assert not making.exists()
    assert _without_times(second.summary) == _without_times(first.summary)


def test_sweep_collect_refuses_a_spectrum_directory(tmp_path):
    """The sweep's table is no spectrum: sweep-collect names the command that combines it."""
    from pydriver.sweep import SweepError, collect
    from pydriver.sweep.spectrum import run_spectrum
    deck = write(tmp_path, "one.nml", spectrum_text(
        "&spectrum regimes = 'only', share = 1.0, flights_per_hour = 0.0 /\n", levels=1))
    assert run_spectrum(deck, tmp_path / "dir", jobs=1).ok
    with pytest.raises(SweepError, match="rotorcable spectrum"):
        collect(tmp_path / "dir")


def test_a_directory_of_another_spectrum_or_a_sweep_is_refused(tmp_path):
    """Other regimes are another spectrum: refused before anything is written, naming what is there."""
    from pydriver.sweep import SweepError
    from pydriver.sweep.spectrum import run_spectrum
    one = write(tmp_path, "one.nml", spectrum_text(
        "&spectrum regimes = 'only', share = 1.0, flights_per_hour = 0.0 /\n", levels=1))
    assert run_spectrum(one, tmp_path / "dir", jobs=1).ok
    other = write(tmp_path, "other.nml", spectrum_text(
        "&spectrum regimes = 'a', 'b', share = 0.5, 0.5, flights_per_hour = 0.0 /\n", levels=1))
    before = sorted(p.name for p in (tmp_path / "dir").rglob("*"))
    with pytest.raises(SweepError, match="another spectrum"):
        run_spectrum(other, tmp_path / "dir", jobs=1)
    assert sorted(p.name for p in (tmp_path / "dir").rglob("*")) == before


# -- bad values of every new key ------------------------------------------------------------------

def test_every_new_key_has_a_range():
    """Every real and integer key of &spectrum and the new &fatigue keys has finite bounds (the fuzz
    classes draw huge and tiny values from them)."""
    keys = [*GROUPS["spectrum"].values()] + [GROUPS["fatigue"][k] for k in ("ultimate", "walker_gamma")]
    for key in keys:
        if key.type in ("real", "int"):
            assert math.isfinite(key.low) and math.isfinite(key.high), key.name


BAD = [  # (group, key, value text, the keys a refusal may name)
    ("spectrum", "share", "1.0e300, 1.0", ("share",)),                       # huge
    ("spectrum", "share", "0.5", ("share",)),                                # wrong count
    ("spectrum", "share", "0.6, 0.6", ("share",)),                           # does not sum to 1
    ("spectrum", "forward_speed", "1.0e300, 1.0", ("forward_speed",)),
    ("spectrum", "forward_speed", "10.0", ("forward_speed",)),
    ("spectrum", "rpm", "-120.0, 120.0", ("rpm",)),
    ("spectrum", "load_factor", "1.0, 1.0, 1.0", ("load_factor",)),
    ("spectrum", "load_factor", "1.0e300, 1.0", ("load_factor",)),
    ("spectrum", "air_density", "4.9e-324, 1.2", ("air_density",)),          # tiny
    ("spectrum", "flights_per_hour", "1.0e300", ("flights_per_hour",)),
    ("spectrum", "flights_per_hour", "-1.0", ("flights_per_hour",)),
    ("spectrum", "start_stops_per_flight", "0.5", ("start_stops_per_flight",)),
    ("spectrum", "runup_time", "4.9e-324", ("runup_time",)),
    ("spectrum", "scatter_factor", "0.5", ("scatter_factor",)),
    ("spectrum", "blade_harmonics", "3000000000", ("blade_harmonics",)),
    ("spectrum", "blade_harmonics", "100", ("blade_harmonics",)),
    ("spectrum", "blade_fit_tolerance_deg", "1.0e-300", ("blade_fit_tolerance_deg",)),
    ("spectrum", "regimes", "'slow', 'SLOW'", ("regimes",)),                 # named twice
    ("spectrum", "regimes", "'a b', 'c'", ("regimes",)),
    ("spectrum", "regimes", "'a', 'b', 'c'", ("share", "forward_speed", "load_factor")),   # counts differ
    ("spectrum", "changes", "'chain.n_bodies = 5', ''", ("changes",)),
    ("spectrum", "changes", "'no assignment', ''", ("changes",)),
    ("spectrum", "changes", "'drag.forward_speed = -5.0', ''", ("changes",)),
    ("spectrum", "changes", "'drag.cd = 1.0; blade.flap_deg(9) = 1.0', ''", ("changes",)),
    ("spectrum", "blade_file", "'missing.csv', ''", ("blade_file",)),
    ("fatigue", "mean_stress", "'goodman'", ("ultimate",)),
    ("fatigue", "mean_stress", "'soderberg'", ("mean_stress",)),
    ("fatigue", "ultimate", "1.0e300", ("ultimate",)),
    ("fatigue", "walker_gamma", "1.5", ("walker_gamma",)),
    ("fatigue", "sn_file", "'missing.csv'", ("sn_reference_amplitude", "sn_file")),
]


def _with(text: str, group: str, key: str, value: str) -> str:
    lines = text.splitlines()
    k = next(i for i, line in enumerate(lines) if line.startswith(f"&{group}"))
    lines[k] = lines[k].rstrip().rstrip("/").rstrip() + f", {key} = {value} /"
    return "\n".join(lines) + "\n"


@pytest.mark.parametrize("group, key, value, named", BAD, ids=[f"{g}.{k}={v}" for g, k, v, _ in BAD])
def test_a_bad_value_of_a_new_key_is_refused_naming_it_and_leaves_nothing(group, key, value, named, tmp_path):
    """Huge, tiny, negative, reversed-sum, wrong-count and malformed values: a DeckError naming the
    deck, the group and the key (or the key the rule is about), before any regime runs, and no
    output directory."""
    if group == "spectrum":
        text = spectrum_text(spectrum_group({**TWO_KEYS, key: value}), levels=1)
    else:
        text = _with(spectrum_text(TWO, levels=1), group, key, value)
    deck = write(tmp_path, "bad.nml", text)
    with pytest.raises(DeckError) as err:
        pydriver.run_deck(deck, out=tmp_path / "out")
    assert err.value.deck == "bad.nml" and err.value.group == group and err.value.key in named, str(err.value)
    assert not (tmp_path / "out").exists()
