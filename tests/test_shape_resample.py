"""A start shape given once for any n (issue 21 item 1): ``&shape resample = .true.`` takes
gamma_deg and beta_deg as the shape of an m-body chain and places its joints on the n-body
chain by arc length (pydriver/shape_resample.py, docs/model.md "Start shape for any n")."""

from __future__ import annotations

import numpy as np
import pytest

import pydriver
from conftest import INPUTS
from pydriver.deckfile import deck_from_text, read_deck
from pydriver.errors import DeckError
from pydriver.shape_resample import chain_lengths, joint_positions, target_joints

CABLE = INPUTS / "uh60_part2_forward_flight_cable.nml"


@pytest.mark.parametrize("stem", ["uh60_part2_forward_flight_cable", "uh60_part2_modal", "six_link_static",
                                  "cantilever_check"])
def test_at_the_decks_own_n_the_shape_is_the_per_body_one(stem):
    """Same points: at n = m every joint lands on itself, value for value (exact equality)."""
    deck = read_deck(INPUTS / f"{stem}.nml")
    r = deck.with_values({"shape.resample": True})
    for key in ("shape.gamma_deg", "shape.beta_deg"):
        assert np.array_equal(r[key], deck[key])
    m = pydriver.Model(r)
    assert np.array_equal(m.q0, pydriver.Model(deck).q0)


def test_doubling_n_is_the_refinement_split_on_a_chain_of_equal_bodies():
    """n = 2m, 4m of a chain of equal bodies: joint i goes to joint k (i - 1) + 1, the others
    stay straight, which is refined_deck's split (the same polygon)."""
    deck = read_deck(INPUTS / "uh60_part2_modal.nml").with_values({"shape.resample": True})
    for k in (2, 4):
        fine = deck.with_values({"chain.n_bodies": 11 * k})
        expect = np.zeros(11 * k)
        expect[::k] = deck["shape.beta_deg"]
        assert np.array_equal(fine["shape.beta_deg"], expect)


def test_joints_go_to_the_nearest_joint_in_arc_length():
    """Hencky chain with the half element at clamp B (L = (n - 1/2) l): each of the m joints
    takes the n-chain joint nearest in arc length; the placement is strictly increasing up to
    n = 2000 (the schema's largest chain)."""
    for m, n in ((11, 22), (11, 44), (11, 12), (3, 2000), (2000, 2000)):
        t = target_joints(m, n, 0.59, True)
        coarse = joint_positions(chain_lengths(m, 0.59, True))
        fine = joint_positions(chain_lengths(n, 0.59, True))
        assert np.all(np.diff(t) > 0) and t[0] == 0
        assert np.all(np.abs(fine[t] - coarse) <= 0.5 * 0.59 / (n - 0.5) / 0.59 * (1 + 1e-12))


def cable_modal(n: int, levels: int, resample: bool) -> pydriver.Model:
    """The forward-flight cable as a modal deck at n bodies, the shape written once for n = 11."""
    deck = read_deck(CABLE)
    changes = {"case.analysis": "modal", "chain.n_bodies": n, "refinement.levels": levels,
               "shape.resample": resample}
    return pydriver.Model(deck.with_values(changes))


def test_a_deck_for_n11_runs_at_22_and_44_with_n_bodies_changed_only():
    """The per-body form refuses n = 22 with 11 values; resample = .true. runs it, and lands on
    the same equilibrium as the per-body deck refined by splitting (first frequency to 1e-9)."""
    with pytest.raises(DeckError, match="needs 22 values"):
        cable_modal(22, 1, False)
    f = {n: pydriver.run_deck(cable_modal(n, 1, True)).summary["frequencies_hz"][0] for n in (22, 44)}
    split = pydriver.run_deck(cable_modal(11, 3, False)).summary["refinement"]["quantities"]["f1 [Hz]"]["values"]
    assert f[22] == pytest.approx(split[1], rel=1e-9) and f[44] == pytest.approx(split[2], rel=1e-9)


def test_refined_runs_of_a_resampled_deck_converge():
    """&refinement levels = 3 on the resampled deck: n = 11, 22, 44 (rotation-vector springs,
    second order): f1 and f2 at observed orders within 0.3 of 2, without warnings."""
    s = pydriver.run_deck(cable_modal(11, 3, True)).summary
    assert s["refinement"]["n"] == [11, 22, 44]
    for name in ("f1 [Hz]", "f2 [Hz]"):
        q = s["refinement"]["quantities"][name]
        assert abs(q["observed_order"] - 2.0) < 0.3 and not q["warning"]


TEXT = """&case analysis = 'static' /
&chain n_bodies = {n}, total_length = 1.0, diameter = 0.01, density = 1000.0, joint = 'xy'{extra_chain} /
&cable ei = 1.0 /
&clamp_a beta_deg = 90.0 /
&shape resample = {resample}, gamma_deg = {gamma}, beta_deg = {beta} /
&loads gravity = 0.0, 0.0, -9.81 /
"""


def deck(n=8, gamma="0.0, 0.0, 0.0", beta="0.0, 10.0, 10.0", resample=".true.", extra_chain=""):
    return deck_from_text(TEXT.format(n=n, gamma=gamma, beta=beta, resample=resample, extra_chain=extra_chain),
                          "resample.nml")


def test_one_point_and_many_bodies():
    """Tiny: a single joint (m = 1) is joint 1 (a lone value is the one-point shape, not a
    broadcast); huge: the same 3-point shape on 2000 bodies."""
    d = deck(gamma="0.0", beta="30.0")
    assert np.array_equal(d["shape.beta_deg"], [30.0] + [0.0] * 7)
    big = deck(n=2000)
    assert np.count_nonzero(big["shape.beta_deg"]) == 2 and big["shape.beta_deg"].size == 2000


@pytest.mark.parametrize("kwargs,key,words", [
    (dict(n=2), "gamma_deg", "m at most n_bodies = 2; got 3"),                        # wrong count: m > n
    (dict(gamma=", ".join(["0.0"] * 9), beta=", ".join(["1.0"] * 9)), "gamma_deg", "got 9"),   # huge m
    (dict(gamma="0.0, 0.0"), "beta_deg", "gamma_deg has 2 values, beta_deg has 3"),   # counts differ
    (dict(resample="3"), "resample", "not a logical"),
    (dict(resample="'yes'"), "resample", "not a logical"),
    (dict(beta="0.0, 10.0, 400.0"), "beta_deg", "out of range"),                       # range still checked
    (dict(extra_chain=", body_length = 8*0.125"), "resample", "total_length"),
])
def test_bad_resample_decks_name_the_key(kwargs, key, words):
    with pytest.raises(DeckError) as exc:
        pydriver.Model(deck(**kwargs))
    assert exc.value.group in ("shape", "chain") and exc.value.key == key
    assert words in str(exc.value)


def test_without_resample_the_per_body_form_is_unchanged():
    with pytest.raises(DeckError, match="needs 8 values"):
        deck(resample=".false.")
