"""Fatigue post-processor (pydriver/fatigue.py): rainflow counts against ASTM E1049-85, closed
forms for Miner damage and the damage-equivalent amplitude, periodic closing, the table.

Tolerances: rainflow counts are multiples of 0.5 and are compared exactly. Ranges, damages
and amplitudes built from exactly representable extremes are compared to 1e-12 relative:
each is a handful of float operations (a few ulps, ~1e-15), so 1e-12 leaves a margin of three
orders of magnitude while still catching any formula error (those are O(1)).
"""

import itertools
import json
import math

import numpy as np
import pytest
from conftest import DATA

from pydriver.fatigue import (
    Cycles,
    SNCurve,
    close_period,
    cycles,
    damage_equivalent_amplitude,
    envelope,
    fatigue_table,
    hotspots,
    miner_damage,
)

REL = 1e-12          # see the module docstring
SN = SNCurve(exponent=5.0, reference_amplitude=2.0, reference_cycles=1.0e6)


def counts_by_range(cyc: Cycles) -> dict:
    """Total count per range (ranges here are exact binary numbers, so exact keys are safe)."""
    out = {}
    for r, c in zip(cyc.ranges, cyc.counts):
        out[float(r)] = out.get(float(r), 0.0) + float(c)
    return out


def sine(amplitude, periods, mean=0.0, samples_per_period=64):
    """`periods` whole periods of a sampled sine; 64 samples put samples 16 and 48 exactly on
    the peak and the valley, so the extremes are exact (sin(pi/2) = 1 in double precision)."""
    one = mean + amplitude * np.sin(2.0 * np.pi * np.arange(samples_per_period) / samples_per_period)
    return np.tile(one, periods)


def two_level_block(a1=1.5, n1=5, a2=4.0, n2=3, mean=0.5, ramp=4):
    """n2 cycles of amplitude a2, then n1 of amplitude a1, about `mean`, as linear ramps of
    `ramp` samples per half cycle (the ramps add samples but no reversals). As a closed
    periodic history it holds exactly n2 cycles of range 2 a2 and n1 of range 2 a1."""
    peaks = [mean + a2, mean - a2] * n2 + [mean + a1, mean - a1] * n1
    closed = peaks + peaks[:1]
    pieces = [np.linspace(p, q, ramp, endpoint=False) for p, q in itertools.pairwise(closed)]
    return np.concatenate(pieces)


def test_astm_e1049_rainflow_example():
    """ASTM E1049-85 Fig. 6: the published counts per range, exactly (multiples of 0.5)."""
    ref = json.loads((DATA / "astm_e1049_rainflow.json").read_text())
    cyc = cycles(ref["history"])
    published = {float(row["range"]): row["count"] for row in ref["cycle_counts"]}
    # Exact equality: every other range of the history must have count 0, i.e. be absent.
    assert counts_by_range(cyc) == published
    assert cyc.total == ref["total_count"]


def test_sine_periodic_gives_k_full_cycles_and_closed_form_damage():
    """k whole periods of a sine, closed: k full cycles of range 2 S_a, no half cycles."""
    k, s_a, mean = 7, 3.5, 1.25
    cyc = cycles(sine(s_a, k, mean), periodic=True)
    assert np.array_equal(cyc.counts, np.ones(k))           # exact: counts are 0.5 multiples
    np.testing.assert_allclose(cyc.ranges, 2.0 * s_a, rtol=REL, atol=0.0)
    np.testing.assert_allclose(cyc.means, mean, rtol=REL, atol=0.0)
    closed_form = k * (s_a / SN.reference_amplitude) ** SN.exponent / SN.reference_cycles
    assert miner_damage(cyc, SN) == pytest.approx(closed_form, rel=REL, abs=0.0)
    # k cycles of amplitude S_a applied k times: the DEL is S_a itself.
    assert damage_equivalent_amplitude(cyc, SN.exponent, k) == pytest.approx(s_a, rel=REL, abs=0.0)


def test_open_history_halves_one_largest_cycle():
    """Why the periodic closing exists: the open sine (starting at 0) counts only k - 1/2 cycles
    of the full range, the residue being half cycles; closed, all k are full cycles."""
    k, s_a = 7, 1.0
    open_counts = counts_by_range(cycles(sine(s_a, k)))
    assert open_counts[2.0 * s_a] == k - 0.5                  # exact: multiples of 0.5
    closed = cycles(sine(s_a, k), periodic=True)
    assert counts_by_range(closed) == {2.0 * s_a: float(k)}


