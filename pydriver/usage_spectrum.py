"""A usage spectrum as input (``&case analysis = 'spectrum'``, ``&spectrum``): the deck's regimes
as flight decks, and the run-up deck of the rotor's start.

A spectrum deck is a flight deck (the base: cable, clamps, rotor, blade, drag, fatigue) with a
``&spectrum`` group listing the regimes, each with its share of the flight time and its changes
of the base: forward speed, rotor speed, load factor (gravity times n: a steady turn or a
pull-up), air density, the blade's motion from a table (:mod:`pydriver.blade_fit`) and any
further deck value (``changes``).  :func:`spectrum_of` turns it into

* one plain flight deck per regime (:attr:`Regime.text`, re-runnable alone; what the regime
  runs), named ``<deck stem>_<regime>.nml``;
* the run-up deck (a dynamic run of the same cable from rest, the rotor spun up from 0 to the
  deck's speed in ``runup_time``, no forward speed, the blade in its installed pose): the rest
  state is its first sample, and its closed cycles are those of a start (docs/model.md, "Usage
  spectrum").  A spectrum without flights (``flights_per_hour = 0``) has none.

Every deck is made from the base's values (:func:`pydriver.deckfile.deck_text`) and read back
from its own text, so a regime run in this process and one run from its file in a sweep
directory are the same deck bit for bit.  Everything is checked before anything runs: a bad
value names the spectrum deck, the ``&spectrum`` key (or the key a ``changes`` entry sets) and
the regime.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from pydriver.blade_fit import AngleFit, fit_blade_file
from pydriver.data_tables import resolve
from pydriver.deckfile import Deck, deck_from_text, deck_text, parse_value_text, validate
from pydriver.errors import DeckError
from pydriver.schema import GROUPS, lookup

#: How far the shares may miss a sum of 1 (shares written with six decimals add up to within it).
SHARE_SUM_TOLERANCE = 1.0e-6
#: A regime's name: it becomes part of file and case names.
REGIME_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_-]{0,63}")
#: Groups a regime's ``changes`` may not touch: what the regimes must share for their damages to
#: add up point by point (the chain and its refinement levels, the S-N curve) or what is the
#: spectrum's own (case, spectrum, design; its limits judge the spectrum, not a regime).
FIXED_GROUPS = ("case", "chain", "refinement", "fatigue", "spectrum", "design", "limits")
#: The per-regime list keys of ``&spectrum`` and the deck key each one sets.
REGIME_KEYS = {"forward_speed": "drag.forward_speed", "rpm": "rotor.rpm", "air_density": "drag.air_density"}
#: Fewest run-up samples per revolution at flight speed.
RUNUP_SAMPLES_MIN = 36
#: Flight keys a run-up (a dynamic run) has no use for; it is given its own times.
_FLIGHT_ONLY = ("periodic_method", "floquet", "periodic_tol", "max_revolutions", "samples_per_rev", "t_end",
                "dt_out", "checkpoint_interval", "output_format")


@dataclass(frozen=True)
class Regime:
    """One regime of the spectrum.

    Attributes
    ----------
    name : str
        The regime's name (``&spectrum regimes``).
    share : float
        Its share of the flight time.
    deck : Deck
        Its flight deck (read back from :attr:`text`).
    text : str
        The deck's namelist text (``decks/<id>.nml`` of a spectrum directory).
    changes : dict
        What it changes of the base, ``{"group.key": value}`` (for the reports).
    blade_fit : dict
        Angle -> :class:`pydriver.blade_fit.AngleFit` of its blade table (empty without one).
    blade_file : str
        Its blade table as the deck names it ('' for none).
    """

    name: str
    share: float
    deck: Deck
    text: str
    changes: dict = field(default_factory=dict)
    blade_fit: dict = field(default_factory=dict)
    blade_file: str = ""


@dataclass(frozen=True)
class Spectrum:
    """A deck's usage spectrum (:func:`spectrum_of`)."""

    deck: Deck                        #: the spectrum deck
    regimes: tuple                    #: the :class:`Regime` s, in the deck's order
    runup: Deck | None                #: the run-up deck; None without flights
    runup_text: str                   #: its text ('' without flights)
    flights_per_hour: float
    start_stops_per_flight: float
    scatter_factor: float


def _raw_copy(deck: Deck) -> tuple[dict, dict]:
    return {g: dict(v) for g, v in deck.raw.items()}, {g: dict(v) for g, v in deck.starts.items()}


def _absolute_paths(raw: dict, deck: Deck) -> None:
    """A file a derived deck reads must not depend on where that deck is written."""
    if deck["fatigue.sn_file"]:
        raw["fatigue"]["sn_file"] = str(resolve(deck["fatigue.sn_file"], deck.path).resolve())


