"""A report a person reads (issue 13): legible plots, the terminal summary, report.html."""

from __future__ import annotations

import html
import re
import subprocess
import sys

import matplotlib
import numpy as np
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


def test_the_legibility_check_sees_covered_lines_look_alikes_scale_and_frames():
    """Issue 22's plot faults, each in a small figure: a legend over a curve, two labelled
    lines of near-identical colour, a 3-D panel not to scale, an axis spanning round-off, and
    an axis label on the next panel's frame."""
    import matplotlib.pyplot as plt
    import numpy as np
    fig, ax = plt.subplots()
    ax.plot([0, 1], [1, 1], label="FA_y"); ax.plot([0, 1], [0, 0.2], label="FB_y")
    ax.set_xlabel("t [s]"); ax.set_ylabel("F [N]"); ax.legend(loc="upper right")
    assert any("covers the line 'FA_y'" in p for p in plots.legibility_problems(fig))
    plt.close(fig)
    fig, ax = plt.subplots()
    cmap = plt.get_cmap("viridis")
    ax.plot([0, 1], [0, 1], color=cmap(29 / 43), label="joint 30")
    ax.plot([0, 1], [0.5, 1.5], color=cmap(30 / 43), label="joint 31")
    ax.set_xlabel("t [s]"); ax.set_ylabel("M [Nm]")
    assert any("'joint 30' and 'joint 31' look alike" in p for p in plots.legibility_problems(fig))
    plt.close(fig)
    fig = plt.figure()
    ax = fig.add_subplot(projection="3d")
    ax.plot([0, 0.25, 0.5], [0, 0.05, 0.1], [1e-18, -1e-18, 1e-18])
    ax.set_xlabel("x [m]"); ax.set_ylabel("y [m]"); ax.set_zlabel("z [m]")
    problems = plots.legibility_problems(fig)
    assert any("not to scale" in p for p in problems) and any("round-off" in p for p in problems)
    plt.close(fig)
    fig, ax = plt.subplots(2, 1, figsize=(4, 2.2))
    ax[0].set_xlabel("t [s]"); ax[0].set_ylabel("z [mm]"); ax[1].set_xlabel("f [Hz]"); ax[1].set_ylabel("a [mm]")
    assert any("'t [s]' lies on the frame of another panel" in p for p in plots.legibility_problems(fig))
    plt.close(fig)


def test_shape_panels_are_to_scale_and_show_round_off_as_zero():
    """A planar cable with 1e-18 m of round-off in z: drawn as z = 0, the 3-D box to scale."""
    import matplotlib.pyplot as plt
    import numpy as np
    x = np.linspace(0, 0.6, 12)
    table = {"x_m": x, "y_m": 0.1 * x**2, "z_m": 1e-18 * (-1.0) ** np.arange(12)}
    fig = plt.figure(figsize=(15, 5))
    plots._shape_axes(fig, {"cable": table}, clamped_b=False)
    plots._declutter_3d(fig)
    assert plots.legibility_problems(fig) == []
    ax3 = fig.axes[0]
    assert np.all(ax3.get_lines()[0].get_data_3d()[2] == 0.0)
    assert np.all(fig.axes[1].get_lines()[0].get_ydata() == 0.0)        # the y-z side view too
    plt.close(fig)


def test_spectrum_range_follows_the_data():
    """Three times the highest significant peak, at most the Nyquist limit (it was 0-200 Hz)."""
    import numpy as np
    from pydriver.signal import spectrum
    t = np.arange(0, 1, 1e-3)
    f, a = spectrum(t, np.sin(2 * np.pi * 26.3 * t) + 0.01 * np.sin(2 * np.pi * 150 * t))
    assert 75 < plots.spectrum_range(f, a) < 82                          # the 1 % peak is not significant
    f, a = spectrum(t, np.sin(2 * np.pi * 26.3 * t) + 0.5 * np.sin(2 * np.pi * 310 * t))
    assert plots.spectrum_range(f, a) == pytest.approx(500.0)            # 3 x 310 Hz > Nyquist
    f, a = spectrum(t, np.sin(2 * np.pi * 240 * t))
    assert 700 > plots.spectrum_range(f, a) > 240


def test_distinct_styles_do_not_repeat():
    styles = [plots.distinct_style(k) for k in range(40)]
    assert len(set(styles)) == 40


@pytest.mark.parametrize("deck", ["uh60_part2", "six_link_dynamic", "uh60_part2_forward_flight_cable",
                                  "uh60_part2_campbell_soft", "uh60_part2_decay", "cantilever_check"])
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
    assert re.search(r"largest bending moment \[Nm\]\s+\d+\.\d+ \+- ", text)   # a value with its error bar
    # Issue 37: the words of the field, not the stored names (fd1, peak ..., 0 deg around).
    assert "damped frequency of mode 1 [Hz]" in text and not re.search(r"\bfd\d|deg around", text)
    assert "fatigue hotspot 1" in text and str(out) in text
    assert not re.search(r"\d\.\d{12,}", text)                              # no 17-digit dumps


