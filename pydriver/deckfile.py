"""Reading a deck: Fortran namelist text -> validated values, by f90nml and the schema.

f90nml (PyPI) gives the namelist semantics (repeat counts ``10*3.05``, element assignments
``key(3) = ...``, one-line groups, tabs, long lines); comments (``!`` to the end of the line)
are stripped before f90nml sees the text (:func:`strip_comments`); :mod:`pydriver.schema` says what
each key must be.  Every problem becomes a :class:`~pydriver.errors.DeckError` naming the deck,
the group, the key and the reason.  Cross-key rules come afterwards (:mod:`pydriver.deck_rules`).
"""

from __future__ import annotations

import contextlib
import io
import math
import re
import warnings
from dataclasses import dataclass, field, replace
from pathlib import Path

import f90nml
import numpy as np

from pydriver.deck_tokens import CommaDecimal, check_groups, check_tokens, comma_decimals
from pydriver.errors import DeckError
from pydriver.schema import GROUPS, REQUIRED_GROUPS, Key, lookup, unknown_key_reason
from pydriver.shape_resample import resample

# Comments and blank lines are removed before f90nml sees the text: its scanner walks the text
# one character at a time in Python (26 s for 10 MB of comment lines), a compiled regular
# expression does it in milliseconds.  Quoted strings are kept whole ('it''s' doubles a quote).
_COMMENT = re.compile(r"""('(?:[^'\n]|'')*'|"(?:[^"\n]|"")*")|![^\n]*""")
_BLANK_LINES = re.compile(r"\n[ \t\r]*(?=\n)")
# Long plain lists of numbers (a table of thousands of samples) are parsed by numpy, and
# f90nml sees a single sentinel in their place: f90nml spends ~10 us per value in Python
# (6 s for a 14 MB table).  Only lists that are nothing but numbers qualify (no repeat
# counts, nulls or strings) and that end where the next assignment, '/' or '&' begins, so
# the namelist meaning is unchanged; anything else stays f90nml's.  A run of number
# characters is found first (one character class: fast), then checked token by token.
_NUMBER_RUN = re.compile(r"=([ \t\r\n]*)([0-9eEdD.+\-,\s]{2048,})")
_NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eEdD][-+]?\d+)?")
_NEXT = re.compile(r"[ \t\r\n,]*(?:/|&|[A-Za-z_]\w*[ \t\r\n]*(?:\(|=))")
_SENTINEL = -7_316_502_489_151
#: The core's integers are 32-bit (f2py ``integer``): a larger deck integer cannot reach it.
INT32_MAX = 2**31 - 1


