"""Bad decks raise a Python exception naming the deck, the key and the reason (issue 2).

The interpreter must survive (library Fortran never stops) and no output file may be left.
"""

import subprocess
import sys

import pytest

import pydriver
from conftest import INPUTS, ROOT


CASES = [
    # (deck edit, expected group, expected key, words expected in the reason)
    (("six_link_static", "chain", {"lenth": "1.0"}), "chain", "lenth", "unknown key"),
    (("six_link_static", "chain", {"total_length": "-1.0"}), "chain", "total_length", "positive"),
    (("six_link_static", "chain", {"density": "-7801.0"}), "chain", "density", "positive"),
    (("three_body", "chain", {"total_mass": "-0.153"}), "chain", "total_mass", "positive"),
    (("six_link_static", "chain", {"n_bodies": "0"}), "chain", "n_bodies", "at least 1"),
    (("six_link_static", "chain", {"total_length": "abc"}), "chain", "total_length", "not a number"),
    (("six_link_static", "chain", {"n_bodies": "5.5"}), "chain", "n_bodies", "not an integer"),
    (("six_link_dynamic", "clamp_b", {"position": "3.0, 0.2, 0.0"}), "clamp_b", "position", "out of reach"),
    (("six_link_static", "case", {"analysis": "'modal_x'"}), "case", "analysis", "static"),
    (("six_link_static", "chain", {"first_body": "'welded'"}), "chain", "first_body", "clamped"),
    (("six_link_dynamic", "solver", {"linear_solver": "'lu'"}), "solver", "linear_solver", "block"),
    (("six_link_dynamic", "solver", {"jacobian_max_age": "0"}), "solver", "jacobian_max_age", "at least 1"),
    (("six_link_dynamic", "solver", {"vector_kernels": "'fast'"}), "solver", "vector_kernels", "compiled"),
]


@pytest.mark.parametrize("edit,group,key,reason", CASES)
def test_bad_value_names_deck_key_reason(deck_copy, tmp_path, edit, group, key, reason):
    stem, grp, assignments = edit
    deck = deck_copy(stem, grp, assignments)
    out = tmp_path / "out"
    with pytest.raises(pydriver.DeckError) as exc:
        pydriver.run_deck(deck, out=out)
    err = exc.value
    assert err.deck == deck.name and deck.name in str(err)
    assert err.group == group and err.key == key
    assert key in str(err) and reason in str(err)
    assert not out.exists()


def test_missing_group(deck_copy, tmp_path):
    deck = deck_copy("six_link_static", "chain", drop_group=True)
    with pytest.raises(pydriver.DeckError) as exc:
        pydriver.run_deck(deck, out=tmp_path / "out")
    assert exc.value.group == "chain" and "missing" in str(exc.value)
    assert deck.name in str(exc.value)
    assert not (tmp_path / "out").exists()


def test_missing_deck(tmp_path):
    with pytest.raises(pydriver.DeckError) as exc:
        pydriver.run_deck(tmp_path / "nope.nml")
    assert "nope.nml" in str(exc.value) and "not found" in str(exc.value)


def test_too_few_angles(deck_copy):
    deck = deck_copy("six_link_static", "shape", {"gamma_deg": "0.0, 0.0"})
    with pytest.raises(pydriver.DeckError) as exc:
        pydriver.run_deck(deck)
    assert exc.value.key == "gamma_deg" and "5 values" in str(exc.value)


def test_cli_reports_error_and_survives(deck_copy, tmp_path):
    # One bad and one good deck in a batch: the bad one is reported on stderr, the good one
    # still runs, the exit status is 1, and the bad one leaves no directory.
    bad = deck_copy("six_link_static", "chain", {"diameter": "-0.05"})
    proc = subprocess.run([sys.executable, "-m", "pydriver", "run", str(bad),
                           str(INPUTS / "six_link_static.nml")],
                          cwd=tmp_path, capture_output=True, text=True)
    assert proc.returncode == 1
    assert "diameter" in proc.stderr and bad.name in proc.stderr
    assert (tmp_path / "results" / "six_link_static" / "summary.json").is_file()
    assert not (tmp_path / "results" / bad.stem).exists()


def test_interpreter_survives_many_bad_decks(deck_copy):
    # Fortran `stop` would kill the process; a loop of failures must not.
    for i in range(20):
        deck = deck_copy("six_link_static", "chain", {"n_bodies": str(-i)})
        with pytest.raises(pydriver.DeckError):
            pydriver.run_deck(deck)
    assert pydriver.run_deck(INPUTS / "six_link_static.nml").summary["analysis"] == "static"


def test_no_stop_in_library_fortran():
    # Standing rule: library Fortran returns a status instead of stopping.
    import re
    for f in (ROOT / "src_fortran").glob("*.f90"):
        for line in f.read_text().splitlines():
            code = line.split("!")[0]
            assert not re.search(r"(^|\s)(error\s+)?stop\b", code, re.I), f"{f.name}: {line}"


def test_rejected_deck_can_be_read_again_after_fixing(deck_copy, tmp_path):
    """A deck rejected after its file was opened (n_bodies = 0 is checked inside the namelist
    read) must not leave the Fortran unit open: fixing the file and running it again in the
    same process has to work."""
    deck = deck_copy("six_link_static", "chain", {"n_bodies": "0"})
    for _ in range(2):                      # twice: the second rejection needs the file too
        with pytest.raises(pydriver.DeckError):
            pydriver.run_deck(deck)
    from pydriver.study import override_deck
    override_deck(deck, deck, {"chain": {"n_bodies": "5"}})
    res = pydriver.run_deck(deck)
    assert res.summary["reactions"]["B"]["F"][2] == pytest.approx(75.13, abs=0.01)
