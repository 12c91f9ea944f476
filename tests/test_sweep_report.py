"""A sweep's report.html (issue 13: every run or sweep can write one) and legible sweep plots."""

from __future__ import annotations

import re
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
