"""Studies run from any working directory and write where --out says (issue 13, item 5), as one
marked output of their kind (issue 35: tests/test_user_files.py has the refusals)."""

from __future__ import annotations

import json
import subprocess
import sys

from pydriver.ownership import MARKER


def test_study_runs_outside_the_repository(tmp_path):
    elsewhere = tmp_path / "somewhere"
    elsewhere.mkdir()
    done = subprocess.run([sys.executable, "-m", "pydriver", "study", "shapes", "--out", "figs"],
                          capture_output=True, text=True, cwd=elsewhere)
    assert done.returncode == 0, done.stderr
    figures = ["uh60_part1_rest_vs_hover.png", "uh60_part2_rest_vs_hover.png"]
    assert sorted(p.name for p in (elsewhere / "figs").iterdir()) == [MARKER, *figures]
    marker = json.loads((elsewhere / "figs" / MARKER).read_text())
    assert marker["kind"] == "study shapes" and marker["files"] == figures
    # Without --out: results/studies/<name>, so that two studies do not share a directory.
    done = subprocess.run([sys.executable, "-m", "pydriver", "study", "shapes"],
                          capture_output=True, text=True, cwd=elsewhere)
    assert done.returncode == 0, done.stderr
    assert (elsewhere / "results" / "studies" / "shapes" / figures[0]).is_file()