def _read_back(text: str, name: str, path) -> Deck:
    deck = deck_from_text(text, name)
    deck.path = path
    return deck


def _stem(deck: Deck) -> str:
    return Path(deck.name).stem


def base_flight_deck(deck: Deck) -> Deck:
    """The spectrum deck as the plain flight deck its regimes change: ``&spectrum`` removed,
    ``analysis = 'flight'``, no Floquet analysis (a regime reports its damage, not its
    stability)."""
    raw, starts = _raw_copy(deck)
    for group in ("spectrum",):
        raw.pop(group, None)
        starts.pop(group, None)
    raw["case"]["analysis"] = "flight"
    raw.get("solver", {}).pop("floquet", None)
    _absolute_paths(raw, deck)
    out = validate(raw, starts, deck.name)
    out.path = deck.path
    return out


def _parse_changes(deck: Deck, regime: str, text: str) -> list[tuple[str, int | None, str]]:
    """``'group.key = value; group.key(i) = value'`` as (dotted, element or None, value text)."""
    out = []
    for part in _split(text):
        if not part.strip():
            continue
        m = re.fullmatch(r"\s*([a-z_]\w*)\.([a-z_]\w*)\s*(?:\(\s*(\d+)\s*\))?\s*=(.*)", part, re.I | re.S)

        def fail(reason, part=part):
            deck.fail("spectrum", "changes", f"regime '{regime}': '{part.strip()}': {reason}")
        if m is None:
            fail("not 'group.key = value' (entries separated by ';')")
        group, name, index, value = m.group(1).lower(), m.group(2).lower(), m.group(3), m.group(4).strip()
        if group not in GROUPS:
            fail(f"unknown group &{group}")
        if lookup(group, name) is None:
            fail(f"unknown key; &{group} has: {', '.join(GROUPS[group])}")
        if group in FIXED_GROUPS:
            fail(f"a regime cannot change &{group}: the regimes share it ({', '.join('&' + g for g in FIXED_GROUPS)} "
                 "are the spectrum's)")
        if not value:
            fail("no value")
        out.append((f"{group}.{name}", int(index) if index else None, value))
    return out


def _split(text: str) -> list[str]:
    """Split at ';' outside quotes (a string value may hold one)."""
    parts, cur, quote = [], "", None
    for ch in text:
        if quote:
            quote = None if ch == quote else quote
        elif ch in "'\"":
            quote = ch
        elif ch == ";":
            parts.append(cur)
            cur = ""
            continue
        cur += ch
    parts.append(cur)
    return parts


def _listed(deck: Deck, key: str, count: int):
    """A per-regime list of ``&spectrum``, checked to have one value per regime (None: not given)."""
    values = deck[f"spectrum.{key}"]
    if values is None:
        return None
    values = list(values)
    if len(values) != count:
        deck.fail("spectrum", key, f"needs one value per regime ({count} regimes), got {len(values)}")
    return values


def is_spectrum(deck: Deck) -> bool:
    """Whether the deck's analysis is a usage spectrum (its registry row's rules are this module's)."""
    from pydriver.analyses.registry import analysis_of
    return analysis_of(deck).rules == f"{__name__}:check"


def check(deck: Deck) -> None:
    """The spectrum's own rules (:mod:`pydriver.deck_rules`): the regimes' names, one value of
    every per-regime list per regime, shares that sum to 1; the regimes' decks are checked when
    they are made (:func:`spectrum_of`)."""
    if "spectrum" not in deck.groups:
        deck.fail("spectrum", "regimes", "analysis = 'spectrum' needs the usage spectrum (&spectrum regimes, share, "
                                         "flights_per_hour)")
    if "fatigue" not in deck.groups:
        deck.fail("fatigue", "sn_exponent", "analysis = 'spectrum' computes a fatigue life: it needs the S-N curve "
                                            "(&fatigue)")
    names = deck["spectrum.regimes"]
    if names is None:
        deck.fail("spectrum", "regimes", "is required: the names of the spectrum's flight regimes")
    from pydriver.schema import MAX_REGIMES
    if not 1 <= len(names) <= MAX_REGIMES:
        deck.fail("spectrum", "regimes", f"1 ... {MAX_REGIMES} regimes, got {len(names)}")
    for name in names:
        if not REGIME_NAME.fullmatch(name):
            deck.fail("spectrum", "regimes", f"'{name}' is not a regime name: letters, digits, _ and - (at most 64, "
                                             "starting with a letter or digit)")
    seen = set()
    for name in names:
        if name.lower() in seen:
            deck.fail("spectrum", "regimes", f"'{name}' is named twice (names are compared without case)")
        seen.add(name.lower())
    if deck["spectrum.share"] is None:
        deck.fail("spectrum", "share", "is required: each regime's share of the flight time")
    shares = _listed(deck, "share", len(names))
    total = float(np.sum(shares))
    if abs(total - 1.0) > SHARE_SUM_TOLERANCE:
        deck.fail("spectrum", "share", f"the shares of the flight time sum to {total:.9g}, not 1 (within "
                                       f"{SHARE_SUM_TOLERANCE:g})")
    for key in (*REGIME_KEYS, "load_factor", "blade_file", "changes"):
        _listed(deck, key, len(names))
    if not deck.has("spectrum.flights_per_hour"):
        deck.fail("spectrum", "flights_per_hour", "is required: flights per flight hour, each one ground-air-ground "
                                                  "cycle (0 for none)")


