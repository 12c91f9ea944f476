"""Lexical checks of a deck's text that f90nml does not make.

f90nml reads ``pitch_deg = 1.2.3`` silently as ``1.2, 0.3``, ``c_beta = 1-70`` as 1e-70 (the
Fortran exponent without a letter) and expands ``beta_deg = 2000000000*1.0`` into two billion
Python floats before any check can run (24 s, then MemoryError).  These checks run on the
comment-free text before f90nml sees it (issue 20) and raise the deck's DeckError naming the
group and the key.

Hand-written because no namelist library offers them; the work is done by compiled regular
expressions (valid numbers are removed in one substitution, only what is left is looked at),
so a deck with a table of a million samples is checked in well under a second.
"""

from __future__ import annotations

import re

from pydriver.errors import DeckError

#: The largest repeat count ``r*value`` a deck may use: ten times the longest body/joint array
#: (n_bodies <= 2000) and enough for any table typed by repeat counts; f90nml expands a repeat
#: into a Python list at ~10 us per value, so this also bounds the parse time (~0.2 s).
MAX_REPEAT = 20_000
#: The sum of all repeat counts of one deck (the same bound on memory and time for the deck).
MAX_REPEAT_TOTAL = 100_000

_STRING = re.compile(r"""'(?:[^'\n]|'')*'|"(?:[^"\n]|"")*\"""")
_REPEAT = re.compile(r"(?<![\w.+\-])(\d+)\s*\*")
# A valid real or integer with its own boundaries: not glued to a name, a dot or a sign-led
# exponent (so '1.2.3' and '1-70' are left for the check below).
_VALID_NUMBER = re.compile(r"(?<![\w.+\-])[-+]?(?:\d+\.?\d*|\.\d+)(?:[eEdD][-+]?\d+)?(?![\w.+\-])")
_NUMBER_LIKE = re.compile(r"(?<![\w.'\"+\-])[-+]?(?:\d|\.\d)[\w.+\-]*")
_GROUP = re.compile(r"&(\w+)")
_ASSIGN = re.compile(r"([A-Za-z_]\w*)\s*(?:\([^)=]*\))?\s*=")


def _blank_strings(text: str) -> str:
    """The text with every quoted string replaced by ``'S'``-like filler of the same length
    (positions are kept, so a later message can name the key at a position)."""
    return _STRING.sub(lambda m: "'" + "S" * (len(m.group(0)) - 2) + "'", text)


def _where(text: str, pos: int) -> tuple[str, str]:
    """(group, key) of the assignment the position ``pos`` belongs to."""
    group_end, group = 0, ""
    for m in _GROUP.finditer(text, 0, pos):
        group_end, group = m.end(), m.group(1).lower()
    key = ""
    for m in _ASSIGN.finditer(text, group_end, pos):
        key = m.group(1).lower()
    return group, key


def check_tokens(text: str, deck: str) -> None:
    """Refuse malformed numbers and huge repeat counts in a comment-free namelist text.

    Raises
    ------
    DeckError
        Naming the group and the key of the first offending value.
    """
    plain = _blank_strings(text)
    total = 0
    for m in _REPEAT.finditer(plain):
        count = int(m.group(1))
        total += count
        if count > MAX_REPEAT or total > MAX_REPEAT_TOTAL:
            group, key = _where(plain, m.start())
            what = (f"repeat count {count}* is larger than any array of a deck (at most {MAX_REPEAT})"
                    if count > MAX_REPEAT else
                    f"the repeat counts of the deck add up to more than {MAX_REPEAT_TOTAL} values")
            raise DeckError(deck, group, key, what)
    rest = _VALID_NUMBER.sub(lambda m: " " * len(m.group(0)), _REPEAT.sub(
        lambda m: " " * len(m.group(0)), plain))
    for m in _NUMBER_LIKE.finditer(rest):
        token = m.group(0)
        group, key = _where(plain, m.start())
        hint = ""
        if re.fullmatch(r"[-+]?(?:\d+\.?\d*|\.\d+)[-+]\d+", token):
            written = re.sub(r"([-+]\d+)$", r"e\1", token)
            hint = (f": write {written} (the Fortran exponent without a letter is refused, it "
                    "reads like arithmetic)")
        elif token.count(".") > 1:
            hint = ": a number has at most one decimal point (separate values with commas)"
        raise DeckError(deck, group, key, f"'{token}' is not a number{hint}")