@dataclass
class Deck:
    """A validated deck: every schema key of every group, defaults filled in.

    Attributes
    ----------
    name : str
        The deck's file name (for messages).
    values : dict
        ``values[group][key]``: float, int, bool, str, or a numpy array for array keys;
        None where a key has no default and was not given.
    given : set of (group, key)
        The keys the deck sets explicitly.
    groups : set of str
        The groups present in the deck.
    path : Path or None
        The file it was read from.
    """

    name: str
    values: dict
    given: set = field(default_factory=set)
    groups: set = field(default_factory=set)
    path: Path | None = None
    raw: dict = field(default_factory=dict, repr=False)      #: f90nml's values, per group
    starts: dict = field(default_factory=dict, repr=False)   #: f90nml's start indices
    #: {(group, key): CommaDecimal} of the real keys whose text has a decimal comma (``0,590``):
    #: named beside any error of that key or of its group (:func:`with_comma_hint`)
    comma_decimals: dict = field(default_factory=dict, repr=False)

    def with_values(self, changes: dict) -> "Deck":
        """A new deck with ``changes = {"group.key": value}`` (Python values or namelist
        value texts), validated like a deck read from a file."""
        raw = {g: dict(v) for g, v in self.raw.items()}
        starts = {g: dict(v) for g, v in self.starts.items()}
        n_new = changes.get("chain.n_bodies", self.n_bodies)
        for dotted, value in changes.items():
            group, _, name = dotted.lower().partition(".")
            key = lookup(group, name)
            if key is None:
                raise DeckError(self.name, group, name, unknown_key_reason(group, name) if group in GROUPS
                                else f"unknown group &{group}")
            if isinstance(value, str) and (key.type != "str" or value[:1] in "'\""):
                value = parse_value_text(key, value, self.name)
            if isinstance(value, np.ndarray):
                value = value.tolist()
            elif isinstance(value, tuple):
                value = list(value)
            elif key.shape in ("body", "joint") and isinstance(value, (int, float)) \
                    and not isinstance(value, bool):
                # A Python number on a per-body key sets every body (numpy's broadcast); only
                # deck text follows Fortran's element-1 reading (see normalize).
                value = [value] * int(n_new)
            raw.setdefault(group, {})[name] = value
            starts.get(group, {}).pop(name, None)
        deck = validate(raw, starts, self.name)
        deck.path = self.path
        deck.comma_decimals = {gk: c for gk, c in self.comma_decimals.items()
                               if ".".join(gk) not in {d.lower() for d in changes}}
        return deck

    def __getitem__(self, dotted: str):
        group, key = dotted.split(".")
        return self.values[group][key]

    def has(self, dotted: str) -> bool:
        """True when ``group.key`` was set in the deck (not just defaulted)."""
        group, key = dotted.split(".")
        return (group, key) in self.given

    @property
    def n_bodies(self) -> int:
        return int(self.values["chain"]["n_bodies"])

    def fail(self, group: str, key: str, reason: str):
        """Raise the DeckError of this deck (with the decimal comma it may come from)."""
        raise with_comma_hint(DeckError(self.name, group, key, reason), self.comma_decimals)


def with_comma_hint(err: DeckError, commas: dict) -> DeckError:
    """``err`` with the decimal comma of its key, or of another real key of its group, named
    beside its reason (a rule may name the partner of the key written with one: table_rpm for
    table_t)."""
    comma = commas.get((err.group, err.key))
    if comma is not None:
        return DeckError(err.deck, err.group, err.key, f"{err.reason}; {comma.hint()}")
    other = next(((k, c) for (g, k), c in commas.items() if g == err.group), None)
    if other is None:
        return err
    return DeckError(err.deck, err.group, err.key, f"{err.reason}; note &{err.group} {other[0]}: {other[1].hint()}")


def strip_comments(text: str) -> str:
    """The namelist text without comments and blank lines (quoted strings untouched)."""
    return _BLANK_LINES.sub("", _COMMENT.sub(lambda m: m.group(1) or "", text))


def _fast_tables(text: str, tables: list) -> str:
    """Replace long plain number lists by sentinels; their arrays go to ``tables``."""
    out, pos = [], 0
    for m in _NUMBER_RUN.finditer(text):
        body = m.group(2)
        # The run may have swallowed the start of the next name ("..., 2.0  d_beta" stops at
        # '_'): cut back to the last character that can end a number.
        end = len(body.rstrip())
        while end and body[end - 1] not in "0123456789.":
            end -= 1
        head = body[:end]
        tokens = head.replace(",", " ").split()
        if (len(tokens) < 256 or re.search(r",\s*,", head)
                or not _NEXT.match(text, m.start(2) + end)
                or not all(_NUMBER.fullmatch(tok) for tok in (tokens[0], tokens[-1]))):
            continue
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            try:
                values = np.fromstring(head.replace("d", "e").replace("D", "e").replace(",", " "), sep=" ")
            except (ValueError, DeprecationWarning):
                continue
        if values.size != len(tokens):
            continue
        tables.append(values)
        out.append(text[pos:m.start(2)])
        out.append(str(_SENTINEL + len(tables) - 1))
        pos = m.start(2) + end
    out.append(text[pos:])
    return "".join(out)