def _regime(deck: Deck, base: Deck, k: int) -> Regime:
    name = deck["spectrum.regimes"][k]
    share = float(deck["spectrum.share"][k])
    changes: dict = {}
    for key, target in REGIME_KEYS.items():
        values = deck[f"spectrum.{key}"]
        if values is not None:
            changes[target] = float(values[k])
    factors = deck["spectrum.load_factor"]
    if factors is not None:
        changes["loads.gravity"] = [float(factors[k]) * g for g in base["loads.gravity"]]

    def refused(err: DeckError, key: str):
        raise DeckError(deck.name, "spectrum", key, f"regime '{name}': {err.reason}"
                        + (f" (&{err.group} {err.key})" if err.group else "")) from None

    try:
        out = base.with_values(changes)
    except DeckError as err:
        source = next((k_ for k_, t in REGIME_KEYS.items() if t == f"{err.group}.{err.key}"), None)
        refused(err, source or ("load_factor" if err.key == "gravity" else "regimes"))
    texts = deck["spectrum.changes"]
    for dotted, index, value in _parse_changes(deck, name, texts[k] if texts is not None else ""):
        try:
            if index is not None:
                array = out[dotted]
                key = lookup(*dotted.split("."))
                if array is None or not key.is_array or not 1 <= index <= len(array):
                    deck.fail("spectrum", "changes", f"regime '{name}': {dotted} has no element {index}")
                array = np.array(array, dtype=object if key.type == "str" else float)
                element = parse_value_text(key, value, deck.name)
                array[index - 1] = element[0] if isinstance(element, list) else element
                out = out.with_values({dotted: array.tolist()})
            else:
                out = out.with_values({dotted: value})
        except DeckError as err:
            if err.deck == deck.name and err.group == "spectrum":
                raise
            refused(err, "changes")
        changes[dotted + (f"({index})" if index is not None else "")] = value
    fits, blade_file = {}, ""
    files = deck["spectrum.blade_file"]
    if files is not None and files[k].strip():
        blade_file = files[k].strip()
        if "blade" not in base.groups:
            deck.fail("spectrum", "blade_file", f"regime '{name}': a blade table needs a support on the blade "
                                                "(&blade, &clamp_b moves_with = 'blade')")
        try:
            fits = fit_blade_file(resolve(blade_file, deck.path), int(deck["spectrum.blade_harmonics"]))
        except ValueError as err:
            deck.fail("spectrum", "blade_file", f"regime '{name}': {err}")
        tolerance = float(deck["spectrum.blade_fit_tolerance_deg"])
        for angle, fit in fits.items():
            if f"blade.{angle}_deg" in changes:
                deck.fail("spectrum", "blade_file", f"regime '{name}': {blade_file} gives the {angle} angle that its "
                                                    f"changes set too (blade.{angle}_deg): give it once")
            if fit.max_deg > tolerance:
                deck.fail("spectrum", "blade_fit_tolerance_deg",
                          f"regime '{name}': the {angle} angle of {blade_file} misses its fit with "
                          f"{deck['spectrum.blade_harmonics']} harmonics by {fit.max_deg:.3g} deg at azimuth "
                          f"{fit.max_at_deg:g} deg (rms {fit.rms_deg:.3g} deg), more than the tolerance "
                          f"{tolerance:g} deg: more harmonics (blade_harmonics) or smoother data")
        try:
            out = out.with_values({f"blade.{angle}_deg": list(fit.coefficients) for angle, fit in fits.items()})
        except DeckError as err:
            refused(err, "blade_file")
    raw, starts = _raw_copy(out)
    raw["case"]["name"] = f"{deck['case.name'] or _stem(deck)}_{name}"
    header = (f"regime '{name}' of the usage spectrum {deck.name} (share {share:g} of the flight time)\n"
              + "".join(f"  {key} = {value}\n" for key, value in changes.items())
              + (f"  blade angles fitted to {blade_file} ({deck['spectrum.blade_harmonics']} harmonics)\n"
                 if blade_file else "")
              + "written by rotorcable (pydriver/usage_spectrum.py); runs alone as a flight deck")
    regime_name = f"{_stem(deck)}_{name}.nml"
    text = deck_text(validate(raw, starts, regime_name), header)
    try:
        regime_deck = _read_back(text, regime_name, deck.path)
        from pydriver import deck_rules
        deck_rules.check(regime_deck)
    except DeckError as err:
        refused(err, "regimes")
    return Regime(name=name, share=share, deck=regime_deck, text=text, changes=changes, blade_fit=fits,
                  blade_file=blade_file)


