"""A sweep's report.html (issue 13: every run or sweep can write one) and legible sweep plots."""

from __future__ import annotations

import re
import shutil
import subprocess
import sys

import matplotlib

matplotlib.use("Agg")

from matplotlib.figure import Figure     # noqa: E402

from conftest import INPUTS, ROOT        # noqa: E402
from pydriver import plots               # noqa: E402
from pydriver.sweep import collect       # noqa: E402


def test_sweep_report_and_legible_plots(tmp_path, monkeypatch):
    out = tmp_path / "sweep"
    cmd = [sys.executable, "-m", "pydriver", "sweep", str(INPUTS / "uh60_part2_modal.nml"),
           "--set", "springs.c_beta=20,35.531,50", "--out", str(out), "--quiet", "--no-plots", "--jobs", "1"]
    done = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT)
    assert done.returncode == 0, done.stderr
    # Plots and the report drawn here, in-process, so that every figure is checked as saved.
    problems = {}
    save = Figure.savefig

    def checked(fig, *args, **kw):
        problems[len(problems)] = plots.legibility_problems(fig)
        return save(fig, *args, **kw)

    monkeypatch.setattr(Figure, "savefig", checked)
    status = collect(out, plots=True, report=True)
    assert status.ok and problems and not any(problems.values()), problems
    page = (out / "report.html").read_text()
    for id_, c in (("0000", "20"), ("0001", "35.531"), ("0002", "50")):
        assert re.search(rf"<td class=\"l\">{id_}</td><td class=\"l\">{c}</td>", page)
    assert page.count("data:image/png;base64,") == len(list((out / "plots").glob("*.png"))) > 0
    assert not re.search(r"""(src|href)=["']?(https?:|file:|/)""", page)
    captions = re.findall(r"<figcaption>(.*?)</figcaption>", page)
    assert captions and not any(".png" in c for c in captions)
    assert "<b>Figure 1.</b> FA_x [N] of every finished point against springs.c_beta [Nm/rad]" in page
    assert "<h2 id='glossary'>" in page and "<dt>F_A, M_A, F_B, M_B; FA_x ... MB_z</dt>" in page
    wide = tables_wider_than_the_page(out / "report.html", tmp_path)
    if wide is not None:
        assert wide == [], f"tables cut at the right edge at 1280 px: {wide}"


def tables_wider_than_the_page(page, tmp_path, width: int = 1280):
    """The widths of the tables that do not fit their column at ``width`` px in headless
    chromium (issue 22: the sweep's table was cut at the right edge), or None without chromium."""
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    if chromium is None:
        return None
    probe = tmp_path / "probe.html"
    script = ("<script>window.addEventListener('load', () => { const wide = [];"
              "document.querySelectorAll('table').forEach(t => { const box = t.parentElement;"
              "if (t.getBoundingClientRect().right > document.body.getBoundingClientRect().right + 1 ||"
              " box.scrollWidth > box.clientWidth + 1) wide.push(Math.round(t.getBoundingClientRect().width)); });"
              "document.body.setAttribute('data-wide', JSON.stringify(wide)); });</script>")
    probe.write_text(page.read_text().replace("</body>", script + "</body>"))
    done = subprocess.run([chromium, "--headless", "--no-sandbox", "--disable-gpu", f"--window-size={width},2000",
                           "--virtual-time-budget=5000", "--dump-dom", probe.as_uri()],
                          capture_output=True, text=True, timeout=120)
    m = re.search(r'data-wide="([^"]*)"', done.stdout)
    assert m, done.stderr[-2000:]
    import json
    return json.loads(m.group(1).replace("&quot;", '"'))
