"""A reference document (headings, paragraphs, tables) and its three forms: Markdown (the files
``docs/deck_reference.md`` and ``docs/outputs.md``), terminal text and a self-contained HTML page
(``rotorcable keys``, ``rotorcable outputs``, ``rotorcable docs``; issue 37).

The references are built from the tables that drive the program (the deck schema, the output
columns), so the installed tool prints the same reference the source tree carries as Markdown.
Cell and paragraph texts use two pieces of Markdown inline markup only: ```code``` and
``*emphasis*``; each form renders them its own way (the terminal drops the marks).
"""

from __future__ import annotations

import html
import re
import shutil
import textwrap
from dataclasses import dataclass, field

_CODE = re.compile(r"`([^`]*)`")
# *word ...*, not the * of 3*v3 or of a unit '*'.
_EMPHASIS = re.compile(r"(?<![\w*])\*(\w(?:[^*]*\w)?)\*(?![\w*])")


@dataclass
class Table:
    """A table: its column headings and its rows (cells are texts with inline markup)."""

    header: tuple[str, ...]
    rows: list[tuple[str, ...]] = field(default_factory=list)


@dataclass
class Section:
    """A titled part of a document: paragraphs, then a table."""

    title: str
    paragraphs: list[str] = field(default_factory=list)
    table: Table | None = None


@dataclass
class Document:
    """A reference document.

    Attributes
    ----------
    title : str
    paragraphs : list of str
        The introduction.
    sections : list of Section
    source_note : str
        Where a generated Markdown file comes from (shown in the Markdown form only: it is about
        the file, not about what it describes).
    """

    title: str
    paragraphs: list[str] = field(default_factory=list)
    sections: list[Section] = field(default_factory=list)
    source_note: str = ""


def markdown(doc: Document) -> str:
    """The document as Markdown (the form of the files in ``docs/``), ending in a newline."""
    lines = [f"# {doc.title}", ""]
    for para in ([doc.source_note] if doc.source_note else []) + doc.paragraphs:
        lines += [para, ""]
    for section in doc.sections:
        lines += [f"## {section.title}", ""]
        for para in section.paragraphs:
            lines += [para, ""]
        if section.table is not None:
            t = section.table
            lines.append("| " + " | ".join(t.header) + " |")
            lines.append("|" + "---|" * len(t.header))
            # A bare | would split the cell (GitHub's tables take \| inside code spans too).
            lines += ["| " + " | ".join(c.replace("|", "\\|") for c in row) + " |" for row in t.rows]
            lines.append("")
    return "\n".join(lines)


def _inline(text: str, code, emphasis, other=lambda s: s) -> str:
    """``text`` with its code spans rendered by ``code`` (their text is literal), and emphasis and
    the rest of the text outside them by ``emphasis`` and ``other``."""
    out = []
    for i, part in enumerate(text.split("`")):
        if i % 2:
            out.append(code(part))
        else:
            out.append(_EMPHASIS.sub(lambda m: emphasis(m.group(1)), other(part)))
    return "".join(out)


def _plain(text: str) -> str:
    """A text without its inline marks (for the terminal)."""
    return _inline(text, lambda s: s, lambda s: s)


def text(doc: Document, width: int | None = None) -> str:
    """The document for a terminal: each table row as a name, its meaning below it, then its
    other cells as 'heading value' pairs; wrapped to ``width`` (default: the terminal's, at
    most 100 columns)."""
    if width is None:
        width = min(100, shutil.get_terminal_size((100, 24)).columns)
    width = max(width, 40)

    def wrap(s: str, indent: str) -> list[str]:
        return textwrap.wrap(_plain(s), width, initial_indent=indent, subsequent_indent=indent,
                             break_on_hyphens=False, break_long_words=False) or [indent.rstrip()]

    lines = [_plain(doc.title), "=" * len(_plain(doc.title)), ""]
    for para in doc.paragraphs:
        lines += wrap(para, "") + [""]
    for section in doc.sections:
        title = _plain(section.title)
        lines += [title, "-" * len(title)]
        for para in section.paragraphs:
            lines += wrap(para, "") + [""]
        if section.table is not None:
            head = section.table.header
            for row in section.table.rows:
                lines.append("  " + _plain(row[0]))
                lines += wrap(row[-1], "      ")
                details = "; ".join(f"{h} {_plain(c)}" for h, c in zip(head[1:-1], row[1:-1]) if c.strip())
                if details:
                    lines += wrap(details, "      ")
        lines.append("")
    return "\n".join(lines).rstrip("\n") + "\n"


def _inline_html(s: str) -> str:
    """Inline marks as HTML."""
    return _inline(s, lambda c: f"<code>{html.escape(c)}</code>", lambda e: f"<em>{e}</em>", html.escape)


def _anchor(title: str) -> str:
    return re.sub(r"[^a-z0-9_.-]+", "-", _plain(title).lower()).strip("-")


def html_page(docs: list[Document], title: str) -> str:
    """One self-contained HTML page of the documents (no scripts, no outside files), with a
    table of contents."""
    parts = ["<!DOCTYPE html>", '<html lang="en">', "<head>", '<meta charset="utf-8">',
             f"<title>{html.escape(title)}</title>",
             "<style>body{font-family:sans-serif;max-width:72em;margin:1em auto;padding:0 1em;line-height:1.4}"
             "table{border-collapse:collapse;margin:0.5em 0 1.5em}th,td{border:1px solid #ccc;padding:0.2em 0.5em;"
             "vertical-align:top;text-align:left}th{background:#f0f0f0}code{background:#f4f4f4}"
             "nav ul{columns:3}</style>",
             "</head>", "<body>"]
    for doc in docs:
        parts.append(f'<h1 id="{_anchor(doc.title)}">{_inline_html(doc.title)}</h1>')
        parts += [f"<p>{_inline_html(p)}</p>" for p in doc.paragraphs]
        parts.append("<nav><ul>" + "".join(f'<li><a href="#{_anchor(s.title)}">{_inline_html(s.title)}</a></li>'
                                          for s in doc.sections) + "</ul></nav>")
        for section in doc.sections:
            parts.append(f'<h2 id="{_anchor(section.title)}">{_inline_html(section.title)}</h2>')
            parts += [f"<p>{_inline_html(p)}</p>" for p in section.paragraphs]
            if section.table is not None:
                t = section.table
                parts.append("<table><thead><tr>" + "".join(f"<th>{_inline_html(h)}</th>" for h in t.header)
                             + "</tr></thead><tbody>")
                parts += ["<tr>" + "".join(f"<td>{_inline_html(c)}</td>" for c in row) + "</tr>" for row in t.rows]
                parts.append("</tbody></table>")
    parts += ["</body>", "</html>", ""]
    return "\n".join(parts)