def test_periodic_signal_started_at_any_phase_gives_same_cycles():
    """One revolution of a multi-harmonic load, rolled by whole samples: same cycles, same damage
    (to 1e-12 relative; in fact bit-identical, since closing rotates to the same maximum)."""
    theta = 2.0 * np.pi * np.arange(720) / 720
    load = (50.0 * np.sin(theta) + 20.0 * np.sin(3.0 * theta + 0.3) + 7.5 * np.cos(7.0 * theta)
            + 3.0 * np.sin(23.0 * theta + 1.1))
    sn = SNCurve(exponent=4.0, reference_amplitude=40.0, reference_cycles=2.0e6)
    ref = cycles(load, periodic=True)
    assert np.all(ref.counts == 1.0)                          # no half cycles remain
    order = np.lexsort((ref.means, ref.ranges))
    d_ref = miner_damage(ref, sn)
    for shift in (1, 97, 360, 611):
        cyc = cycles(np.roll(load, shift), periodic=True)
        o = np.lexsort((cyc.means, cyc.ranges))
        np.testing.assert_allclose(cyc.ranges[o], ref.ranges[order], rtol=REL, atol=0.0)
        # Means can be ~0, where a relative tolerance is void: 1e-12 of the load scale (50).
        np.testing.assert_allclose(cyc.means[o], ref.means[order], rtol=REL, atol=50.0 * REL)
        assert np.array_equal(cyc.counts[o], ref.counts[order])
        assert miner_damage(cyc, sn) == pytest.approx(d_ref, rel=REL, abs=0.0)


def test_closed_random_periods_leave_no_half_cycles():
    """The pairing of half cycles in a closed history is complete: 500 random periods (a third
    rounded to integers, so ties and plateaus occur) never leave a half cycle."""
    rng = np.random.default_rng(20240611)
    for trial in range(500):
        x = rng.normal(size=int(rng.integers(1, 60)))
        if trial % 3 == 0:
            x = np.round(x)
        cyc = cycles(x, periodic=True)
        assert np.all(cyc.counts == 1.0), x               # exact: counts are 0.5 multiples
        assert np.all(cyc.ranges > 0.0)


def test_close_period_starts_and_ends_at_global_maximum():
    """close_period rotates to the first global maximum and repeats it at the end (exact)."""
    x = np.array([0.0, 2.0, -1.0, 3.0, 1.0, -2.0])
    assert close_period(x).tolist() == [3.0, 1.0, -2.0, 0.0, 2.0, -1.0, 3.0]


def test_two_level_block_cycles_and_damage():
    """Known spectrum: n2 cycles of range 2 a2 and n1 of range 2 a1, exactly; damage in closed form."""
    a1, n1, a2, n2 = 1.5, 5, 4.0, 3
    cyc = cycles(two_level_block(a1, n1, a2, n2), periodic=True)
    assert counts_by_range(cyc) == {2 * a1: float(n1), 2 * a2: float(n2)}   # exact
    m, s_ref, n_ref = SN.exponent, SN.reference_amplitude, SN.reference_cycles
    closed_form = (n1 * (a1 / s_ref) ** m + n2 * (a2 / s_ref) ** m) / n_ref
    assert miner_damage(cyc, SN) == pytest.approx(closed_form, rel=REL, abs=0.0)


@pytest.mark.parametrize("repeats", [2, 5])
def test_damage_is_linear_in_repetitions(repeats):
    """The same block repeated R times (still one closed period) does R times the damage."""
    block = two_level_block()
    d1 = miner_damage(cycles(block, periodic=True), SN)
    d_r = miner_damage(cycles(np.tile(block, repeats), periodic=True), SN)
    assert d_r == pytest.approx(repeats * d1, rel=REL, abs=0.0)


def test_endurance_cut_off():
    """Amplitudes at or below the cut-off do no damage: cut-off at a1 leaves only the a2 cycles;
    cut-off at a2 leaves nothing (exactly 0, and an infinite life in the table)."""
    a1, n1, a2, n2 = 1.5, 5, 4.0, 3
    block = two_level_block(a1, n1, a2, n2)
    cyc = cycles(block, periodic=True)
    at_a1 = SNCurve(5.0, 2.0, 1.0e6, endurance_amplitude=a1)
    only_a2 = n2 * (a2 / 2.0) ** 5.0 / 1.0e6
    assert miner_damage(cyc, at_a1) == pytest.approx(only_a2, rel=REL, abs=0.0)
    at_a2 = SNCurve(5.0, 2.0, 1.0e6, endurance_amplitude=a2)
    assert miner_damage(cyc, at_a2) == 0.0
    row = fatigue_table({"block": block}, at_a2, revolutions=1.0, revolutions_per_hour=3600.0)[0]
    assert row["damage_per_hour"] == 0.0 and row["life_hours"] == math.inf