def parse_namelist(text: str, deck: str):
    """f90nml's parse of a namelist text; any parse problem becomes a DeckError.

    f90nml's warnings (a value it would drop, e.g. ``a(3) = 1, 2``) are errors here, and what
    it prints on malformed input is captured, never shown.
    """
    check_tokens(text, deck)
    sink = io.StringIO()
    tables: list[list[float]] = []

    text = _fast_tables(text, tables)
    try:
        with warnings.catch_warnings(), contextlib.redirect_stdout(sink):
            warnings.simplefilter("error")
            nml = f90nml.reads(text)
        if tables:
            for group in nml.values():
                for body in (group if isinstance(group, list) else [group]):
                    for key, value in body.items():
                        if isinstance(value, int) and not isinstance(value, bool) and \
                                _SENTINEL <= value < _SENTINEL + len(tables):
                            body[key] = tables[value - _SENTINEL]
        return nml
    except Warning as exc:
        msg = str(exc).replace("f90nml: warning: ", "")
        raise DeckError(deck, "", "", f"namelist: {msg} (an element assignment a(i) = takes one "
                                      "value; give the whole array, a(i:j) = ..., or one element "
                                      "per assignment)") from None
    except Exception as exc:                       # f90nml raises several types on bad text
        detail = str(exc) or type(exc).__name__
        raise DeckError(deck, "", "", f"not a valid Fortran namelist ({detail}): check for an "
                                      "unclosed quote or parenthesis, or a group not ended by '/'") from None


def read_deck(path) -> Deck:
    """Read and validate a deck file.

    Raises
    ------
    DeckError
        Missing file, namelist syntax, unknown group or key, wrong type, shape or range.
    """
    path = Path(path)
    name = path.name
    if not path.is_file():
        raise DeckError(name, "", "", "deck file not found")
    try:
        text = path.read_text(encoding="utf-8", errors="strict")
    except (OSError, UnicodeDecodeError) as exc:
        raise DeckError(name, "", "", f"cannot read the deck: {exc}") from None
    deck = deck_from_text(text, name)
    deck.path = path
    return deck


def deck_from_text(text: str, name: str) -> Deck:
    """Validate a namelist text (see :func:`read_deck`)."""
    uncommented = _COMMENT.sub(lambda m: m.group(1) or "", text)
    check_groups(uncommented, name)                 # on the deck's own lines: messages name them
    text = _BLANK_LINES.sub("", uncommented)
    commas = _real_comma_decimals(text, name)
    nml = parse_namelist(text, name)
    raw: dict[str, dict] = {}
    starts: dict[str, dict] = {}
    for group, body in nml.items():
        group = group.lower()
        if group not in GROUPS:
            raise DeckError(name, group, "", f"unknown group &{group}; known groups: "
                                             + ", ".join("&" + g for g in GROUPS))
        if group in raw or isinstance(body, list):
            raise DeckError(name, group, "", f"group &{group} appears more than once")
        raw[group] = {k.lower(): v for k, v in body.items()}
        starts[group] = {k.lower(): v for k, v in getattr(body, "start_index", {}).items()}
        for key in raw[group]:
            if lookup(group, key) is None:
                raise DeckError(name, group, key, unknown_key_reason(group, key))
    for group in REQUIRED_GROUPS:
        if group not in raw:
            raise DeckError(name, group, "", f"group &{group} is missing")
    try:
        deck = validate(raw, starts, name)
    except DeckError as err:
        raise with_comma_hint(err, commas) from None
    deck.comma_decimals = commas
    return deck


def _real_comma_decimals(text: str, name: str) -> dict[tuple[str, str], CommaDecimal]:
    """The decimal commas of real keys (:func:`pydriver.deck_tokens.comma_decimals`).

    On a key of fixed length (a scalar, three values, one per body or joint) a decimal comma
    adds a value, and the count error that follows names it (:func:`with_comma_hint`).  A
    list takes any number of values, so there it is refused at once when the value has more
    than the one number: ``table_t = 0,5, 1,0`` is a decimal comma beside separated values
    (``table_t = 0,5`` alone stays the two values Fortran reads).
    """
    commas = {}
    for (group, key_name), comma in comma_decimals(text).items():
        key = lookup(group, key_name)
        if key is None or key.type != "real":
            continue
        if key.shape == "list" and not comma.alone:
            raise DeckError(name, group, key_name, f"{comma.hint()}; if these are separate values, separate them "
                                                   "like the others (', ')")
        commas[(group, key_name)] = comma
    return commas


