"""A report a person reads (issue 13): legible plots, the terminal summary, report.html."""

from __future__ import annotations

import re
import subprocess
import sys

import matplotlib
import pytest

matplotlib.use("Agg")

import pydriver                                     # noqa: E402
from conftest import INPUTS, ROOT                   # noqa: E402
from pydriver import plots                          # noqa: E402


def test_the_legibility_check_finds_what_it_should():
    """Overlapping labels and an axis without a unit are reported; a clean figure is not."""
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots()
    ax.plot([0, 1], [0, 1])
    ax.set_xlabel("t [s]"); ax.set_ylabel("force")
    ax.text(0.5, 0.5, "first label"); ax.text(0.5, 0.5, "second label")
    problems = plots.legibility_problems(fig)
    assert any("overlaps" in p for p in problems)
    assert any("unit" in p and "force" in p for p in problems)
    plt.close(fig)
    fig, ax = plt.subplots()
    ax.plot([0, 1], [0, 1], label="line")
    ax.set_xlabel("t [s]"); ax.set_ylabel("force [N]"); ax.legend()
    assert plots.legibility_problems(fig) == []
    plt.close(fig)


@pytest.mark.parametrize("deck", ["uh60_part2", "six_link_dynamic", "uh60_part2_forward_flight_cable",
                                  "uh60_part2_campbell_soft"])
def test_every_plot_passes_the_legibility_check(deck, tmp_path, monkeypatch):
    """Every figure a run writes, as written (after the 3-D views are decluttered): no text
    overlaps other text, every axis that shows numbers has a unit."""
    found = {}
    write = plots._write

    def checked(fig, out, name):
        found[name] = plots.legibility_problems(fig)
        return write(fig, out, name)

    monkeypatch.setattr(plots, "_write", checked)
    pydriver.run_deck(INPUTS / f"{deck}.nml", out=tmp_path / "run", plots=True)
    assert found, "no figure was written"
    assert {name: p for name, p in found.items() if p} == {}


@pytest.fixture(scope="module")
def flight_report(tmp_path_factory):
    out = tmp_path_factory.mktemp("report") / "run"
    cmd = [sys.executable, "-m", "pydriver", "run", str(INPUTS / "uh60_part2_forward_flight_cable.nml"),
           "--out", str(out), "--report"]
    done = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT)
    assert done.returncode == 0, done.stderr
    return done.stdout, out


def test_terminal_summary_is_short_and_has_units(flight_report):
    text, out = flight_report
    assert "F_A [N]" in text and "M_B [Nm]" in text
    assert re.search(r"peak bending \[Nm\]\s+\d+\.\d+ \+- ", text)          # a value with its error bar
    assert "fatigue hotspot 1" in text and str(out) in text
    assert not re.search(r"\d\.\d{12,}", text)                              # no 17-digit dumps


def test_report_html_is_self_contained(flight_report):
    """One file: inputs, the converged numbers, the fatigue table and the figures embedded."""
    _, out = flight_report
    html = (out / "report.html").read_text()
    assert "<h2>Fatigue hotspots</h2>" in html and "Richardson" in html
    # The flight run's figures, and the shape of the mode within the resonance margin (issue 21).
    assert html.count("data:image/png;base64,") == 4
    assert all(name in html for name in ("envelopes.png", "loads_vs_azimuth.png", "shapes_vs_azimuth.png",
                                         "mode1_shape.png"))
    assert "<h2>Resonance margins</h2>" in html and "WITHIN MARGIN" in html
    assert not re.search(r"""(src|href)=["']?(https?:|file:|/)""", html)    # nothing fetched from elsewhere
    assert "ei" in html and "1.906" in html                                 # the inputs
