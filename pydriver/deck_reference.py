"""``python -m pydriver.deck_reference [PATH]``: write the deck reference generated from the
schema (tests/test_deck_schema.py checks that ``docs/deck_reference.md`` is current).

Without PATH it writes the source checkout's ``docs/deck_reference.md``; an installed package
has no ``docs/`` and prints the reference instead (``rotorcable keys`` is the command for users).
"""

from __future__ import annotations

import sys

from pydriver.document import markdown
from pydriver.key_scope import describe
from pydriver.reference_output import write_generated
from pydriver.schema import reference_document


def reference_markdown() -> str:
    """``docs/deck_reference.md``: the schema as tables, one per group, with each key's scope
    from :mod:`pydriver.key_scope` (generated)."""
    return markdown(reference_document(acts=describe))


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    return write_generated(argv, "deck_reference.md", reference_markdown() + "\n", "# Deck reference")


if __name__ == "__main__":
    sys.exit(main())