def validate(raw: dict, starts: dict, name: str) -> Deck:
    """Turn raw values ``raw[group][key]`` (f90nml's Python values) into a :class:`Deck`."""
    n_key = lookup("chain", "n_bodies")
    if "n_bodies" not in raw.get("chain", {}):
        raise DeckError(name, "chain", "n_bodies", "is required (number of rigid bodies)")
    n = normalize(n_key, raw["chain"]["n_bodies"], None, 0, name)
    values: dict[str, dict] = {}
    given = set()
    resampled = "resample" in raw.get("shape", {}) and normalize(
        lookup("shape", "resample"), raw["shape"]["resample"], starts.get("shape", {}).get("resample"), n, name)
    for group, keys in GROUPS.items():
        values[group] = {}
        for key_name, key in keys.items():
            if key_name in raw.get(group, {}):
                start = starts.get(group, {}).get(key_name)
                if resampled and (group, key_name) in RESAMPLED_KEYS:
                    key = replace(key, shape="list")       # the shape at any number of joints
                values[group][key_name] = normalize(key, raw[group][key_name], start, n, name)
                given.add((group, key_name))
            else:
                values[group][key_name] = default_value(key, n)
    if resampled:
        _resample_shape(values, given, name)
    return Deck(name=name, values=values, given=given, groups=set(raw), raw=raw, starts=starts)


#: The keys ``&shape resample = .true.`` resamples (pydriver.shape_resample).
RESAMPLED_KEYS = (("shape", "gamma_deg"), ("shape", "beta_deg"))


def _resample_shape(values: dict, given: set, name: str) -> None:
    """Replace the m-joint start shape of a ``resample = .true.`` deck by the n-body one
    (:mod:`pydriver.shape_resample`); a DeckError names the key and the reason."""
    n = int(values["chain"]["n_bodies"])
    if ("chain", "body_length") in given:
        raise DeckError(name, "shape", "resample", "resampling along the arc length needs a uniform chain: give "
                                                   "&chain total_length, not per-body body_length")
    total = values["chain"]["total_length"]
    if total is None:
        raise DeckError(name, "chain", "total_length", "is required with &shape resample = .true. (the arc "
                                                       "length the shape is resampled along)")
    counts = {k: len(values["shape"][k]) for g, k in RESAMPLED_KEYS if (g, k) in given}
    if len(set(counts.values())) > 1:
        raise DeckError(name, "shape", "beta_deg", "with resample = .true. gamma_deg and beta_deg give the shape at "
                                                   "the same joints: " + ", ".join(f"{k} has {m} values"
                                                                                   for k, m in counts.items()))
    half_last = ("cable", "ei") in given and bool(values["clamp_b"]["active"])
    for key, m in counts.items():
        if m > n:
            raise DeckError(name, "shape", key, f"with resample = .true. the shape is given at m joints of an "
                                                f"m-body chain, m at most n_bodies = {n}; got {m} values")
        try:
            values["shape"][key] = resample(values["shape"][key], n, float(total), half_last)
        except ValueError as err:
            raise DeckError(name, "shape", key, f"resample = .true.: {err}; give the shape at fewer joints "
                                                "or use more bodies") from None


def array_length(key: Key, n: int) -> int | None:
    """Number of values an array key takes (None: any number)."""
    return {"vec3": 3, "body": n, "joint": n}.get(key.shape)


def default_value(key: Key, n: int):
    """The schema default of a key, shaped (None if it has none)."""
    if key.default is None:
        return None
    if not key.is_array:
        return key.default
    length = array_length(key, n)
    d = np.atleast_1d(np.asarray(key.default, dtype=float if key.type == "real" else object))
    if length is not None and d.size == 1:
        d = np.full(length, d[0], dtype=d.dtype)
    return d


