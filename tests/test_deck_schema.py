"""The deck schema and reader (issue 11): f90nml's namelist semantics, one schema table, clear
errors.  Every deck defect found by trying the old hand-written scanner as a new user would
is a case here: valid decks it rejected now run, invalid decks it accepted are refused with
the deck, the group, the key and the reason."""

from __future__ import annotations

import builtins
import io
import re

import numpy as np
import pytest

import pydriver
from conftest import INPUTS, ROOT
from pydriver.deckfile import deck_from_text, read_deck
from pydriver.deck_reference import reference_markdown
from pydriver.schema import KEYS

SIX = (INPUTS / "six_link_static.nml").read_text()


def six_link_result(text: str, tmp_path, name="deck.nml"):
    p = tmp_path / name
    p.write_text(text)
    return pydriver.run_deck(p)


def reference_b_force():
    return pydriver.run_deck(INPUTS / "six_link_static.nml").summary["reactions"]["B"]["F"]


# ---- valid decks the old scanner rejected -------------------------------------------------

def test_tab_before_equals(tmp_path):
    res = six_link_result(SIX.replace("n_bodies = 5", "n_bodies\t= 5"), tmp_path)
    assert res.summary["n_bodies"] == 5


def test_comment_inside_a_value_list(tmp_path):
    text = SIX.replace("beta_deg  = 90.0, 90.0, 90.0, 90.0, -90.0",
                       "beta_deg  = 90.0, 90.0,   ! the swing\n    90.0, 90.0, -90.0")
    assert text != SIX
    assert six_link_result(text, tmp_path).summary["reactions"]["B"]["F"] == pytest.approx(reference_b_force())


def test_whole_deck_on_one_line(tmp_path):
    body = re.sub(r"!.*", "", SIX)
    one_line = " ".join(body.split())
    assert "\n" not in one_line
    res = six_link_result(one_line, tmp_path)
    assert res.summary["reactions"]["B"]["F"] == pytest.approx(reference_b_force())


def test_line_longer_than_4096_characters(tmp_path):
    text = SIX.replace("density = 7801.0", "density = " + " " * 5000 + "7801.0")
    assert max(len(line) for line in text.splitlines()) > 4096
    assert six_link_result(text, tmp_path).summary["reactions"]["B"]["F"] == pytest.approx(reference_b_force())


def test_group_with_more_than_200_assignments(tmp_path):
    """A 300-body chain whose start angles are given one element per line (300 assignments
    in &shape): namelist semantics, no limit."""
    n = 300
    lines = [f"  beta_deg({j}) = {2.0 if j > 1 else 90.0}" for j in range(1, n + 1)]
    text = (f"&case analysis = 'static' /\n&chain n_bodies = {n}, total_length = 3.0, diameter = 0.01,\n"
            f"  density = 1000.0, first_body = 'pivot' /\n&shape\n  gamma_deg = {n}*0.0\n" + "\n".join(lines) + "\n/\n")
    deck = deck_from_text(text, "long.nml")
    assert deck["shape.beta_deg"][0] == 90.0 and np.all(deck["shape.beta_deg"][1:] == 2.0)


def test_repeat_counts_and_element_assignments():
    text = ("&case analysis='static' / &chain n_bodies=11 total_length=1 diameter=0.01 density=1 /"
            " &shape gamma_deg = 11*0.0 beta_deg = 90.0, 10*3.05 beta_deg(4) = 7.0 /")
    beta = deck_from_text(text, "x.nml")["shape.beta_deg"]
    assert beta[0] == 90.0 and beta[3] == 7.0 and np.count_nonzero(beta == 3.05) == 9


# ---- invalid decks the old scanner accepted -----------------------------------------------