def test_sn_curve_cycles_to_failure():
    """N(S_ref) = N_ref; doubling the amplitude divides N by 2^m; inf at or below the cut-off."""
    sn = SNCurve(exponent=3.0, reference_amplitude=10.0, reference_cycles=2.0e6, endurance_amplitude=4.0)
    n = sn.cycles_to_failure([10.0, 20.0, 4.0, 0.0, 3.0])
    assert n[0] == pytest.approx(2.0e6, rel=REL, abs=0.0)
    assert n[1] == pytest.approx(2.0e6 / 8.0, rel=REL, abs=0.0)
    assert np.all(np.isinf(n[2:]))
    # Without a cut-off only amplitude 0 is harmless (no division by zero).
    assert SNCurve(3.0, 10.0, 2.0e6).cycles_to_failure(0.0) == math.inf
    for bad in (-1.0, math.nan, math.inf):
        with pytest.raises(ValueError, match="amplitudes"):
            sn.cycles_to_failure([1.0, bad])


def test_sn_curve_has_no_defaults_and_validates():
    """The jacket's S-N data are unknown: no defaults may be invented; bad values are refused."""
    with pytest.raises(TypeError):
        SNCurve()
    for kwargs in ({"exponent": 0.0}, {"exponent": -3.0}, {"reference_amplitude": 0.0},
                   {"reference_cycles": math.nan}, {"reference_cycles": math.inf},
                   {"endurance_amplitude": -1.0}, {"exponent": "five"}):
        args = {"exponent": 5.0, "reference_amplitude": 1.0, "reference_cycles": 1e6, **kwargs}
        with pytest.raises(ValueError, match="SNCurve"):
            SNCurve(**args)


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_non_finite_signal_is_rejected(bad):
    """NaN or inf anywhere in a signal is an error, not a silently wrong count."""
    x = [0.0, 1.0, bad, -1.0]
    for periodic in (False, True):
        with pytest.raises(ValueError, match="non-finite"):
            cycles(x, periodic=periodic)
    with pytest.raises(ValueError, match="non-finite"):
        envelope(x)
    with pytest.raises(ValueError, match="'M_bend_2'"):
        fatigue_table({"M_bend_1": [0.0, 1.0], "M_bend_2": x}, SN, 1.0, 1.0)


def test_empty_or_two_dimensional_signal_is_rejected():
    """An empty or 2-D signal has no defined cycles."""
    with pytest.raises(ValueError, match="empty"):
        cycles([])
    with pytest.raises(ValueError, match="one-dimensional"):
        cycles(np.zeros((3, 2)))


def test_constant_signal_has_no_cycles_no_damage_infinite_life():
    """A constant signal (and a single sample): zero cycles, zero damage and DEL, life inf; every
    table field is finite except life_hours, the one field where inf means "no damage"."""
    for x in (np.full(50, 3.25), [7.0]):
        for periodic in (False, True):
            cyc = cycles(x, periodic=periodic)
            assert cyc.ranges.size == 0 and cyc.total == 0.0
            assert miner_damage(cyc, SN) == 0.0
            assert damage_equivalent_amplitude(cyc, 5.0, 10.0) == 0.0
    row = fatigue_table({"F_axial": np.full(50, 3.25)}, SN, 7.0, 15480.0)[0]
    assert row["life_hours"] == math.inf
    assert row["damage_per_rev"] == 0.0 and row["n_cycles"] == 0.0
    assert all(math.isfinite(v) for k, v in row.items() if k not in ("quantity", "life_hours"))


def test_del_gives_the_same_miner_damage_for_any_curve_of_that_exponent():
    """S_eq applied n_equivalent times does the spectrum's damage on any Basquin curve with the
    same exponent and no cut-off (two different reference points), to 1e-12 relative."""
    cyc = cycles(two_level_block(), periodic=True)
    m, n_eq = 4.0, 11.0
    s_eq = damage_equivalent_amplitude(cyc, m, n_eq)
    for sn in (SNCurve(m, 2.0, 1.0e6), SNCurve(m, 37.0, 5.0e3)):
        equivalent = Cycles(ranges=np.array([2.0 * s_eq]), means=np.zeros(1), counts=np.array([n_eq]))
        assert miner_damage(equivalent, sn) == pytest.approx(miner_damage(cyc, sn), rel=REL, abs=0.0)