def normalize(key: Key, raw, start, n: int, deck: str):
    """Check one key's value against the schema and return it in its Python form."""
    def fail(reason):
        raise DeckError(deck, key.group, key.name, reason)

    if isinstance(raw, np.ndarray):
        if key.type == "real" and key.is_array and not start:
            return _real_array(key, raw, n, fail)
        raw = raw.tolist()
    items = raw if isinstance(raw, list) else [raw]
    if not key.is_array:
        if start is not None and start != [1]:
            fail("is not an array: no index allowed")
        if len(items) != 1:
            fail(f"takes one value, got {len(items)}")
        if items[0] is None:
            fail("has no value")
        return _element(key, items[0], fail)
    length = array_length(key, n)
    offset = (start[0] - 1) if start else 0
    if start and len(start) > 1:
        fail("takes one index")
    if offset < 0:
        fail(f"index {offset + 1} is out of range (indices start at 1)")
    broadcast = (length is not None and key.shape != "vec3" and not start and len(items) == 1
                 and not isinstance(raw, list))
    if broadcast:
        if items[0] is None:
            fail("has no value")
        value = _element(key, items[0], fail)
        if not key.broadcast and length > 1 and value != 0:
            # A Fortran namelist read sets element 1 only; broadcasting would run a different
            # (coiled) cable than the same deck read by Fortran (issue 20).  Zero reads the
            # same both ways (the other elements stay 0), so it is kept.
            what = "body" if key.shape == "body" else "joint"
            fail(f"a single value {value:g} would set every {what} here but only {what} 1 in a Fortran "
                 f"namelist read; write {length}*{value:g} for all {length}, or one value per {what}")
        return np.full(length, value, dtype=float if key.type == "real" else object)
    if length is None:
        length = offset + len(items)
    # A whole-array assignment must give every element (Fortran would keep the old values of
    # the rest silently: 'gravity = 0.0, 0.0' would keep g_z); an element assignment
    # 'key(i) = v' changes element i only.
    if offset + len(items) > length or (not start and len(items) != length):
        what = {"vec3": "3 values", "body": f"{length} values (one per body)",
                "joint": f"{length} values (one per joint)"}[key.shape]
        fail(f"needs {what}, got {offset + len(items)}{_count_hint(key, items, length)}")
    base = default_value(key, n)
    out = [None] * length
    if base is not None:                           # a list's default may be shorter than the list
        out[:min(length, len(base))] = list(base)[:length]
    for i, item in enumerate(items):
        if item is not None:                         # a null value keeps the element's default
            out[offset + i] = _element(key, item, fail)
    missing = [i + 1 for i, v in enumerate(out) if v is None]
    if missing:
        what = {"vec3": "3 values", "body": f"{length} values (one per body)",
                "joint": f"{length} values (one per joint)", "list": "a value for every element"}[key.shape]
        fail(f"needs {what}; element{'s' if len(missing) > 1 else ''} "
             f"{', '.join(map(str, missing[:8]))}{' ...' if len(missing) > 8 else ''} not set")
    return np.asarray(out, dtype=float if key.type == "real" else object)


def _count_hint(key: Key, items, length: int) -> str:
    """How to fix a per-body or per-joint key whose count is not n_bodies (a deck switched to
    another n): the start shape resamples, the thesis's joint constants come from &cable, and
    one value for every body is written ``n*value``."""
    if key.shape not in ("body", "joint"):
        return ""
    got = len(items)
    if (key.group, key.name) in RESAMPLED_KEYS:
        if got < length:
            return (f"; a start shape given for a chain of {got} bodies is placed on these {length} by arc length "
                    "with &shape resample = .true. (rotorcable keys shape.resample)")
        return (f"; &shape resample = .true. places a shape of at most n_bodies = {length} joints: give "
                f"{length} values")
    if key.group == "springs":
        return ("; the per-joint constants of &springs hold for one n: &cable ei (with gj, damping_time) gives "
                "them for any n_bodies (rotorcable keys cable)")
    first = items[0] if got else None
    if got > 1 and isinstance(first, (int, float)) and not isinstance(first, bool) and all(v == first for v in items):
        return f"; for {first:g} at every {key.shape} write {length}*{first:g}"
    return ""


