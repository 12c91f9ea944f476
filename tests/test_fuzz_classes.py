"""Every shipped deck mutated in each class of bad input found by the second reliability pass
(issue 20): out-of-range integers, huge repeat counts, denormals, reversed ranges, single values
for pairs and triples, malformed reals, and lone scalars for shape arrays.

Each mutated deck must give exactly one of two outcomes:

* a DeckError naming the deck, the group and the key (within 2 s: before any model is built or
  large allocation made), or a RunError naming the deck; nothing is left behind;
* or a run whose every output is finite, whose reactions are plausible (below 1e6 N: the
  shipped decks carry at most a few hundred newtons, and none of these mutations adds load)
  and whose files are all in its output directory.

The keys of each class are drawn with a fixed seed from the keys each deck sets (and the
schema's integer and range keys), so a failure is reproducible by its id.  The checks are the
classes, not the cases listed in the issue.
"""

from __future__ import annotations

import re
import time

import numpy as np
import pytest

import pydriver
from conftest import INPUTS
from pydriver.deckfile import read_deck
from pydriver.schema import GROUPS
from pydriver.study import override_deck

# A numpy warning (0/0, overflow) on the way to an answer is a defect of the same kind.
pytestmark = pytest.mark.filterwarnings("error::RuntimeWarning")

DECKS = sorted(p.stem for p in INPUTS.glob("*.nml"))
KEYS_PER_CLASS = 4
#: Short runs: the classes are about input handling, not long integrations.
SHORT = {"solver": {"t_end": "0.02", "dt_out": "0.01", "max_steps": "20000", "newton_max_iter": "60",
                    "samples_per_rev": "36", "max_revolutions": "12",
                    # The main job's Floquet analysis is a second run with 54 IDAS sensitivities: the
                    # classes here test input handling, not it (tests/test_floquet.py does).
                    "floquet": ".false."}}


#: Bad &design values (tests/test_design_sensitivities.py and tests/test_design_optimiser.py have the
#: reasons): parameters, and the optimiser's keys (refused on any analysis but 'design', and on the
#: design deck for their values: an unknown objective, a bound count or order, out-of-range settings).
DESIGN_VALUES = [("parameters", v) for v in (
    "'chain.lenght'", "'solver.rtol'", "1.0", "''", "'loads.gravity(9)'", "'shape.beta_deg'",
    "'chain.total_length', 'chain.total_length'", "'loads.gravity'", ".true.")] + [
    ("objective", "'least_mass'"), ("lower", "1.0"), ("upper", "-1.0e9, 2.0"),
    ("frequency_margin_percent", "100.0"), ("method", "'newton'"), ("max_iterations", "0"),
    ("tolerance", "-1.0"), ("starts", "0"), ("starts", "4"), ("frequency_levels", "5")]


def short_base(stem: str, tmp_path):
    changes = {g: dict(k) for g, k in SHORT.items()}
    deck = read_deck(INPUTS / f"{stem}.nml")
    if deck["refinement.levels"] > 1:
        changes["refinement"] = {"levels": "1"}
    if deck["case.analysis"] == "campbell":
        changes["campbell"] = {"n_speeds": "5"}
    if deck["case.analysis"] == "design":
        # One start at the deck's n: the classes test input handling, not the optimiser's starts and
        # refined frequencies (tests/test_design_optimiser.py, tests/test_design_study.py do).
        changes["design"] = {"starts": "1", "frequency_levels": "1"}
    return override_deck(INPUTS / f"{stem}.nml", tmp_path / f"base_{stem}.nml", changes)


def set_value(text: str, group: str, key: str, value: str) -> str:
    """The deck text with ``group.key = value`` written as text (no parser in between, so that
    malformed values reach the reader as a user would type them)."""
    block = re.search(rf"(?ims)^&{group}\b.*?^\s*/", text)
    line = f"    {key} = {value}"
    if block is None:
        return text + f"\n&{group}\n{line}\n/\n"
    body = block.group(0)
    new, count = re.subn(rf"(?im)^\s*{key}\s*(\(\s*\d+\s*\))?\s*=.*$", lambda m: line, body, count=1)
    if not count:
        new = body.replace("\n", "\n" + line + "\n", 1)
    return text[:block.start()] + new + text[block.end():]


def given_keys(deck):
    return [(g, k) for (g, k) in sorted(deck.given)]


