"""Messages that point to the fix (issue 37): each class of deck mistake a new user makes is
refused with the deck, the group, the key and what to write instead, checked for every key or
group of the schema the class applies to (not for the one case the issue names).

The decks are read with :func:`pydriver.deckfile.deck_from_text` (the reader every command
uses); one test per class goes through the command line, where no traceback may show.
"""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from pydriver.deckfile import deck_from_text
from pydriver.errors import DeckError
from pydriver.examples import example_names, init_deck
from pydriver.schema import GROUPS, KEYS, groups_of

N = 3
#: A minimal valid deck (static, three bodies), group by group; the tests change one key or group.
BASE = {"case": {"analysis": "'static'"},
        "chain": {"n_bodies": str(N), "total_length": "1.0", "diameter": "0.01", "density": "1000.0"},
        "shape": {"gamma_deg": f"{N}*0.0", "beta_deg": f"90.0, {N - 1}*0.0"}}
HEADER = "! a deck of tests/test_deck_messages.py\n!\n"


def deck_lines(groups: dict, unclosed: str = "") -> list[str]:
    """The deck's lines: each group on its own lines, ended by '/' (except ``unclosed``)."""
    lines = HEADER.splitlines()
    for group, keys in groups.items():
        lines.append(f"&{group}")
        lines += [f"  {key} = {value}" for key, value in keys.items()]
        if group != unclosed:
            lines.append("/")
    return lines


def refusal(text: str) -> DeckError:
    with pytest.raises(DeckError) as exc:
        deck_from_text(text, "msg.nml")
    assert exc.value.deck == "msg.nml"
    return exc.value


def test_the_base_deck_reads():
    deck = deck_from_text("\n".join(deck_lines(BASE)) + "\n", "msg.nml")
    assert deck.n_bodies == N and deck["shape.beta_deg"][0] == 90.0


def _wrong_group(key) -> str:
    """A group without a key of this name (the next one in the schema's order, so that every
    group is a wrong host for some keys)."""
    order = list(GROUPS)
    start = order.index(key.group)
    return next(g for g in order[start + 1:] + order[:start] if key.name not in GROUPS[g])


class TestMisplacedKey:
    """A key of one group written in another (``t_end`` in ``&chain``) names the group(s) it
    belongs to, for every key of the schema."""

    @pytest.mark.parametrize("key", KEYS, ids=lambda k: f"{k.group}.{k.name}")
    def test_names_its_group(self, key):
        wrong = _wrong_group(key)
        groups = {g: dict(v) for g, v in BASE.items()}
        groups.setdefault(wrong, {})[key.name] = "1"
        err = refusal("\n".join(deck_lines(groups)) + "\n")
        assert (err.group, err.key) == (wrong, key.name), str(err)
        owners = groups_of(key.name)
        assert key.group in owners
        for owner in owners:
            assert f"&{owner}" in err.reason, str(err)
        assert "move it into" in err.reason

    def test_through_a_changed_value(self):
        """Deck.with_values (sweeps, --refine) says the same."""
        deck = deck_from_text("\n".join(deck_lines(BASE)) + "\n", "msg.nml")
        with pytest.raises(DeckError, match=r"t_end is a key of &solver; move it into &solver"):
            deck.with_values({"chain.t_end": 2.0})

    def test_a_misspelt_key_gets_the_closest_names(self):
        groups = {g: dict(v) for g, v in BASE.items()}
        groups["chain"]["n_bodys"] = groups["chain"].pop("n_bodies")
        err = refusal("\n".join(deck_lines(groups)) + "\n")
        assert err.key == "n_bodys" and "did you mean n_bodies" in err.reason

    def test_on_the_command_line(self, tmp_path):
        deck = tmp_path / "moved.nml"
        groups = {g: dict(v) for g, v in BASE.items()}
        groups["chain"]["t_end"] = "2.0"
        deck.write_text("\n".join(deck_lines(groups)) + "\n")
        done = subprocess.run([sys.executable, "-m", "pydriver", "run", str(deck), "--out", str(tmp_path / "o")],
                              capture_output=True, text=True)
        assert done.returncode == 1 and "Traceback" not in done.stderr
        assert "&chain key 't_end'" in done.stderr and "move it into &solver" in done.stderr
        assert not (tmp_path / "o").exists()