def runup_deck(deck: Deck) -> tuple[Deck, str]:
    """The run-up deck (module docstring) and its text: the base's cable from rest, spun up from
    0 to its rotor speed in ``runup_time``, ``samples_per_rev``/4 samples per revolution at flight
    speed, the record ending when the speed is reached."""
    base = base_flight_deck(deck)
    raw, starts = _raw_copy(base)
    rpm = float(base["rotor.rpm"])
    duration = float(deck["spectrum.runup_time"])
    raw["case"].update(analysis="dynamic", start="equilibrium", name=f"{deck['case.name'] or _stem(deck)}_runup")
    raw["rotor"].update(profile="runup", rpm_start=0.0, rpm=rpm, runup_start=0.0, runup_time=duration)
    if "drag" in raw:
        raw["drag"]["forward_speed"] = 0.0
        raw["drag"].pop("stream_velocity", None)
    for key in ("flap_deg", "lag_deg", "pitch_deg", "lag_extra_deg", "lag_extra_hz", "lag_extra_phase_deg"):
        raw.get("blade", {}).pop(key, None)
        starts.get("blade", {}).pop(key, None)
    solver = raw.setdefault("solver", {})
    for key in _FLIGHT_ONLY:
        solver.pop(key, None)
    # A quarter of a flight revolution's samples per revolution at flight speed (every 4 deg of
    # rotor angle at 360): the run-up's sampling and rainflow counting of every jacket point
    # cost in proportion, and its fastest content, the cable's first mode near 4/rev, keeps
    # about 20 samples per period (peaks within 1 - cos(pi/20) = 1.2 %).
    period = 60.0 / rpm
    dt = period / max(RUNUP_SAMPLES_MIN, int(base["solver.samples_per_rev"]) // 4)
    solver.update(t_end=duration, dt_out=duration / max(1, round(duration / dt)))
    # Not repeated at rtol/100: the whole run-up again would cost several times every regime
    # together, for the closed cycles of a start, a small share of the damage (the spectrum
    # prints it).  The regimes keep the deck's own estimate.
    solver["error_estimate"] = False
    for group in ("resonance", "limits"):
        raw.pop(group, None)
        starts.pop(group, None)
    name = f"{_stem(deck)}_runup.nml"
    header = (f"the rotor run-up of the usage spectrum {deck.name}: from rest to {rpm:g} rpm in {duration:g} s, "
              "no forward speed, the blade in its installed pose\n"
              "written by rotorcable (pydriver/usage_spectrum.py); runs alone as a dynamic deck")
    text = deck_text(validate(raw, starts, name), header)
    try:
        out = _read_back(text, name, deck.path)
        from pydriver import deck_rules
        deck_rules.check(out)
    except DeckError as err:
        raise DeckError(deck.name, "spectrum", "runup_time", f"the run-up deck: {err.reason}"
                        + (f" (&{err.group} {err.key})" if err.group else "")) from None
    return out, text


def spectrum_of(deck: Deck) -> Spectrum:
    """The deck's usage spectrum: its regimes' flight decks and the run-up deck, all checked.

    Raises
    ------
    DeckError
        Naming the spectrum deck, the key and the regime.
    """
    check(deck)
    base = base_flight_deck(deck)
    for group in ("limits", "resonance"):
        # A regime alone is judged by nothing: the spectrum's life is (pydriver/analyses/limits.py).
        if group in base.groups:
            raw, starts = _raw_copy(base)
            raw.pop(group)
            starts.pop(group, None)
            path = base.path
            base = validate(raw, starts, base.name)
            base.path = path
    regimes = tuple(_regime(deck, base, k) for k in range(len(deck["spectrum.regimes"])))
    flights = float(deck["spectrum.flights_per_hour"])
    runup, text = runup_deck(deck) if flights > 0.0 else (None, "")
    return Spectrum(deck=deck, regimes=regimes, runup=runup, runup_text=text, flights_per_hour=flights,
                    start_stops_per_flight=float(deck["spectrum.start_stops_per_flight"]),
                    scatter_factor=float(deck["spectrum.scatter_factor"]))


def angle_fit_summary(fit: AngleFit) -> dict:
    """A blade fit for summary.json: coefficients and residuals [deg]."""
    return {"coefficients_deg": list(fit.coefficients), "residual_rms_deg": fit.rms_deg,
            "residual_max_deg": fit.max_deg, "residual_max_at_azimuth_deg": fit.max_at_deg}
