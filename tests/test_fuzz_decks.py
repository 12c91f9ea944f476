"""A fixed corpus of mutated decks (issue 10): every input gives exactly one of two outcomes.

* A DeckError naming the deck, and the group and the key (a namelist that cannot be parsed
  at all names no key: then the reason says so), or a RunError naming the deck; in both cases
  no output is left behind.
* Or a run whose results are finite, whose solver converged and whose constraints hold to
  the stated accuracy.

Any other exception (a KeyError, a numpy warning turned error, a crash of the interpreter) or
a non-finite number in a result fails the test.  The corpus is built from the shipped decks
with a fixed seed, so a failure is reproducible by its index.
"""

from __future__ import annotations

import re

import numpy as np
import pytest

import pydriver
from conftest import INPUTS
from pydriver.deckfile import patch_deck

BASES = ["six_link_static", "six_link_dynamic", "three_body", "uh60_part1", "uh60_part2_hover",
         "uh60_part2_modal", "uh60_part2_decay", "cantilever_check"]
VALUES = ["-1.0", "0", "0.0", "1e400", "-1e400", "nan", "1.0e300", "1e-300", "abc", "'text'", ".true.", "",
          "3*", "1.0, 2.0", "1.0d0", "-0.0", "7", "2*1.5", ", ,", "1e15", "-273.15"]
N_DECKS = 120


def _short(stem: str, tmp_path):
    """The base deck with a short run and a small step budget (the corpus must run fast)."""
    src = INPUTS / f"{stem}.nml"
    dst = tmp_path / f"base_{stem}.nml"
    return patch_deck(src, dst, {"solver": {"t_end": "0.02", "dt_out": "0.01", "max_steps": "20000",
                                            "newton_max_iter": "60"}}).read_text()


def mutate(text: str, rng: np.random.Generator) -> str:
    """One random mutation of a deck's text."""
    lines = text.splitlines()
    assign = [i for i, ln in enumerate(lines) if "=" in ln and not ln.lstrip().startswith("!")]
    op = rng.integers(0, 11)
    if op <= 2 and assign:                                     # a value replaced
        i = int(rng.choice(assign))
        key, _, _ = lines[i].partition("=")
        lines[i] = f"{key}= {rng.choice(VALUES)}"
    elif op >= 9 and assign:                                   # numbers scaled: valid, extreme
        i = int(rng.choice(assign))
        factor = float(rng.choice([0.5, 2.0, 10.0, 1e-3, 1e3, -1.0]))
        lines[i] = re.sub(r"(?<![\w.])(\d+\.\d*(?:[eE][-+]?\d+)?)", lambda m: repr(float(m.group(1)) * factor),
                          lines[i])
    elif op == 3 and assign:                                   # an assignment dropped
        del lines[int(rng.choice(assign))]
    elif op == 4:                                              # a group dropped or doubled
        groups = re.findall(r"&\w+[^/]*?\n\s*/", text, re.S)
        if not groups:
            return text + "\n&chain\n/\n"
        g = groups[int(rng.integers(len(groups)))]
        return text.replace(g, "" if rng.random() < 0.5 else g + "\n" + g, 1)
    elif op == 5:                                              # n_bodies changed
        return re.sub(r"n_bodies\s*=\s*\d+", f"n_bodies = {int(rng.choice([-1, 0, 1, 2, 3, 40]))}", text)
    elif op == 6:                                              # text cut off
        return text[:int(rng.integers(1, len(text)))]
    elif op == 7:                                              # a stray character
        k = int(rng.integers(len(text)))
        return text[:k] + str(rng.choice(["(", "'", "&", "/", "*", "=", '"', ","])) + text[k:]
    else:                                                      # an unknown or misplaced key
        i = int(rng.choice(assign)) if assign else 0
        lines.insert(i, str(rng.choice(["  lenght = 1.0", "  analysis = 'dynamic'", "  c_beta = 1.0",
                                        "  rotor_rpm = 260.0", "  pulse_body = 3", "  joint = 'xy'",
                                        "  tip_force = 0.0, 0.0, 1.0", "  start = 'equilibrium'"])))
    return "\n".join(lines) + "\n"


def corpus(tmp_path):
    rng = np.random.default_rng(20261122)
    bases = {stem: _short(stem, tmp_path) for stem in BASES}
    for k in range(N_DECKS):
        stem = BASES[k % len(BASES)]
        text = mutate(bases[stem], rng)
        if rng.random() < 0.3:
            text = mutate(text, rng)                           # sometimes two mutations
        yield k, stem, text


def test_mutated_decks_fail_cleanly_or_run_correctly(tmp_path):
    outcomes = {"deck error": 0, "run error": 0, "ran": 0}
    for k, stem, text in corpus(tmp_path):
        path = tmp_path / f"fuzz{k:03d}_{stem}.nml"
        path.write_text(text)
        out = tmp_path / f"out{k:03d}"
        try:
            res = pydriver.run_deck(path, out=out)
        except pydriver.DeckError as err:
            outcomes["deck error"] += 1
            assert err.deck == path.name, (k, str(err))
            assert (err.group and err.key) or err.group and "group" in err.reason or \
                "namelist" in err.reason, (k, str(err))
            assert not out.exists(), k
            continue
        except pydriver.RunError as err:
            outcomes["run error"] += 1
            assert path.name in str(err), (k, str(err))
            assert not out.exists(), k
            continue
        outcomes["ran"] += 1
        s = res.summary
        assert (out / "summary.json").is_file(), k
        for name in ("table", "timeseries"):
            cols = getattr(res, name)
            if cols:
                assert all(np.all(np.isfinite(np.asarray(v, float))) for v in cols.values()), (k, name)
        # Converged and closed: the statics test passed (else RunError), the constraints hold.
        assert s["max_constraint_violation_m"] < 1e-6, (k, s["max_constraint_violation_m"])
    # The corpus exercises both outcomes (a corpus that only ever fails proves little).
    assert outcomes["deck error"] > 30 and outcomes["ran"] > 10, outcomes
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".out")]
