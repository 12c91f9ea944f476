"""The example decks shipped with rotorcable: found in a source checkout (``inputs/``) or in an
installed package (``pydriver/examples/``, package data of the wheel), copied out for a user,
or used as the start of a new deck (``rotorcable examples``, ``rotorcable init``).

Neither command overwrites a file: an example already in the target directory is left as it
is and named, and ``init`` refuses an existing deck (a user's file is never replaced).  Each
file is created new, never through a link (:func:`pydriver.ownership.create_new_file`): a link
placed where a deck would go, even one that points nowhere, counts as a file already there.
"""

from __future__ import annotations

import difflib
from datetime import date
from pathlib import Path

from pydriver.ownership import create_new_file

_PACKAGE = Path(__file__).resolve().parent


def examples_dir() -> Path:
    """The directory holding the example decks: the installed package's ``examples/``, or the
    source checkout's ``inputs/`` (an editable install or a run from the project root)."""
    for candidate in (_PACKAGE / "examples", _PACKAGE.parent / "inputs"):
        if (candidate / "uh60_part2_forward_flight_cable.nml").is_file():
            return candidate
    raise FileNotFoundError(f"no example decks beside {_PACKAGE} (a broken installation: reinstall rotorcable)")


def example_names() -> list[str]:
    """The example decks' names (file stems), sorted."""
    return sorted(p.stem for p in examples_dir().glob("*.nml"))


#: The files of the examples: the decks and the tables they read (a usage spectrum's blade table).
EXAMPLE_FILES = ("*.nml", "*.csv")


def copy_examples(dest) -> tuple[list[Path], list[Path]]:
    """Copy every example deck, and every table a deck reads, into ``dest`` (created if missing).

    Returns
    -------
    written, kept : list of Path
        The files copied, and the names already taken in ``dest`` (a file, a directory or a
        link: left untouched).

    Raises
    ------
    OSError
        ``dest`` cannot be made or written.
    """
    dest = Path(dest)
    dest.mkdir(parents=True, exist_ok=True)
    written, kept = [], []
    for src in sorted(p for pattern in EXAMPLE_FILES for p in examples_dir().glob(pattern)):
        target = dest / src.name
        try:
            create_new_file(target, src.read_bytes())
        except FileExistsError:
            kept.append(target)
            continue
        written.append(target)
    return written, kept


#: Where ``init``'s header sends a user for the keys: commands of the installed program (the
#: source tree's docs/ are not installed); tests/test_packaging.py runs each of them.
HEADER_REFERENCE = ("Every key: `rotorcable keys` (one group: `rotorcable keys chain`,\n"
                    "! one key: `rotorcable keys t_end`); the output files: `rotorcable outputs`.")


def example_name(like: str) -> str:
    """The example deck ``like`` names: its stem, with or without ``.nml``.

    Raises
    ------
    ValueError
        No example has that name; the message suggests the closest and lists them all.
    """
    names = example_names()
    stem = like[:-4] if like.lower().endswith(".nml") else like
    if stem in names:
        return stem
    close = difflib.get_close_matches(stem, names, n=3, cutoff=0.6)
    hint = f"; did you mean {' or '.join(close)}?" if close else ";"
    raise ValueError(f"--like {like}: no such example deck{hint} the examples are: {', '.join(names)}")


def init_deck(path, like: str) -> Path:
    """Write a new deck ``path`` that starts as the example ``like``, with a header saying so.

    Raises
    ------
    FileExistsError
        ``path`` exists, or is a link (it is never replaced, nor written through).
    ValueError
        ``like`` is not an example deck (its name with or without ``.nml``).
    """
    path = Path(path)
    like = example_name(like)
    if path.exists() or path.is_symlink():
        raise FileExistsError(f"{path} exists; rotorcable init never replaces a file (choose another name)")
    text = (examples_dir() / f"{like}.nml").read_text(encoding="utf-8")
    header = (f"! {path.name}: a new deck, started on {date.today().isoformat()} from the example '{like}'\n"
              f"! (rotorcable init).  {HEADER_REFERENCE}\n"
              "! SI units, angles in degrees.  Change the case name, the cable and the supports, then:\n"
              f"! rotorcable run {path.name}\n!\n")
    text = text.replace(f"name = '{like}'", f"name = '{path.stem}'", 1)
    path.parent.mkdir(parents=True, exist_ok=True)
    try:
        return create_new_file(path, header + text)        # fails if it appeared meanwhile
    except FileExistsError:
        raise FileExistsError(f"{path} exists; rotorcable init never replaces a file (choose another "
                              "name)") from None
