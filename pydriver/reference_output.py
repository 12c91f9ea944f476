"""Where a generated reference goes: the terminal (:func:`print_text`, ``rotorcable keys``,
``outputs``, ``docs``) or a file of the source checkout's ``docs/`` (:func:`write_generated`,
``python -m pydriver.deck_reference``, ``python -m pydriver.output_columns``).

The references themselves are made elsewhere (:mod:`pydriver.reference`, the deck schema, the
output columns); this module only delivers text, so each of them can use it without importing
the others.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

#: The source checkout's root, where ``docs/`` holds the generated references (None when installed).
_ROOT = Path(__file__).resolve().parents[1]


def print_text(text: str) -> None:
    """Print ``text``; a reader that stops early (``rotorcable keys | head``) ends the output
    quietly, without a traceback."""
    try:
        sys.stdout.write(text)
        sys.stdout.flush()
    except BrokenPipeError:
        # Python's advice (signal docs, "Note on SIGPIPE"): point stdout at devnull so that the
        # flush at exit does not fail again.
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())


def source_checkout_file(name: str) -> Path | None:
    """``docs/<name>`` of the source checkout this module runs from, or None for an installed
    package (its parent is site-packages, which has no docs of ours)."""
    path = _ROOT / "docs" / name
    return path if (_ROOT / "meson.build").is_file() and path.is_file() else None


def write_generated(argv: list, name: str, content: str, first_line: str) -> int:
    """The ``main`` of a generator of ``docs/<name>``.

    With a PATH argument the reference goes there; without one, to the source checkout's
    ``docs/<name>``, or, installed, to stdout.  A file is replaced only if it is such a generated
    reference already (its first line is ``first_line``): a user's file is never overwritten.

    Parameters
    ----------
    argv : list of str
        The command's arguments: empty, or the PATH to write.
    name : str
        The file's name in ``docs/``.
    content : str
        The reference.
    first_line : str
        The first line every such generated reference starts with.

    Returns
    -------
    int
        The exit status: 0 written (or printed), 1 refused or not writable (said on stderr).
    """
    if argv and argv[0].startswith("-"):      # an option, not a path: say how it is used
        print(f"usage: python -m pydriver.<generator> [PATH]: write docs/{name} (or PATH; installed: "
              "print it)", file=sys.stderr if argv[0] not in ("-h", "--help") else sys.stdout)
        return 0 if argv[0] in ("-h", "--help") else 1
    if not argv:
        target = source_checkout_file(name)
        if target is None:
            print_text(content)
            return 0
    else:
        target = Path(argv[0])
    if target.is_symlink() or target.is_dir() or (
            target.exists() and target.read_text(encoding="utf-8", errors="replace").split("\n", 1)[0] != first_line):
        print(f"error: {target} exists and is not a reference this command wrote; give a new file name",
              file=sys.stderr)
        return 1
    try:
        target.write_text(content, encoding="utf-8")
    except OSError as exc:
        print(f"error: cannot write {target}: {exc.strerror or exc}", file=sys.stderr)
        return 1
    print(f"wrote {target}")
    return 0
