"""The grid of a sweep: ``--set GROUP.KEY=VALUES`` options, checked by the deck schema.

Each option names a key of :mod:`pydriver.schema` (or one element of an array key) and a list
of values in namelist syntax.  Every value is parsed as the deck reader parses it
(:func:`pydriver.deckfile.parse_value_text`) and its type checked against the key, so a
malformed value is refused before anything is written or run, naming the option.  Ranges and
cross-key rules are the deck check's: the first grid point is checked whole before the sweep
starts (:mod:`pydriver.sweep.directory`), any other point that breaks them becomes that
point's failed record, as a hand-written deck would.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import re
import unicodedata

import numpy as np

from pydriver.deckfile import normalize, parse_value_text
from pydriver.errors import DeckError
from pydriver.schema import GROUPS, Key, lookup
from pydriver.sweep.errors import SweepError

GRID_HELP = """\
grid syntax of --set GROUP.KEY=VALUES (VALUES is namelist text):
  v1,v2,v3       a list (strings quoted as in the deck: case.analysis="'static','modal'")
  a:b:n          n points from a to b inclusive, evenly spaced (1:70:24 = 1, 4, ..., 70;
                 integer end points with an integer step give integers)
  log:a:b:n      n log-spaced points from a to b inclusive (a, b > 0)
  items may be mixed: 0.5,1:70:24.  Several --set options span the Cartesian product
  (the last one varies fastest); grid points get ids 0000, 0001, ... in that order.
  Each grid point takes one value.  Vector keys (loads.gravity, clamp_b.position, ...)
  are swept one element at a time: loads.gravity(3)=-9.81,-1.62.  A per-body or per-joint
  key (springs.c_beta, shape.beta_deg, ...) takes one value for every body or joint, or
  one element at a time; if the base deck gives it different values per element, only
  one element at a time."""

# GROUP.KEY or GROUP.KEY(i), as the option names it (not deck text: the deck is f90nml's).
_NAME = re.compile(r"([a-z_]\w*)\.([a-z_]\w*)(?:\(\s*(\d+)\s*\))?", re.IGNORECASE)
_INTEGER = re.compile(r"[+-]?\d+")


def _split_items(text: str) -> list[str]:
    """Split on commas outside quotes (namelist strings may contain commas)."""
    items, cur, quote = [], "", None
    for ch in text:
        if quote:
            cur += ch
            if ch == quote:
                quote = None
        elif ch in "'\"":
            cur += ch
            quote = ch
        elif ch == ",":
            items.append(cur)
            cur = ""
        else:
            cur += ch
    items.append(cur)
    return [s.strip() for s in items]


def _fmt(x: float) -> str:
    # 15 significant digits drop linspace round-off (0.30000000000000004 -> 0.3), so the deck,
    # the manifest and sweep.csv all carry the same short text.
    return repr(float(f"{x:.15g}"))


def _range(item: str, spec: str) -> list[str]:
    """The value texts of an ``a:b:n`` or ``log:a:b:n`` item."""
    log = item.lower().startswith("log:")
    parts = item[4:].split(":") if log else item.split(":")
    form = "log:a:b:n" if log else "a:b:n"
    if len(parts) != 3:
        raise SweepError(f"--set {spec}: range '{item}' is not of the form {form}")
    a, b, n = (p.strip() for p in parts)
    try:
        fa, fb = float(a.lower().replace("d", "e")), float(b.lower().replace("d", "e"))
        num = int(n)
    except ValueError:
        raise SweepError(f"--set {spec}: range '{item}': {form} needs numbers a, b and an "
                         f"integer n") from None
    if num < 2:
        raise SweepError(f"--set {spec}: range '{item}': n must be at least 2 (a list takes one value)")
    if log:
        if fa <= 0 or fb <= 0:
            raise SweepError(f"--set {spec}: log range '{item}' needs a > 0 and b > 0")
        return [_fmt(x) for x in np.geomspace(fa, fb, num)]
    if _INTEGER.fullmatch(a) and _INTEGER.fullmatch(b) and (int(b) - int(a)) % (num - 1) == 0:
        step = (int(b) - int(a)) // (num - 1)
        return [str(int(a) + k * step) for k in range(num)]
    return [_fmt(x) for x in np.linspace(fa, fb, num)]


def _key(group: str, name: str, index: int | None, spec: str) -> Key:
    """The schema key an option sets, with its element index checked against the shape."""
    if group not in GROUPS:
        raise SweepError(f"--set {spec}: unknown group &{group}; known groups: "
                         + ", ".join("&" + g for g in GROUPS))
    key = lookup(group, name)
    if key is None:
        raise SweepError(f"--set {spec}: unknown key {group}.{name}; &{group} has: "
                         + ", ".join(GROUPS[group]))
    if index is not None:
        if not key.is_array:
            raise SweepError(f"--set {spec}: {group}.{name} is not an array; drop the ({index})")
        if index < 1 or (key.shape == "vec3" and index > 3):
            raise SweepError(f"--set {spec}: {group}.{name} has no element {index}")
    elif key.shape in ("vec3", "list"):
        # One grid value cannot be the whole vector: sweep one element.
        raise SweepError(f"--set {spec}: {group}.{name} is an array ({key.shape}); sweep one "
                         f"element at a time, e.g. --set {group}.{name}(3)=...")
    return key


def _check_value(key: Key, item: str, spec: str) -> None:
    """Refuse a grid value that is not one value of the key's type (range: the deck check)."""
    def refuse(reason):
        raise SweepError(f"--set {spec}: value {item}: {reason}")

    if key.type == "str" and item[:1] not in "'\"":
        return                      # an unquoted string is the string itself (patch_deck)
    try:
        value = parse_value_text(key, item)
    except DeckError as exc:
        refuse(exc.reason)
    if value is None:
        refuse("no value")
    if isinstance(value, list):
        shown = ", ".join(map(str, value[:4])) + (", ..." if len(value) > 4 else "")
        refuse(f"reads as {len(value)} values ({shown}); a grid point takes one (commas "
               "separate grid points)")
    # The key's type and finiteness only; range and choices are checked with the whole deck.
    loose = dataclasses.replace(key, shape="scalar", low=-math.inf, high=math.inf, choices=())
    try:
        normalize(loose, value, None, 0, "--set")
    except DeckError as exc:
        refuse(exc.reason)