class TestUnclosedGroup:
    """A group not ended by '/' is named with its line, for every group, whether the next group
    or the end of the file comes first (f90nml drops the next group silently: the deck was
    refused as "group &chain is missing")."""

    @pytest.mark.parametrize("group", list(GROUPS))
    def test_before_the_next_group(self, group):
        key = next(iter(GROUPS[group]))
        if group in BASE:
            groups = dict(BASE)
        else:                      # the group between &case and &chain
            groups = {"case": BASE["case"], group: {key: "1"}, **{g: v for g, v in BASE.items() if g != "case"}}
        names = list(groups)
        following = names[names.index(group) + 1] if group != names[-1] else None
        lines = deck_lines(groups, unclosed=group)
        err = refusal("\n".join(lines) + "\n")
        line = lines.index(f"&{group}") + 1
        assert (err.group, err.key) == (group, ""), str(err)
        assert f"&{group} (line {line}) is not closed" in err.reason, str(err)
        if following:
            assert f"before &{following} (line {lines.index(f'&{following}') + 1})" in err.reason, str(err)
        else:
            assert "the file ends first" in err.reason

    @pytest.mark.parametrize("group", list(GROUPS))
    def test_at_the_end_of_the_file(self, group):
        lines = deck_lines(BASE) + [f"&{group}", f"  {next(iter(GROUPS[group]))} = 1"]
        err = refusal("\n".join(lines) + "\n")
        assert err.group == group and f"&{group} (line {len(lines) - 1}) is not closed" in err.reason, str(err)
        assert "the file ends first" in err.reason

    def test_the_case_of_the_issue_on_the_command_line(self, tmp_path):
        lines = deck_lines(BASE, unclosed="case")
        deck = tmp_path / "open.nml"
        deck.write_text("\n".join(lines) + "\n")
        done = subprocess.run([sys.executable, "-m", "pydriver", "run", str(deck), "--out", str(tmp_path / "o")],
                              capture_output=True, text=True)
        assert done.returncode == 1 and "Traceback" not in done.stderr
        assert "&case (line 3) is not closed: end it with '/' before &chain (line 5)" in done.stderr
        assert "missing" not in done.stderr

    def test_a_key_after_the_slash_names_its_line(self):
        """A namelist read skips an assignment between groups: refused, with the group it follows."""
        lines = deck_lines(BASE)
        lines.insert(lines.index("&shape"), "  first_body = 'pivot'")
        err = refusal("\n".join(lines) + "\n")
        where = lines.index("  first_body = 'pivot'") + 1
        assert (err.group, err.key) == ("chain", "first_body")
        assert f"line {where}" in err.reason and "after the '/' that ends &chain" in err.reason

    def test_old_terminators_and_slashes_in_strings_are_kept(self):
        text = ("&case analysis = 'static', description = 'a/b &c' &end\n"
                "$chain n_bodies = 3, total_length = 1.0, diameter = 0.01, density = 1000.0 $end\n"
                "&shape gamma_deg = 3*0.0, beta_deg = 90.0, 2*0.0 /\n")
        assert deck_from_text(text, "old.nml")["case.description"] == "a/b &c"


REAL_KEYS = [k for k in KEYS if k.type == "real"]


def _comma_value(key) -> str:
    """The key's value written with decimal commas: 1.5 as '1,5', as many as the key takes."""
    return {"scalar": "1,5", "list": "1,5, 2,5"}.get(key.shape, ", ".join(["1,5"] * (3 if key.shape == "vec3" else N)))


class TestCommaDecimal:
    """``total_length = 0,590`` is two values to a namelist; the refusal says the number is
    written with a point, for every real key (a fixed count: beside the count error; a list:
    refused at once, since any count is valid)."""

    @pytest.mark.parametrize("key", REAL_KEYS, ids=lambda k: f"{k.group}.{k.name}")
    def test_is_recognised(self, key):
        groups = {g: dict(v) for g, v in BASE.items()}
        groups.setdefault(key.group, {})[key.name] = _comma_value(key)
        err = refusal("\n".join(deck_lines(groups)) + "\n")
        assert (err.group, err.key) == (key.group, key.name), str(err)
        assert "'1,5' reads as two values, 1 and 5: a decimal is written with a point, 1.5" in err.reason, str(err)

    def test_the_issues_case(self):
        groups = {g: dict(v) for g, v in BASE.items()}
        groups["chain"]["total_length"] = "0,590"
        err = refusal("\n".join(deck_lines(groups)) + "\n")
        assert err.reason.startswith("takes one value, got 2; '0,590' reads as two values, 0 and 590")
        assert "0.590" in err.reason

    def test_a_rule_on_the_partner_key_names_it(self):
        """A speed table: table_t = 0,0, 10,0 against three speeds (refused at once: a list), and
        the rule's error on table_rpm when table_t is a lone pair read as two times."""
        groups = {g: dict(v) for g, v in BASE.items()}
        groups["case"]["analysis"] = "'dynamic'"
        groups["rotor"] = {"profile": "'table'", "table_t": "0,5", "table_rpm": "0.0, 100.0, 200.0"}
        deck = deck_from_text("\n".join(deck_lines(groups)) + "\n", "msg.nml")
        np.testing.assert_array_equal(deck["rotor.table_t"], [0.0, 5.0])     # Fortran's reading, kept
        from pydriver.deck_rules import check
        with pytest.raises(DeckError) as exc:
            check(deck)
        assert exc.value.key == "table_rpm" and "note &rotor table_t: '0,5' reads as two values" in str(exc.value)

    @pytest.mark.parametrize("text,expect", [("position = 0,1,0", [0.0, 1.0, 0.0]),
                                             ("position = 0.0,1.0,0.0", [0.0, 1.0, 0.0]),
                                             ("position = 0, 1, 0", [0.0, 1.0, 0.0])])
    def test_lists_joined_by_commas_stay_lists(self, text, expect):
        """Values all joined by commas (``0,1,0``) are an ordinary namelist list."""
        lines = deck_lines(BASE) + ["&ball_b", "  active = .true.", f"  {text}", "/"]
        np.testing.assert_array_equal(deck_from_text("\n".join(lines) + "\n", "msg.nml")["ball_b.position"], expect)