def test_del_does_not_overflow_for_steep_curves_and_large_loads():
    """Amplitudes of 1e10 (N m) with m = 50 would overflow a ** m; the result is still exact:
    n equal cycles with n_equivalent = n give back the amplitude (1e-12 relative)."""
    cyc = Cycles(ranges=np.full(3, 2.0e10), means=np.zeros(3), counts=np.ones(3))
    assert damage_equivalent_amplitude(cyc, 50.0, 3.0) == pytest.approx(1.0e10, rel=REL, abs=0.0)
    with pytest.raises(ValueError, match="n_equivalent"):
        damage_equivalent_amplitude(cyc, 50.0, 0.0)
    with pytest.raises(ValueError, match="exponent"):
        damage_equivalent_amplitude(cyc, math.nan, 1.0)


def test_envelope():
    """min, max, mean and half peak-to-peak, exact for these binary fractions."""
    assert envelope([1.0, -3.0, 2.5, 0.5]) == {"min": -3.0, "max": 2.5, "mean": 0.25, "amplitude": 2.75}


def test_fatigue_table_and_hotspots():
    """Per-revolution and per-hour damage, life, 1/rev DEL and ranking on sines with 1 cycle per
    revolution over 7 revolutions (closed forms, 1e-12 relative); ties keep the column order."""
    revs, per_hour = 7, 258.0 * 60.0
    columns = {"F_axial": np.full(64 * revs, 2.0), "M_bend_1": sine(1.0, revs),
               "M_bend_2": sine(3.0, revs, mean=0.5), "F_shear": np.zeros(64 * revs)}
    rows = fatigue_table(columns, SN, revolutions=revs, revolutions_per_hour=per_hour)
    assert [r["quantity"] for r in rows] == ["M_bend_2", "M_bend_1", "F_axial", "F_shear"]
    for row, s_a in ((rows[0], 3.0), (rows[1], 1.0)):
        per_rev = (s_a / SN.reference_amplitude) ** SN.exponent / SN.reference_cycles
        assert row["damage_per_rev"] == pytest.approx(per_rev, rel=REL, abs=0.0)
        assert row["damage_per_hour"] == pytest.approx(per_rev * per_hour, rel=REL, abs=0.0)
        assert row["life_hours"] == pytest.approx(1.0 / (per_rev * per_hour), rel=REL, abs=0.0)
        # One cycle per revolution: the 1/rev-equivalent amplitude is the amplitude itself.
        assert row["del_amplitude"] == pytest.approx(s_a, rel=REL, abs=0.0)
        assert row["n_cycles"] == revs                           # exact: whole cycles
        assert row["amplitude"] == pytest.approx(s_a, rel=REL, abs=0.0)
    assert rows[0]["mean"] == pytest.approx(0.5, rel=REL, abs=0.0)
    for row in rows:
        finite = [v for k, v in row.items() if k not in ("quantity", "life_hours")]
        assert all(math.isfinite(v) for v in finite)
    assert [r["life_hours"] for r in rows[2:]] == [math.inf, math.inf]

    top = hotspots(rows, top=2)
    assert [(r["rank"], r["quantity"]) for r in top] == [(1, "M_bend_2"), (2, "M_bend_1")]
    assert len(hotspots(rows, top=10)) == 4
    assert "rank" not in rows[0]                                # copies: the table is unchanged
    for bad in (0, -1, 2.5, True):
        with pytest.raises(ValueError, match="top"):
            hotspots(rows, top=bad)


@pytest.mark.parametrize("revs, per_hour", [(0.0, 1.0), (-7.0, 1.0), (7.0, 0.0), (math.nan, 1.0),
                                            (7.0, math.inf)])
def test_fatigue_table_rejects_bad_revolutions(revs, per_hour):
    """Revolutions and speed divide and multiply the damage: they must be finite and > 0."""
    with pytest.raises(ValueError, match="revolutions"):
        fatigue_table({"M": sine(1.0, 1)}, SN, revs, per_hour)


def test_damage_beyond_float_range_is_an_error():
    """An S-N curve in other units than the signal (amplitude 1e6 against S_ref = 1, m = 60)
    gives a damage beyond 1e308: a ValueError naming the column, never inf or NaN. A steep but
    representable case (m = 50: 1e300 / 1e6) stays exact (1e-12 relative)."""
    cyc = Cycles(ranges=np.array([2.0e6]), means=np.zeros(1), counts=np.ones(1))
    assert miner_damage(cyc, SNCurve(50.0, 1.0, 1.0e6)) == pytest.approx(1.0e294, rel=REL, abs=0.0)
    with pytest.raises(ValueError, match="float range"):
        miner_damage(cyc, SNCurve(60.0, 1.0, 1.0e6))
    with pytest.raises(ValueError, match="column 'M'"):
        fatigue_table({"M": [1.0e6, -1.0e6]}, SNCurve(60.0, 1.0, 1.0e6), 1.0, 1.0)
