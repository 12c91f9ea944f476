"""The reference at hand (issue 37): ``rotorcable keys``, ``rotorcable outputs`` and ``rotorcable
docs`` print the deck reference and the output reference generated from the schema and the
output table, in the terminal, as Markdown (the very files of docs/) and as one HTML page; the
studies' outputs have their rows.  tests/test_packaging.py runs the commands from an installed
wheel."""

from __future__ import annotations

import csv
import json
import subprocess
import sys
from html.parser import HTMLParser

import pytest

from conftest import INPUTS, ROOT
from pydriver.output_columns import COLUMNS, bare_name, column_of
from pydriver.reference import full_reference, keys_reference, outputs_reference
from pydriver.schema import GROUPS, KEYS


def cli(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "pydriver", *args], capture_output=True, text=True, cwd=cwd)


class _Tags(HTMLParser):
    """The open/close balance of the block tags of a page."""

    BLOCKS = ("html", "head", "body", "table", "thead", "tbody", "tr", "td", "th", "p", "h1", "h2", "code", "nav")

    def __init__(self):
        super().__init__()
        self.stack, self.errors, self.tables, self.text = [], [], 0, []

    def handle_starttag(self, tag, attrs):
        if tag in self.BLOCKS:
            self.stack.append(tag)
        self.tables += tag == "table"

    def handle_endtag(self, tag):
        if tag in self.BLOCKS:
            if not self.stack or self.stack.pop() != tag:
                self.errors.append(tag)

    def handle_data(self, data):
        self.text.append(data)


class TestKeys:
    def test_every_key_in_every_form(self):
        text, md, page = (keys_reference(fmt=f) for f in ("text", "markdown", "html"))
        for k in KEYS:
            assert f"\n  {k.name}\n" in text, k.name                 # one block per key in the terminal
            assert f"| `{k.name}` |" in md and f"<td><code>{k.name}</code></td>" in page, k.name
        for group in GROUPS:
            assert f"\n&{group}\n" in text and f"## &{group}" in md

    def test_markdown_is_the_docs_file(self):
        """The installed command prints what the source tree carries (docs/deck_reference.md)."""
        assert keys_reference(fmt="markdown") + "\n" == (ROOT / "docs" / "deck_reference.md").read_text()
        assert outputs_reference(fmt="markdown") == (ROOT / "docs" / "outputs.md").read_text()

    @pytest.mark.parametrize("name,groups,keys", [
        ("chain", ["chain"], list(GROUPS["chain"])), ("&solver", ["solver"], list(GROUPS["solver"])),
        ("t_end", ["solver"], ["t_end"]), ("gamma_deg", ["shape", "clamp_a", "clamp_b"], ["gamma_deg"]),
        ("clamp_b.gamma_deg", ["clamp_b"], ["gamma_deg"]), ("&clamp_b gamma_deg", ["clamp_b"], ["gamma_deg"])])
    def test_one_group_or_key(self, name, groups, keys):
        text = keys_reference(name)
        shown_groups = [g for g in GROUPS if f"\n&{g}\n" in text]
        shown_keys = {k.name for k in KEYS if f"\n  {k.name}\n" in text}
        assert shown_groups == groups and shown_keys == set(keys)
        assert "Fortran namelist" not in text                      # the introduction only with the whole

    def test_an_unknown_name_gets_the_closest(self):
        with pytest.raises(ValueError, match="did you mean chain"):
            keys_reference("chian")

    def test_text_is_wrapped_for_a_terminal(self):
        assert max(len(line) for line in keys_reference(fmt="text").splitlines()) <= 100
        from pydriver import document
        from pydriver.schema import reference_document
        assert max(len(line) for line in document.text(reference_document("design"), width=60).splitlines()) <= 60
        # The marks are Markdown's: the terminal shows the words, and keeps a literal * (3*v3, unit *).
        text = keys_reference(fmt="text")
        assert "Differentiable (&design parameters)" in text and "*Differentiable*" not in text and "`" not in text
        assert "3*v3" in text and "n*value" in text


