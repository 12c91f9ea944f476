"""Numeric tables a deck points to (a blade's angles against azimuth, an S-N curve): CSV files
with a header row naming the columns.

Such a file is input like the deck itself: everything wrong with it (missing, unreadable, a
column missing, a cell that is no finite number, too few rows) is a ValueError whose message
names the file and, for a bad cell, its line and column, and the caller turns it into a
DeckError naming the deck key that named the file.  The header may carry units in brackets
(``azimuth [deg]``), as the program's own CSV files do (:mod:`pydriver.output_columns`); names
are compared without them and without case.  Lines that start with ``#`` are comments.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np

from pydriver.output_columns import bare_name

#: The largest table read (rows): a blade record of 0.1 deg steps has 3600; an S-N curve a few
#: dozen.  Beyond it the file is not what the key asks for.
MAX_ROWS = 100_000


def resolve(path_text: str, deck_path) -> Path:
    """A path a deck gives, relative to the deck's own directory (absolute paths as they are);
    a deck without a file (made in memory) resolves against the working directory."""
    path = Path(path_text).expanduser()
    if path.is_absolute() or deck_path is None:
        return path
    return Path(deck_path).parent / path


def read_columns(path, required: tuple[str, ...], optional: tuple[str, ...] = (), min_rows: int = 1) -> dict:
    """The named columns of a CSV file as float arrays.

    Parameters
    ----------
    path : str or Path
        The file.
    required : tuple of str
        Column names that must be there (lower case, without units).
    optional : tuple of str
        Column names read when present.
    min_rows : int
        Fewest data rows accepted.

    Returns
    -------
    dict
        Name -> numpy array, for every required column and every optional one present; other
        columns are ignored.

    Raises
    ------
    ValueError
        Naming the file (and the line and column of a bad cell).
    """
    path = Path(path)
    try:
        with open(path, encoding="utf-8", newline="") as fh:
            lines = [(k, line) for k, line in enumerate(fh, start=1)
                     if line.strip() and not line.lstrip().startswith("#")]
    except FileNotFoundError:
        raise ValueError(f"{path}: no such file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ValueError(f"{path}: cannot read it: {exc}") from None
    if not lines:
        raise ValueError(f"{path}: empty (a header row and data rows are needed)")
    rows = list(csv.reader(line for _, line in lines))
    header = [bare_name(c).lower() for c in rows[0]]
    missing = [c for c in required if c not in header]
    if missing:
        raise ValueError(f"{path}: no column {', '.join(repr(c) for c in missing)} in the header "
                         f"(it has {', '.join(repr(c) for c in header)})")
    wanted = [c for c in (*required, *optional) if c in header]
    data = rows[1:]
    if len(data) < min_rows:
        raise ValueError(f"{path}: {len(data)} data rows, at least {min_rows} needed")
    if len(data) > MAX_ROWS:
        raise ValueError(f"{path}: {len(data)} data rows, more than {MAX_ROWS}")
    out = {c: np.empty(len(data)) for c in wanted}
    for i, (row, (line, _)) in enumerate(zip(data, lines[1:])):
        for name in wanted:
            col = header.index(name)
            cell = row[col].strip() if col < len(row) else ""
            try:
                value = float(cell)
            except ValueError:
                value = math.nan
            if not math.isfinite(value):
                raise ValueError(f"{path}, line {line}, column '{name}': {cell!r} is not a finite number")
            out[name][i] = value
    return out