def _real_array(key: Key, a: np.ndarray, n: int, fail) -> np.ndarray:
    """A long real list (numpy's parse, see _fast_tables), checked as a whole."""
    length = array_length(key, n)
    if length is not None and a.size != length:
        fail(f"needs {length} values, got {a.size}{_count_hint(key, a, length)}")
    bad = ~np.isfinite(a)
    if np.any(bad):
        fail(f"must be finite, got {a[bad][0]} (value {int(np.argmax(bad)) + 1})")
    lo = (a <= key.low) if key.low_open else (a < key.low)
    hi = (a >= key.high) if key.high_open else (a > key.high)
    tiny = (a != 0) & (np.abs(a) < key.tiny)
    if np.any(lo | hi | tiny):
        v = float(a[np.argmax(lo | hi | tiny)])
        fail(_range_reason(key, v) if not key.tiny or abs(v) >= key.tiny else
             f"is 0 (none) or at least {key.tiny:g} {key.unit}, got {v:g}")
    return a.astype(float)


def _element(key: Key, v, fail):
    """One scalar value of the key's type, finite and in range."""
    if key.type == "real":
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            fail(f"not a number: {v!r}")
        v = float(v)
        if not math.isfinite(v):
            fail(f"must be finite, got {v}")
    elif key.type == "int":
        if isinstance(v, bool) or not isinstance(v, int):
            fail(f"not an integer: {v!r}")
        if abs(v) > INT32_MAX:
            fail(f"{v} is beyond the core's 32-bit integers (at most {INT32_MAX}); "
                 f"allowed: {key.range_text()}")
    elif key.type == "bool":
        if not isinstance(v, bool):
            fail(f"not a logical (.true. or .false.): {v!r}")
        return v
    else:
        if not isinstance(v, str):
            fail(f"not a string: {v!r} (quote it: '...')")
        v = v.strip()
        if key.choices and v not in key.choices:
            fail(f"must be {key.range_text()}, got '{v}'")
        return v
    lo_bad = v < key.low or (key.low_open and v == key.low)
    hi_bad = v > key.high or (key.high_open and v == key.high)
    if lo_bad or hi_bad:
        fail(_range_reason(key, v))
    if v != 0 and abs(v) < key.tiny:
        fail(f"is 0 (none) or at least {key.tiny:g} {key.unit}, got {v:g}")
    return v


def _range_reason(key: Key, v) -> str:
    note = f" ({key.note})" if key.note else ""
    unit = f" {key.unit}" if key.unit not in ("-", "") else ""
    if key.type == "int":
        return f"must be at least {key.low:g}, got {v}" if v < key.low else f"must be at most {key.high:g}, got {v}"
    if v < 0 <= key.low:
        head = "must not be negative" if key.low == 0 and not key.low_open else "must be positive"
    elif v == 0 and (key.low > 0 or key.low_open and key.low == 0):
        head = "must be positive"
    else:
        head = "is out of range"
    return f"{head}: allowed {key.range_text()}{unit}, got {v:g}{note}"


def parse_value_text(key: Key, text: str, deck: str = "--set"):
    """The Python value of a namelist value text for ``key`` (e.g. ``"90.0, 10*0.0"``)."""
    nml = parse_namelist(f"&{key.group}\n {key.name} = {text}\n/\n", deck)
    return nml[key.group].get(key.name)


