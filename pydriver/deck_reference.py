"""``python -m pydriver.deck_reference [PATH]``: write the deck reference generated from the
schema (default ``docs/deck_reference.md``; tests/test_deck_schema.py checks it is current)."""

from __future__ import annotations

import sys
from pathlib import Path

from pydriver.schema import reference_markdown

DEFAULT = Path(__file__).resolve().parents[1] / "docs" / "deck_reference.md"


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    target = Path(argv[0]) if argv else DEFAULT
    target.write_text(reference_markdown() + "\n", encoding="utf-8")
    print(f"wrote {target}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
