"""Shared helpers for the rotorcable tests."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
INPUTS = ROOT / "inputs"
DATA = Path(__file__).resolve().parent / "data"


def thesis(name: str) -> dict:
    """Reference numbers typed from the thesis (tests/data/<name>.json)."""
    return json.loads((DATA / f"{name}.json").read_text())


def edit_deck(src: Path, dst: Path, group: str, assignments: dict | None = None,
              drop_group: bool = False, raw: str | None = None) -> Path:
    """Copy a deck, replacing keys inside one namelist group (or dropping the group).

    ``assignments`` maps key -> value text; keys already present are replaced, new ones
    appended to the group.  ``raw`` is appended verbatim inside the group.
    """
    text = src.read_text()
    pat = re.compile(rf"(&{group}\b)(.*?)(\n\s*/)", re.S | re.I)
    m = pat.search(text)
    if drop_group:
        assert m, f"group {group} not in {src}"
        text = text[:m.start()] + text[m.end():]
    else:
        if m is None:
            text += f"\n&{group}\n/\n"
            m = pat.search(text)
        body = m.group(2)
        for key, value in (assignments or {}).items():
            kpat = re.compile(rf"^\s*{key}\s*=.*$", re.M | re.I)
            if kpat.search(body):
                body = kpat.sub(f"  {key} = {value}", body)
            else:
                body += f"\n  {key} = {value}"
        if raw:
            body += "\n  " + raw
        text = text[:m.start()] + m.group(1) + body + m.group(3) + text[m.end():]
    dst.write_text(text)
    return dst


@pytest.fixture
def deck_copy(tmp_path):
    """Factory: deck_copy('six_link_static', group, {...}) -> path of an edited copy."""
    def make(stem, group=None, assignments=None, **kw):
        src = INPUTS / f"{stem}.nml"
        dst = tmp_path / f"{stem}_{len(list(tmp_path.iterdir()))}.nml"
        if group is None:
            dst.write_text(src.read_text())
            return dst
        return edit_deck(src, dst, group, assignments, **kw)
    return make