def parse_set(spec: str) -> tuple[str, list[str], str]:
    """Parse one ``--set GROUP.KEY=VALUES`` option.

    Parameters
    ----------
    spec : str
        ``GROUP.KEY=VALUES`` or ``GROUP.KEY(i)=VALUES`` in the grid syntax (``GRID_HELP``).

    Returns
    -------
    name : str
        ``group.key`` in lower case (``group.key(i)`` for one array element).
    values : list of str
        Namelist value texts, one per grid point along this parameter.
    scale : str
        ``"log"`` when every item is a log range (for plot axes), else ``"linear"``.

    Raises
    ------
    SweepError
        Malformed option, unknown group or key, a whole vector, or a value that is not one
        value of the key's type; the message starts with ``--set SPEC``.
    """
    if any(unicodedata.category(c) in ("Cc", "Zl", "Zp") for c in spec):
        # A newline in a value would become a line of the point's deck (issue 20).
        raise SweepError(f"--set {spec!r}: a control character (newline, tab, ...) is refused")
    if "=" not in spec:
        raise SweepError(f"--set {spec}: expected GROUP.KEY=VALUES")
    name, text = (s.strip() for s in spec.split("=", 1))
    m = _NAME.fullmatch(name)
    if not m:
        raise SweepError(f"--set {spec}: '{name}' is not GROUP.KEY (e.g. springs.c_beta) "
                         f"or GROUP.KEY(i) for one array element")
    group, key_name = m.group(1).lower(), m.group(2).lower()
    index = int(m.group(3)) if m.group(3) else None
    key = _key(group, key_name, index, spec)
    name = f"{group}.{key_name}" + (f"({index})" if index is not None else "")
    if not text:
        raise SweepError(f"--set {spec}: no values")
    values, log_items = [], []
    for item in _split_items(text):
        if not item:
            raise SweepError(f"--set {spec}: empty value in the list")
        if item[0] in "'\"" or ":" not in item:
            values.append(item)
            log_items.append(False)
        else:
            values.extend(_range(item, spec))
            log_items.append(item.lower().startswith("log:"))
    for value in dict.fromkeys(values):
        _check_value(key, value, spec)
    return name, values, "log" if all(log_items) else "linear"


def expand_grid(specs: list[str]) -> tuple[list[str], list[list[str]], dict]:
    """Cartesian product of several ``--set`` options.

    Returns
    -------
    params : list of str
        Parameter names in option order.
    points : list of list of str
        Value texts per grid point (last parameter varies fastest).
    scales : dict
        Parameter -> ``"log"`` or ``"linear"``.
    """
    if not specs:
        raise SweepError("a sweep needs at least one --set GROUP.KEY=VALUES")
    params, axes, scales = [], [], {}
    for spec in specs:
        name, values, scale = parse_set(spec)
        if name in params:
            raise SweepError(f"--set {spec}: {name} is set twice")
        params.append(name)
        axes.append(values)
        scales[name] = scale
    return params, [list(p) for p in itertools.product(*axes)], scales


def check_against_base(specs: list[str], params: list[str], base_nml) -> None:
    """Refuse a single value for a per-body/per-joint key the base deck gives per element.

    One value sets every body or joint alike (the schema's rule), which would silently flatten
    e.g. a start shape the base deck spells out body by body; such a key is swept one element
    at a time.

    Parameters
    ----------
    specs, params : list of str
        The options and the parameter names ``expand_grid`` made of them.
    base_nml : f90nml.Namelist
        The base deck as parsed by :func:`pydriver.deckfile.parse_namelist`.
    """
    for spec, name in zip(specs, params):
        if "(" in name:
            continue
        group, key_name = name.split(".")
        body = base_nml.get(group)
        if body is None or isinstance(body, list) or key_name not in body:
            continue                # not given (or a repeated group: the deck check's error)
        value = body[key_name]
        elements = np.asarray(value, dtype=object).ravel().tolist()
        per_element = key_name in getattr(body, "start_index", {}) or len(
            {repr(v) for v in elements}) > 1
        if per_element:
            shown = ", ".join(map(str, elements[:6])) + (", ..." if len(elements) > 6 else "")
            raise SweepError(f"--set {spec}: the base deck gives {name} per element ({shown}); one "
                             f"value would set every element alike.  Sweep one element at a "
                             f"time, e.g. --set {name}(2)=...")


def point_changes(params: list[str], values: list[str]) -> dict:
    """``{group: {key or key(i): value text}}`` of one grid point, for ``patch_deck``."""
    changes: dict = {}
    for name, value in zip(params, values):
        group, key = name.split(".", 1)
        changes.setdefault(group, {})[key] = value
    return changes