def patch_deck(src, dst, changes: dict) -> Path:
    """Copy deck ``src`` to ``dst`` with ``changes = {group: {key: value}}`` applied by f90nml.

    Values are Python values or namelist value texts (``"35.0"``, ``"90.0, 10*0.0"``,
    ``"'modal'"``); keys are checked against the schema.  ``key(i)`` changes one element of an
    array key (the other elements keep the base deck's values).  The other keys and their
    values are kept and a missing group is added, but the deck's comments are not: the copy is
    parsed without them and written again by f90nml, with one first comment line that names
    the source deck and the changes.
    """
    name = Path(src).name
    base = None
    patch = f90nml.Namelist()
    for group, keys in changes.items():
        group = group.lower()
        patch[group] = f90nml.Namelist()
        for key_name, value in keys.items():
            m = re.fullmatch(r"\s*([a-z_]\w*)\s*(?:\(\s*(\d+)\s*\))?\s*", key_name, re.I)
            if m is None:
                raise DeckError(name, group, key_name, "not a key name")
            key = lookup(group, m.group(1))
            if key is None:
                # Written as given: the deck's reader names it when the copy is read (a
                # test or a user may want a deck with a misspelt key).
                key = Key(group, m.group(1).lower(), "str")
                if isinstance(value, str):
                    value = parse_value_text(key, value, name)
            elif isinstance(value, str) and (key.type != "str" or value[:1] in "'\""):
                value = parse_value_text(key, value, name)
            if isinstance(value, np.ndarray):
                value = value.tolist()
            if m.group(2):
                # One element: the whole array with that element changed (f90nml patches whole
                # assignments); the base values come from the validated base deck.
                if base is None:
                    base = read_deck(src)
                index = int(m.group(2))
                array = base[f"{group}.{key.name}"]
                if array is None or not key.is_array or not 1 <= index <= len(array):
                    raise DeckError(name, group, key.name, f"has no element {index}")
                array = list(np.asarray(array).tolist())
                array[index - 1] = value[0] if isinstance(value, list) else value
                value = array
            patch[group][key.name] = value
    # The whole deck is parsed and written again by f90nml: its in-place patch mode garbles
    # repeat counts ("90.0, 10*0.0" patched to eleven zeros comes out as "0.0, 0.0*0.0").
    nml = parse_namelist(strip_comments(Path(src).read_text()), name)
    for group, keys in patch.items():
        if group not in nml:
            nml[group] = f90nml.Namelist()
        for key_name, value in keys.items():
            nml[group][key_name] = value
            if key_name in getattr(nml[group], "start_index", {}):
                del nml[group].start_index[key_name]
    out = io.StringIO()
    what = "; ".join(f"&{g} {k} = {v if isinstance(v, str) else _nml_value(v)}"
                     for g, ks in changes.items() for k, v in ks.items())
    out.write(f"! {name} with {what[:2000]}\n")
    nml.uppercase = False
    nml.write(out)
    Path(dst).write_text(out.getvalue())
    return Path(dst)


def _nml_value(v) -> str:
    """A Python value as namelist text (for groups the patch adds)."""
    if isinstance(v, list):
        return ", ".join(_nml_value(x) for x in v)
    if isinstance(v, bool):
        return ".true." if v else ".false."
    if isinstance(v, str):
        return "'" + v.replace("'", "''") + "'"
    return repr(v)


def deck_text(deck: Deck, header: str = "") -> str:
    """A deck as a plain namelist text that reads back to the same values: the keys it sets, in
    their groups (a key the deck set by element, ``a(3) = ...``, written whole).  ``header``
    becomes comment lines at the top (why the deck was written, by what)."""
    nml = f90nml.Namelist()
    for group in (g for g in GROUPS if g in deck.raw):
        body = f90nml.Namelist()
        for key, value in deck.raw[group].items():
            if key in deck.starts.get(group, {}):
                value = deck[f"{group}.{key}"]
            if isinstance(value, np.ndarray):
                value = value.tolist()
            body[key] = value
        nml[group] = body
    out = io.StringIO()
    for line in header.splitlines():
        out.write(f"! {line}\n")
    nml.uppercase = False
    nml.write(out)
    return out.getvalue()