def test_report_html_is_self_contained(flight_report):
    """One file: inputs, the converged numbers, the fatigue table and the figures embedded."""
    _, out = flight_report
    html = (out / "report.html").read_text()
    assert "<h2>Fatigue hotspots</h2>" in html and "Richardson" in html
    # The flight run's figures, and the shape of the mode within the resonance margin (issue 21).
    assert html.count("data:image/png;base64,") == 4
    captions = re.findall(r"<figcaption>(.*?)</figcaption>", html)
    assert len(captions) == 4 and not any(".png" in c for c in captions)      # what it shows, not a file name
    assert any("Mode 1, within the resonance margin" in c for c in captions)
    assert "<h2>Resonance margins</h2>" in html and "WITHIN MARGIN" in html
    assert not re.search(r"""(src|href)=["']?(https?:|file:|/)""", html)    # nothing fetched from elsewhere
    assert "ei" in html and "1.906" in html                                 # the inputs


def test_one_number_for_one_quantity(flight_report):
    """Issue 36: every headline number of the main job (refined) is the same in the terminal
    summary, summary.json and report.html: the converged value with its error bar, printed by one
    function (pydriver.verdicts.headline_text) from summary['headline']; the finest level's value,
    where shown, is labelled with its n."""
    import json
    from pydriver.verdicts import headline_text
    text, out = flight_report
    s = json.loads((out / "summary.json").read_text())
    page = (out / "report.html").read_text()
    life = s["headline"]["fatigue life [h], shortest"]
    assert life["basis"].startswith("Richardson over n = 11, 22, 44")
    shown = headline_text(life)
    assert shown in text and shown.replace("+-", "+-") in page.replace("&#x27;", "'")
    # The limits judge that same value (not the finest level's 17 h).
    row = next(r for r in s["limits"] if r["unit"] == "h")
    assert row["value"] == life["value"] and row["error_estimate"] == life["error_estimate"]
    # The hotspots give the finest level's lives, labelled as such.
    assert re.search(r"fatigue hotspot 1: .*life [\d.]+ h at n = 44", text)
    for name, entry in s["headline"].items():
        assert headline_text(entry) in text or name.startswith(("F_", "M_")), name
        assert html.escape(headline_text(entry)) in page or name.startswith(("F_", "M_")), name


def test_report_explains_itself(flight_report):
    """Issue 22: a glossary of every abbreviation used, numbers that do not wrap, the job's
    time, and the values the deck's limits would judge shown as not judged."""
    import json
    _, out = flight_report
    page = (out / "report.html").read_text()
    glossary = page[page.index("<h2 id='glossary'>"):]
    for used in ("MB_z max |.|", "DEL FA_x", "worst point of the jacket at 0 deg from the body",
                 "repeated once per rotor revolution"):
        assert used in page
    # Issue 37: the hotspots and the DEL are said in words, not as "0 deg around", "1/rev-equivalent".
    body = page[:page.index("<h2 id='glossary'>")]
    assert "deg around" not in body and "-equivalent" not in body.replace("damage-equivalent", "")
    for term in ("max |.|", "DEL (damage-equivalent load)", "worst point of the jacket at N deg",
                 "repeated once per rotor revolution", "k/rev (1/rev", "f1, f2"):
        assert f"<dt>{term}" in glossary, term
    # Every numeric cell is a no-wrap cell: "8.9937e-" / "04" was split over two lines.
    results = page[:page.index("<h2>Inputs</h2>")]                  # the deck's values are lists, as typed
    cells = re.findall(r"<td( class=\"\w+\")?>(-?\d+\.[\d.e+-]*)</td>", results)
    assert cells and all(cls == ' class="n"' for cls, _ in cells)
    assert "td.n { white-space: nowrap;" in page
    s = json.loads((out / "summary.json").read_text())
    assert f"computed in {s['wall_time_s']:.2f} s (the whole job; refinement levels n = 11: " in page
    assert "<h2 id='verdicts'>Verdicts</h2>" in page and "not judged (no &amp;limits jacket_strain)" in page


def test_limits_are_flagged(tmp_path):
    """&limits jacket_strain and fatigue_life_hours: the flight's 5 % strain and 17 h life are
    flagged in the summary, the terminal and report.html."""
    deck = tmp_path / "limits.nml"
    text = (INPUTS / "uh60_part2_forward_flight_cable.nml").read_text()
    text = re.sub(r"(?ims)^&refinement\b.*?^\s*/", "", text)           # one level: the check, not convergence
    deck.write_text(text + "\n&limits\n  jacket_strain = 0.02\n  fatigue_life_hours = 1000\n/\n")
    cmd = [sys.executable, "-m", "pydriver", "run", str(deck), "--out", str(tmp_path / "o"), "--report"]
    done = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT)
    assert done.returncode == 0, done.stderr
    assert re.search(r"limit at most 0\.0200 \(2\.00 %\)\s+\[NOT MET\]", done.stdout), done.stdout
    assert re.search(r"limit at least 1000 h\s+\[NOT MET\]", done.stdout), done.stdout
    page = (tmp_path / "o" / "report.html").read_text()
    assert page.count('<td class="flag">NOT MET</td>') == 2
    import json
    rows = json.loads((tmp_path / "o" / "summary.json").read_text())["limits"]
    assert [r["exceeded"] for r in rows] == [True, True]


