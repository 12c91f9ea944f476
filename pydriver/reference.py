"""The installed program's own reference (issue 37): ``rotorcable keys [GROUP or KEY]``,
``rotorcable outputs [FILE]`` and ``rotorcable docs``, in the terminal, as Markdown or as one
HTML page.

Nothing is read from files: the references are generated at run time from the tables that are
installed with the program, the deck schema (:func:`pydriver.schema.reference_document`) and the
output columns (:func:`pydriver.output_columns.outputs_document`), so a ``pip install`` has the
same reference as the source tree's ``docs/deck_reference.md`` and ``docs/outputs.md``.  The
commands print (:func:`pydriver.reference_output.print_text`); a file is the user's
redirection.  Writing the two files of ``docs/`` is
:func:`pydriver.reference_output.write_generated` (``python -m pydriver.deck_reference``,
``python -m pydriver.output_columns``).
"""

from __future__ import annotations

from pydriver import document
from pydriver.key_scope import describe
from pydriver.output_columns import outputs_document
from pydriver.schema import reference_document

FORMATS = ("text", "markdown", "html")


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
    return render([reference_document(name, acts=describe)], fmt, "rotorcable deck reference")


def outputs_reference(file: str = "", fmt: str = "text") -> str:
    """``rotorcable outputs``: the output reference, or one file's part of it.

    Raises
    ------
    ValueError
        ``file`` is no output file (the message lists them).
    """
    return render([outputs_document(file)], fmt, "rotorcable output files")


def full_reference(fmt: str = "text") -> str:
    """``rotorcable docs``: the deck reference and the output reference together."""
    return render([reference_document(acts=describe), outputs_document()], fmt, "rotorcable reference")