def mutations(stem: str, deck, rng):
    """(class, group, key, value text) of each mutation of one deck."""
    n = deck.n_bodies
    given = given_keys(deck)
    reals = [(g, k) for g, k in given if GROUPS[g][k].type == "real"]
    arrays = [(g, k) for g, k in given if GROUPS[g][k].is_array]
    ints = [(g, k) for g, keys in GROUPS.items() for k, key in keys.items()
            if key.type == "int" and (g in deck.groups or g == "solver")]
    pairs = [(g, k) for g, k in given if GROUPS[g][k].shape in ("list", "vec3") and GROUPS[g][k].type != "str"
             and deck[f"{g}.{k}"] is not None and len(deck[f"{g}.{k}"]) >= 2]
    shapes = [(g, k) for g, keys in GROUPS.items() for k, key in keys.items()
              if not key.broadcast and (g in deck.groups)]

    def pick(cands, count=KEYS_PER_CLASS):
        if len(cands) <= count:
            return list(cands)
        return [cands[i] for i in sorted(rng.choice(len(cands), count, replace=False))]

    out = []
    for g, k in pick(ints):
        out.append(("int32", g, k, str(int(rng.choice([3_000_000_000, -2_147_483_649, 10**20])))))
    for g, k in pick(arrays):
        out.append(("repeat", g, k, "2000000000*1.0"))
    for g, k in pick(reals):
        key = GROUPS[g][k]
        tiny = str(rng.choice(["4.9e-324", "-4.9e-324", "2.2e-308"]))
        length = {"body": n, "joint": n, "vec3": 3}.get(key.shape)
        out.append(("denormal", g, k, f"{length}*{tiny}" if length else tiny))
    for g, k in pick([p for p in pairs if GROUPS[p[0]][p[1]].shape == "list"]) + \
            ([("loads", "pulse_start")] if deck["loads.pulse_body"] > 0 else []):
        if k == "pulse_start":       # a time range given backwards
            out.append(("reversed", "loads", "pulse_start", repr(float(deck["loads.pulse_end"]) + 0.05)))
        else:
            v = np.asarray(deck[f"{g}.{k}"], float)[::-1]
            out.append(("reversed", g, k, ", ".join(repr(float(x)) for x in v)))
    for g, k in pick(pairs):
        out.append(("single", g, k, repr(float(np.asarray(deck[f"{g}.{k}"], float)[0]))))
    for g, k in pick(reals):
        out.append(("malformed", g, k, str(rng.choice(["1.2.3", "1-70", "1e", "--1.0", "1.0e+", "2.5+1"]))))
    for g, k in pick(shapes):
        out.append(("scalar", g, k, str(rng.choice(["37.0", "-12.5", "90.0"]))))
    # &design parameters (issue 24): names that are no key, no differentiable key, no element, no
    # name at all; or any name on an analysis without sensitivities.  Their own generator, so that
    # the draws of the other classes stay as they were.
    for i in np.random.default_rng(sum(map(ord, stem))).choice(len(DESIGN_VALUES), 2, replace=False):
        key, value = DESIGN_VALUES[i]
        out.append(("design", "design", key, value))
    return out


def corpus(tmp_path):
    rng = np.random.default_rng(20261125)
    for stem in DECKS:
        base = short_base(stem, tmp_path)
        deck = read_deck(base)
        text = base.read_text()
        for i, (cls, g, k, value) in enumerate(mutations(stem, deck, rng)):
            yield f"{stem}-{cls}-{i}", cls, g, k, set_value(text, g, k, value)


def test_every_class_of_bad_input_fails_cleanly_or_runs_plausibly(tmp_path):
    outcomes = {"deck error": 0, "run error": 0, "ran": 0}
    classes = set()
    for id_, cls, g, k, text in corpus(tmp_path):
        classes.add(cls)
        case = tmp_path / id_
        case.mkdir()
        path = case / "deck.nml"
        path.write_text(text)
        out = case / "out"
        t0 = time.perf_counter()
        try:
            res = pydriver.run_deck(path, out=out)
        except pydriver.DeckError as err:
            outcomes["deck error"] += 1
            assert err.deck == "deck.nml" and err.group and err.key, (id_, str(err))
            assert time.perf_counter() - t0 < 2.0, (id_, "refused too late")
            assert sorted(p.name for p in case.iterdir()) == ["deck.nml"], id_
            continue
        except pydriver.RunError as err:
            outcomes["run error"] += 1
            assert "deck.nml" in str(err), (id_, str(err))
            assert sorted(p.name for p in case.iterdir()) == ["deck.nml"], id_
            continue
        outcomes["ran"] += 1
        assert sorted(p.name for p in case.iterdir()) == ["deck.nml", "out"], id_
        assert (out / "summary.json").is_file(), id_
        for name in ("table", "timeseries", "modes"):
            cols = getattr(res, name)
            if cols:
                assert all(np.all(np.isfinite(np.asarray(v, float))) for v in cols.values()), (id_, name)
        for support in res.summary.get("reactions", {}).values():
            assert np.all(np.abs(support["F"]) < 1e6), (id_, support)
    assert classes == {"int32", "repeat", "denormal", "reversed", "single", "malformed", "scalar", "design"}
    # Both outcomes occur (a corpus that only ever fails would prove little).
    assert outcomes["deck error"] > 100 and outcomes["ran"] > 10, outcomes