@pytest.mark.parametrize("key,value,words", [
    ("jacket_strain", "1e300", "[1e-06, 1]"), ("jacket_strain", "1e-320", "[1e-06, 1]"),
    ("jacket_strain", "-0.02", "[1e-06, 1]"), ("jacket_strain", "0.01, 0.02", "one value"),
    ("fatigue_life_hours", "1e300", "[0.001, 1e+09]"), ("fatigue_life_hours", "1e-320", "[0.001, 1e+09]"),
    ("fatigue_life_hours", "-5", "[0.001, 1e+09]"),
    ("fatigue_life_hours", "100, 200", "one value"), ("fatigue_life_hours", "'long'", "")])
def test_limit_keys_are_checked(tmp_path, key, value, words):
    """The new keys' fuzz cases: huge, tiny (a denormal), reversed sign, wrong count, wrong type."""
    deck = tmp_path / "bad.nml"
    deck.write_text((INPUTS / "uh60_part2_forward_flight_cable.nml").read_text()
                    + f"\n&limits\n  {key} = {value}\n/\n")
    with pytest.raises(pydriver.DeckError) as exc:
        pydriver.run_deck(deck)
    assert (exc.value.group, exc.value.key) == ("limits", key) and words in str(exc.value)


def test_a_life_limit_needs_fatigue(tmp_path):
    deck = tmp_path / "bad.nml"
    deck.write_text((INPUTS / "six_link_static.nml").read_text() + "\n&limits\n  fatigue_life_hours = 100\n/\n")
    with pytest.raises(pydriver.DeckError, match="needs &fatigue"):
        pydriver.run_deck(deck)


@pytest.mark.parametrize("name,words", [
    ("fd1 [Hz]", "damped frequency of mode 1 [Hz]"), ("f12 [Hz]", "undamped frequency of mode 12 [Hz]"),
    ("peak strain [-]", "largest jacket strain [-]"), ("peak axial [N]", "largest axial force [N]"),
    ("FA_x max |.|", "largest |FA_x| [N]"), ("MB_z max |.|", "largest |MB_z| [Nm]"),
    ("DEL strain, worst joint", "damage-equivalent strain amplitude, worst joint [-]"),
    ("DEL bending, worst joint", "damage-equivalent bending amplitude, worst joint [Nm]"),
    ("DEL FB_y", "damage-equivalent amplitude of FB_y [N]"), ("fatigue life [h], shortest", "shortest fatigue life [h]"),
    ("F_A x [N]", "force of support A on the cable, x [N]"), ("tip z [m]", "free tip, z [m]")])
def test_refined_quantities_in_words(name, words):
    """Issue 37: the summary names a refined quantity in words (the stored names stay in
    refinement.csv and summary.json, which readers key on)."""
    from pydriver.report_text import quantity_label
    assert quantity_label(name) == words


def test_the_report_opens_with_the_verdicts_and_a_playing_animation(flight_report, tmp_path):
    """Issue 37, as a reader's browser draws the main job's report (headless chromium, 1280 px):
    the verdicts lie wholly on the first screen (1000 px high), and the animation plays by itself:
    two screenshots 0.4 s and 2.5 s after loading differ, and only inside the animation (its canvas
    and its controls: the slider and the frame's label move with it)."""
    import matplotlib.image
    from browser import layout, screenshot
    _, out = flight_report
    page = out / "report.html"
    box = layout(page, tmp_path, {"verdicts": "table.verdicts", "canvas": "#cable-canvas",
                                  "widget": "div:has(> #cable-canvas)"})
    assert box["verdicts"] is not None and box["verdicts"][3] <= 1000.0, box
    height = int(box["widget"][3]) + 40                      # the whole animation in view
    early = matplotlib.image.imread(screenshot(page, tmp_path / "early.png", height=height, after_ms=400))
    late = matplotlib.image.imread(screenshot(page, tmp_path / "late.png", height=height, after_ms=2500))
    changed = np.any(np.abs(early[..., :3] - late[..., :3]) > 0.02, axis=2)
    rows, cols = np.nonzero(changed)
    assert rows.size > 500, "the animation did not move"
    left, top, right, bottom = box["canvas"]
    in_canvas = (cols >= left - 1) & (cols <= right + 1) & (rows >= top - 1) & (rows <= bottom + 1)
    assert np.count_nonzero(in_canvas) > 500, "the cable did not move"
    left, top, right, bottom = box["widget"]
    inside = (cols >= left - 1) & (cols <= right + 1) & (rows >= top - 1) & (rows <= bottom + 1)
    assert inside.all(), f"{np.count_nonzero(~inside)} pixels changed outside the animation"