class TestOutputs:
    def test_every_column_in_every_form(self):
        text, md, page = (outputs_reference(fmt=f) for f in ("text", "markdown", "html"))
        for c in COLUMNS:
            assert f"\n  {c.pattern}\n" in text and f"| `{c.pattern}` |" in md, c.pattern
            assert f"<code>{c.pattern}</code>" in page.replace("&quot;", '"'), c.pattern

    def test_one_file(self):
        text = outputs_reference("fatigue")
        assert "fatigue.csv" in text and "damage_per_hour" in text and "timeseries.csv" not in text
        assert outputs_reference("summary.json").count("\n  ") > 5
        with pytest.raises(ValueError, match="did you mean fatigue.csv"):
            outputs_reference("fatgue.csv")

    def test_html_page_is_whole(self):
        """One self-contained page of both references: balanced tags, a table per section, no
        Markdown marks left in its text."""
        page = full_reference("html")
        tags = _Tags()
        tags.feed(page)
        assert not tags.errors and not tags.stack
        assert tags.tables == len(GROUPS) + len({f for c in COLUMNS for f in c.files}) + 1   # + summary.json
        assert "`" not in "".join(tags.text) and "<script" not in page and "src=" not in page

    def test_study_outputs_have_rows(self, tmp_path):
        """Every key and column the cy-sweep and refine studies write has its row, and
        frequency_vs_cy.csv carries units in its header (issue 37)."""
        from pydriver.study import run_study
        for name in ("refine", "cy-sweep"):
            run_study(name, tmp_path / name, inputs=INPUTS)
        for file, sub in (("refinement.json", "refine"), ("flap_crossing.json", "cy-sweep")):
            keys = json.loads((tmp_path / sub / file).read_text())
            assert keys and all(column_of(file, k) is not None for k in keys), (file, keys)
        with (tmp_path / "cy-sweep" / "frequency_vs_cy.csv").open() as fh:
            header = next(csv.reader(fh))
        assert header == ["c_y_Nm_per_rad [Nm/rad]", "f_undamped_hz [Hz]", "f_damped_hz [Hz]", "zeta [-]"]
        assert all(column_of("frequency_vs_cy.csv", bare_name(c)) is not None for c in header)


class TestCommands:
    def test_keys_outputs_docs(self):
        done = cli("keys", "t_end")
        assert done.returncode == 0 and "end time of a dynamic run" in done.stdout and done.stderr == ""
        done = cli("outputs", "fatigue.csv", "--format", "markdown")
        assert done.returncode == 0 and done.stdout.startswith("# Output files")
        done = cli("docs", "--format", "html")
        assert done.returncode == 0 and done.stdout.startswith("<!DOCTYPE html>")

    def test_unknown_name_is_an_error_without_traceback(self):
        done = cli("keys", "t_edn")
        assert done.returncode == 2 and "did you mean t_end" in done.stderr and "Traceback" not in done.stderr

    def test_a_reader_that_stops_early(self):
        """`rotorcable docs | head -3`: no BrokenPipeError traceback."""
        done = subprocess.run(f"'{sys.executable}' -m pydriver docs | head -3", shell=True, capture_output=True,
                              text=True)
        assert done.stdout.splitlines()[0] == "Deck reference" and done.stderr == ""


class TestGenerators:
    """``python -m pydriver.deck_reference PATH`` and ``python -m pydriver.output_columns PATH``
    write where they are told, replace an earlier reference of theirs and no other file."""

    @pytest.mark.parametrize("module,first", [("pydriver.deck_reference", "# Deck reference"),
                                              ("pydriver.output_columns", "# Output files")])
    def test_path(self, tmp_path, module, first):
        target = tmp_path / "ref.md"
        for _ in range(2):                                     # new, then its own earlier output
            done = subprocess.run([sys.executable, "-m", module, str(target)], capture_output=True, text=True)
            assert done.returncode == 0, done.stderr
            assert target.read_text().startswith(first + "\n")
        user = tmp_path / "notes.md"
        user.write_text("my notes\n")
        done = subprocess.run([sys.executable, "-m", module, str(user)], capture_output=True, text=True)
        assert done.returncode == 1 and "not a reference this command wrote" in done.stderr
        assert user.read_text() == "my notes\n" and "Traceback" not in done.stderr
