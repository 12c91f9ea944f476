"""The installed program's own reference (issue 37): ``rotorcable keys [GROUP or KEY]``,
``rotorcable outputs [FILE]`` and ``rotorcable docs``, in the terminal, as Markdown or as one
HTML page.

Nothing is read from files: the references are generated at run time from the tables that are
installed with the program, the deck schema (:func:`pydriver.schema.reference_document`) and the
output columns (:func:`pydriver.output_columns.outputs_document`), so a ``pip install`` has the
same reference as the source tree's ``docs/deck_reference.md`` and ``docs/outputs.md``.  The
commands print; a file is the user's redirection.  Writing the two files of ``docs/`` is
:func:`write_generated` (``python -m pydriver.deck_reference``, ``python -m pydriver.output_columns``).
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

from pydriver import document

FORMATS = ("text", "markdown", "html")
#: The source checkout's root, where ``docs/`` holds the generated references (None when installed).
_ROOT = Path(__file__).resolve().parents[1]


def render(docs: list, fmt: str, title: str) -> str:
    """The documents in one of :data:`FORMATS`."""
    if fmt == "markdown":
        return "\n".join(document.markdown(d) for d in docs)
    if fmt == "html":
        return document.html_page(docs, title)
    return "\n".join(document.text(d) for d in docs)


def keys_reference(name: str = "", fmt: str = "text") -> str:
    """``rotorcable keys``: the deck reference, or one group's or one key's part of it.

    Raises
    ------
    ValueError
        ``name`` is no group and no key (the message names the closest).
    """
    from pydriver.key_scope import describe
    from pydriver.schema import reference_document
    return render([reference_document(name, acts=describe)], fmt, "rotorcable deck reference")


def outputs_reference(file: str = "", fmt: str = "text") -> str:
    """``rotorcable outputs``: the output reference, or one file's part of it.

    Raises
    ------
    ValueError
        ``file`` is no output file (the message lists them).
    """
    from pydriver.output_columns import outputs_document
    return render([outputs_document(file)], fmt, "rotorcable output files")


def full_reference(fmt: str = "text") -> str:
    """``rotorcable docs``: the deck reference and the output reference together."""
    from pydriver.output_columns import outputs_document
    from pydriver.key_scope import describe
    from pydriver.schema import reference_document
    return render([reference_document(acts=describe), outputs_document()], fmt, "rotorcable reference")


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
    """
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
