"""Lexical checks of a deck's text that f90nml does not make.

f90nml reads ``pitch_deg = 1.2.3`` silently as ``1.2, 0.3``, ``c_beta = 1-70`` as 1e-70 (the
Fortran exponent without a letter) and expands ``beta_deg = 2000000000*1.0`` into two billion
Python floats before any check can run (24 s, then MemoryError).  These checks run on the
comment-free text before f90nml sees it (issue 20) and raise the deck's DeckError naming the
group and the key.

The structure of the groups is checked here too (issue 37): f90nml drops a group that follows
one not ended by ``/`` (``&case ... &chain ... /`` loses ``&chain``, and the deck was refused as
"group &chain is missing") and skips an assignment written after a group's ``/``, as a Fortran
namelist read does.  :func:`check_groups` names the group and its line instead.  A decimal
comma (``total_length = 0,590``: two values, 0 and 590) is found by :func:`comma_decimals`,
so that the reader can say so beside the error it causes.

Hand-written because no namelist library offers them; the work is done by compiled regular
expressions (valid numbers are removed in one substitution, only what is left is looked at),
so a deck with a table of a million samples is checked in well under a second.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

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
# A group's start (&name, $name) or end ('/', &end, $end).
_GROUP_MARK = re.compile(r"[&$]([A-Za-z_]\w*)|/")
# Two digit runs joined by a comma and set apart from what is around them (see comma_decimals).
_COMMA_PAIR = re.compile(r"(?<![^\s=*])[-+]?\d+,\d+(?![\w.]|,\S)")
# Where a value ends: the next assignment, group mark or '/'.
_VALUE_END = re.compile(r"[A-Za-z_]\w*\s*(?:\([^)=]*\))?\s*=|[&$/]")


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


def _line(text: str, pos: int) -> int:
    """The line number (from 1) of position ``pos``."""
    return text.count("\n", 0, pos) + 1


def check_groups(text: str, deck: str) -> None:
    """Refuse a group not ended by ``/`` and an assignment outside every group.

    ``text`` is the deck without comments but with its lines (the line numbers named are the
    deck file's).  A group ends with ``/`` (or the old ``&end``/``$end``); a group that meets the
    next ``&name`` or the end of the file first is not closed.

    Raises
    ------
    DeckError
        Naming the group that is not closed and its line, or the key outside every group.
    """
    plain = _blank_strings(text)
    opened: tuple[str, int] | None = None        # the group being read: (name, position)
    closed: tuple[str, int] | None = None        # the last group ended: (name, position of its '/')
    pos = 0
    for m in _GROUP_MARK.finditer(plain):
        if opened is None:
            _refuse_stray_assignment(plain, pos, m.start(), closed, deck)
        name = (m.group(1) or "").lower()
        if name and name != "end":
            if opened is not None:
                group, start = opened
                raise DeckError(deck, group, "", f"group &{group} (line {_line(plain, start)}) is not closed: end it "
                                                 f"with '/' before &{name} (line {_line(plain, m.start())})")
            opened = (name, m.start())
        elif opened is not None:                 # '/', '&end' or '$end' ends the group
            closed, opened = (opened[0], m.start()), None
        pos = m.end()
    if opened is not None:
        group, start = opened
        raise DeckError(deck, group, "", f"group &{group} (line {_line(plain, start)}) is not closed: end it with '/' "
                                         "(the file ends first)")
    _refuse_stray_assignment(plain, pos, len(plain), closed, deck)


def _refuse_stray_assignment(plain: str, start: int, end: int, closed, deck: str) -> None:
    """An assignment between groups (a namelist read skips it silently) is an error."""
    m = _ASSIGN.search(plain, start, end)
    if m is None:
        return
    key = m.group(1).lower()
    line = _line(plain, m.start())
    if closed is None:
        raise DeckError(deck, "", key, f"line {line}: '{key} = ...' comes before the first group (&name): a "
                                       "namelist read skips it; put it inside its group")
    group, slash = closed
    raise DeckError(deck, group, key, f"line {line}: '{key} = ...' comes after the '/' that ends &{group} "
                                      f"(line {_line(plain, slash)}): a namelist read skips it; move it before "
                                      "that '/' (or into the group it belongs to)")


@dataclass(frozen=True)
class CommaDecimal:
    """A number written with a decimal comma, ``0,590``: two values to a namelist."""

    token: str          #: as written, e.g. '0,590'
    alone: bool         #: the whole value of its assignment

    def hint(self) -> str:
        """What the token means and how to write the number."""
        whole, frac = self.token.split(",")
        return (f"'{self.token}' reads as two values, {whole} and {frac}: a decimal is written with a "
                f"point, {whole}.{frac} (the comma separates values)")


def comma_decimals(text: str) -> dict[tuple[str, str], CommaDecimal]:
    """{(group, key): the first decimal comma in the key's value} of a comment-free text.

    A decimal comma is two digit runs joined by a comma, set apart from the rest of the value
    (``0,590``, ``1,5, 2,5``, ``11*0,5``); a run of values all joined by commas (``1,2,3``) is
    an ordinary list and is not taken for one.
    """
    plain = _blank_strings(text)
    found: dict[tuple[str, str], CommaDecimal] = {}
    pos = 0
    while len(found) < 100:                      # enough to name the one an error meets
        m = _COMMA_PAIR.search(plain, pos)
        if m is None:
            break
        end = _VALUE_END.search(plain, m.end())
        pos = end.start() if end else len(plain)        # one per assignment: on to the next
        where = _where(plain, m.start())
        if not where[1] or where in found:
            continue
        equals = plain.rfind("=", 0, m.start())
        alone = not plain[equals + 1:m.start()].strip() and not plain[m.end():pos].strip(" \t\r\n,")
        found[where] = CommaDecimal(m.group(0), alone)
    return found


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