class TestOtherNumberOfBodies:
    """A deck switched to another n_bodies: each per-body or per-joint key says how to follow,
    and doing what it says gives a deck that reads."""

    def switched(self, n: int, **changes) -> str:
        groups = {g: dict(v) for g, v in BASE.items()}
        groups["chain"]["n_bodies"] = str(n)
        for dotted, value in changes.items():
            group, key = dotted.split("__")
            groups.setdefault(group, {})[key] = value
        return "\n".join(deck_lines(groups)) + "\n"

    @pytest.mark.parametrize("key", ["gamma_deg", "beta_deg"])
    def test_a_shape_points_to_resample(self, key):
        other = {"gamma_deg": "shape__beta_deg", "beta_deg": "shape__gamma_deg"}[key]
        fine = f"{2 * N}*0.0" if key == "gamma_deg" else f"90.0, {2 * N - 1}*0.0"
        err = refusal(self.switched(2 * N, **{other: fine}))
        assert (err.group, err.key) == ("shape", key)
        assert f"needs {2 * N} values (one per body), got {N}" in err.reason
        assert "&shape resample = .true." in err.reason and "rotorcable keys shape.resample" in err.reason
        deck = deck_from_text(self.switched(2 * N, shape__resample=".true."), "msg.nml")      # the fix
        assert deck.n_bodies == 2 * N and len(deck["shape.beta_deg"]) == 2 * N

    def test_a_shape_of_more_bodies_says_how_many(self):
        err = refusal(self.switched(2, shape__gamma_deg="2*0.0"))
        assert err.key == "beta_deg" and "give 2 values" in err.reason

    @pytest.mark.parametrize("key", [k.name for k in GROUPS["springs"].values()])
    def test_joint_constants_point_to_cable(self, key):
        err = refusal(self.switched(N, **{f"springs__{key}": "1.0, 2.0"}))
        assert (err.group, err.key) == ("springs", key)
        assert "&cable ei" in err.reason and "rotorcable keys cable" in err.reason

    def test_one_value_for_every_body_says_n_times(self):
        err = refusal(self.switched(2 * N, shape__gamma_deg=f"{2 * N}*0.0", shape__beta_deg=f"{2 * N}*1.0",
                                    chain__diameter=f"{N}*0.01"))
        assert err.key == "diameter" and f"write {2 * N}*0.01" in err.reason


class TestInitLike:
    """``init --like`` takes an example's name with its suffix, and a wrong name gets the closest."""

    def test_the_suffix_is_accepted(self, tmp_path):
        path = init_deck(tmp_path / "mine.nml", "uh60_part2_modal.nml")
        text = path.read_text()
        assert "from the example 'uh60_part2_modal'" in text and "name = 'mine'" in text
        assert deck_from_text(text, "mine.nml")["case.analysis"] == "modal"

    @pytest.mark.parametrize("typed,closest", [("uh60_part2_modl", "uh60_part2_modal"),
                                               ("six_link_statc.nml", "six_link_static"),
                                               ("UH60_part2_hover", "uh60_part2_hover")])
    def test_a_wrong_name_suggests_the_closest(self, tmp_path, typed, closest):
        with pytest.raises(ValueError) as exc:
            init_deck(tmp_path / "mine.nml", typed)
        message = str(exc.value)
        assert f"did you mean {closest}" in message
        assert all(name in message for name in example_names())              # and lists them all
        assert not (tmp_path / "mine.nml").exists()

    def test_on_the_command_line(self, tmp_path):
        done = subprocess.run([sys.executable, "-m", "pydriver", "init", "x.nml", "--like", "three_bodys"],
                              capture_output=True, text=True, cwd=tmp_path)
        assert done.returncode == 2 and "Traceback" not in done.stderr and "did you mean three_body" in done.stderr