@pytest.mark.parametrize("text,group,key,words", [
    (SIX + "\n&chain\n  n_bodies = 6\n/\n", "chain", "", "more than once"),
    (SIX.replace("beta_deg  = 90.0, 90.0, 90.0, 90.0, -90.0", "beta_deg = 7*1.0"), "shape", "beta_deg", "5 values"),
    (SIX.replace("gravity = 0.0, 0.0, -9.81", "gravity = 0.0, 0.0"), "loads", "gravity", "3 values"),
    (SIX.replace("&loads", "&springs\n  c_beta =\n/\n&loads"), "springs", "c_beta", "no value"),
    (SIX.replace("&loads", "&springs\n  c_beta = 6.1, 10*3.05\n/\n&loads"), "springs", "c_beta", "5 values"),
    (SIX.replace("density = 7801.0", "density = 1.0e400"), "chain", "density", "finite"),
    (SIX.replace("density = 7801.0", "density = 7801.0.0"), "chain", "density", "not a number"),
    (SIX.replace("n_bodies = 5", "n_bodies = 5\n  lenght = 1.0"), "chain", "lenght", "unknown key"),
    (SIX + "\n&rotr\n rpm = 3\n/\n", "rotr", "", "unknown group"),
    (SIX.replace("first_body = 'clamped'", "first_body = 'clamped"), "", "", "namelist"),
    (SIX.replace("&shape", "&shape\n  beta_deg(3) = 1.0, 2.0"), "", "", "element assignment"),
])
def test_invalid_deck_is_named(tmp_path, text, group, key, words):
    p = tmp_path / "bad.nml"
    p.write_text(text)
    with pytest.raises(pydriver.DeckError) as exc:
        pydriver.run_deck(p, out=tmp_path / "out")
    err = exc.value
    assert err.deck == "bad.nml" and (err.group, err.key) == (group, key), str(err)
    assert words in str(err)
    assert not (tmp_path / "out").exists()


def test_parse_problems_print_nothing(tmp_path, capfd):
    """f90nml prints a table to stdout on an unclosed quote: captured, never shown."""
    with pytest.raises(pydriver.DeckError):
        deck_from_text(SIX.replace("'clamped'", "'clamped"), "bad.nml")
    out, err = capfd.readouterr()
    assert out == "" and err == ""


# ---- the schema drives the reference and is read once --------------------------------------

def test_deck_reference_is_current():
    """docs/deck_reference.md is generated from the schema (python -m pydriver.deck_reference)."""
    assert (ROOT / "docs" / "deck_reference.md").read_text() == reference_markdown() + "\n"


def test_every_key_is_documented():
    for k in KEYS:
        assert k.doc, f"{k.group}.{k.name} has no doc"
        assert k.shape in ("scalar", "vec3", "body", "joint", "list")


def test_deck_file_is_opened_once(monkeypatch, tmp_path):
    """One run reads its deck file once: the model is built from the validated values, not
    from the path (the old core opened the file six times per run)."""
    p = tmp_path / "uh60_part2_decay.nml"
    p.write_text((INPUTS / "uh60_part2_decay.nml").read_text().replace("t_end = 1.0", "t_end = 0.02"))
    opened = []
    real_open = io.open              # builtins.open, Path.open and Path.read_text all come here

    def counting_open(file, *a, **kw):
        if str(file) == str(p):
            opened.append(file)
        return real_open(file, *a, **kw)

    monkeypatch.setattr(builtins, "open", counting_open)
    monkeypatch.setattr(io, "open", counting_open)
    pydriver.run_deck(p, out=tmp_path / "out")
    assert len(opened) == 1, opened


def test_with_changes_varies_a_model_without_text():
    m = pydriver.Model.from_deck(INPUTS / "uh60_part2_modal.nml")
    soft = m.with_changes({"springs.c_beta": 20.0})
    assert soft.deck["springs.c_beta"][1] == 20.0 and m.deck["springs.c_beta"][1] == 35.531
    with pytest.raises(pydriver.DeckError) as exc:
        m.with_changes({"springs.c_beta": -1.0})
    assert exc.value.key == "c_beta" and "negative" in str(exc.value)
    f_soft = pydriver.run_deck(soft).summary["frequencies_hz"][0]
    f = pydriver.run_deck(m).summary["frequencies_hz"][0]
    assert f_soft < f                     # a softer spring, a lower first frequency
