"""The sweep directory: one sweep at a time, its manifest, and one deck per grid point.

The directory is checked before anything is written (:mod:`pydriver.sweep.layout`: new, empty
or this sweep's, nothing else), then ``DIR/.sweep.lock`` is held (:mod:`pydriver.sweep.lock`)
from before the first file of a sweep is written until its run ends, and the directory and the
manifest are read again under it: two sweeps started at the same moment into one directory
cannot both write their grids there (one is refused), and a resume with another grid or base
deck is refused without touching the directory.

Decks of grid points are the base deck patched by f90nml (:func:`pydriver.deckfile.patch_deck`):
the deck text is never edited as text.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import sys
import tempfile
from pathlib import Path

from pydriver.deckfile import parse_namelist, patch_deck, strip_comments
from pydriver.errors import DeckError
from pydriver.run import deck_info
from pydriver.sweep.errors import SweepError
from pydriver.sweep.faults import reason, writing
from pydriver.sweep.files import write_atomic
from pydriver.sweep.given_paths import checked_path
from pydriver.sweep.grid import check_against_base, expand_grid, point_changes
from pydriver.sweep.layout import (
    MANIFEST,
    check_sweep_directory,
    claim,
    existing_manifest,
    write_file,
)
from pydriver.sweep.lock import LOCK, hold_lock
from pydriver.sweep.records import read_manifest
from pydriver.sweep.table import TABLE

__all__ = ["LOCK", "deck_text", "hold_lock", "open_sweep", "plan", "prepare"]

def deck_text(base: Path, params: list, values: list, id_: str) -> str:
    """The deck of one grid point: the base deck patched by f90nml, with a header comment."""
    with tempfile.TemporaryDirectory() as tmp:
        text = patch_deck(base, Path(tmp) / "point.nml", point_changes(params, values)).read_text()
    what = ", ".join(f"{p} = {v}" for p, v in zip(params, values))
    return (f"! sweep point {id_}: {what}\n"
            f"! (base deck {base.name}; written by `python -m pydriver sweep`)\n" + text)


def _first_point_error(exc: DeckError, base: Path, sets, params, first: dict) -> SweepError:
    """The error of an invalid first grid point, naming the option to blame: the one setting
    the key the deck check names (or, for an unknown group, the one introducing it)."""
    bad = [s for s, p in zip(sets, params)
           if p.split("(")[0] == f"{exc.group}.{exc.key}".lower()
           or (not exc.key and exc.group and p.split(".")[0] == exc.group.lower())]
    where = f"--set {bad[0]}" if bad else f"base deck {base.name}"
    point = ", ".join(f"{p} = {v}" for p, v in zip(params, first["values"]))
    return SweepError(f"{where}: first grid point ({first['id']}: {point}) is not a valid deck: {exc}")


def plan(base, sets: list[str]) -> dict:
    """The manifest of a sweep, checked, without writing anything.

    Every option is parsed and its values type-checked by the schema
    (:func:`pydriver.sweep.grid.expand_grid`), and the first grid point's deck is read, checked
    and built like any deck (:func:`pydriver.run.deck_info`).

    Raises
    ------
    SweepError
        Missing or unreadable base deck, a base deck path with a control character, bad
        option (named), or an invalid first grid point.
    """
    base = checked_path(base, "base deck")
    if not base.is_file():
        raise SweepError(f"base deck '{base}' not found")
    try:
        base_text = base.read_text()
    except (OSError, UnicodeDecodeError) as exc:
        raise SweepError(f"base deck '{base}': cannot read it: {reason(exc)}") from None
    params, points, scales = expand_grid(list(sets))
    try:
        base_nml = parse_namelist(strip_comments(base_text), base.name)
    except DeckError as exc:
        raise SweepError(f"base deck {base.name}: {exc}") from None
    check_against_base(list(sets), params, base_nml)
    width = max(4, len(str(len(points) - 1)))
    manifest = {
        "format": "rotorcable-sweep/1",
        "base_deck": str(base),
        "base_sha256": hashlib.sha256(base_text.encode()).hexdigest(),
        "sets": list(sets),
        "params": params,
        "scales": scales,
        "points": [{"id": f"{i:0{width}d}", "values": v} for i, v in enumerate(points)],
        "python": sys.executable,
    }
    first = manifest["points"][0]
    with writing(tempfile.gettempdir()), tempfile.TemporaryDirectory() as tmp:
        probe = Path(tmp) / f"{first['id']}.nml"
        try:
            probe.write_text(deck_text(base, params, first["values"], first["id"]))
            deck_info(probe)
        except DeckError as exc:
            raise _first_point_error(exc, base, sets, params, first) from None
    return manifest


def _grid_of(manifest: dict) -> tuple:
    return (manifest["base_sha256"], manifest["params"],
            [p["values"] for p in manifest["points"]])


def _adopt(out: Path, manifest: dict) -> dict:
    """Under the lock: the manifest of ``out`` if it holds this sweep, else write ours."""
    if existing_manifest(out) is not None:
        old = read_manifest(out)
        if _grid_of(old) != _grid_of(manifest):
            what = ("its base deck differs" if old["base_sha256"] != manifest["base_sha256"]
                    else f"its grid differs (it was {' '.join('--set ' + s for s in old['sets'])})")
            raise SweepError(f"{out} holds another sweep: {what}.  Resume with the same base deck "
                             f"and --set options, or choose a new --out.")
        return old                      # keep the original record of how it was made
    if any((out / name).exists() for name in ("runs", "decks", TABLE)):
        raise SweepError(f"{out} holds sweep files but no {MANIFEST}; choose a new --out")
    write_file(out, MANIFEST, json.dumps(manifest, indent=1) + "\n")
    return manifest


def _write_decks(out: Path, base: Path, manifest: dict) -> None:
    """``decks/<id>.nml`` for every grid point; decks already right are left untouched."""
    (out / "decks").mkdir(exist_ok=True)
    (out / "runs").mkdir(exist_ok=True)
    claim(out, [f"decks/{p['id']}.nml" for p in manifest["points"]])
    for p in manifest["points"]:
        deck = out / "decks" / f"{p['id']}.nml"
        try:
            text = deck_text(base, manifest["params"], p["values"], p["id"])
        except DeckError as exc:
            raise SweepError(f"{out}: grid point {p['id']}: cannot write its deck: {exc}") from None
        if not deck.is_file() or deck.read_text() != text:
            write_atomic(deck, text)


@contextlib.contextmanager
def open_sweep(base, sets: list[str], out):
    """Check a sweep, take its directory and write its manifest and decks; yield the manifest.

    The lock of ``out`` is held for the whole ``with`` block (the run of the decks).

    Parameters
    ----------
    base : str or Path
        Base deck.
    sets : list of str
        ``GROUP.KEY=VALUES`` options (grid syntax in ``GRID_HELP``).
    out : str or Path
        Sweep directory, created if needed.  If it already holds a sweep, its grid and base
        deck must be the same (a resume); decks already written are left untouched.

    Yields
    ------
    dict
        The manifest (the one already in ``out`` for a resume).

    Raises
    ------
    SweepError
        Bad option (named), first grid point not a valid deck, another sweep running in
        ``out``, ``out`` holding a different sweep or anything but this sweep (named:
        :mod:`pydriver.sweep.layout`), ``out`` a link, ``out`` or ``base`` with a control
        character, or a file of the sweep that cannot be written (named, with the reason).
    """
    out = checked_path(out, "--out", link_ok=False)
    manifest = plan(base, sets)            # nothing is written before this passes
    check_sweep_directory(out, manifest)
    with writing(out):
        out.mkdir(parents=True, exist_ok=True)
    with hold_lock(out):
        check_sweep_directory(out, manifest)      # again, now that no other sweep can write
        with writing(out):
            manifest = _adopt(out, manifest)
            _write_decks(out, Path(base).resolve(), manifest)
        yield manifest


def prepare(base, sets: list[str], out) -> dict:
    """Write ``DIR/sweep.json`` and ``DIR/decks/`` (under the lock, released on return).

    Parameters and exceptions as :func:`open_sweep`; returns the manifest.
    """
    with open_sweep(base, sets, out) as manifest:
        return manifest
