"""Studies run from any working directory and write where --out says (issue 13, item 5)."""

from __future__ import annotations

import subprocess
import sys


def test_study_runs_outside_the_repository(tmp_path):
    elsewhere = tmp_path / "somewhere"
    elsewhere.mkdir()
    done = subprocess.run([sys.executable, "-m", "pydriver", "study", "shapes", "--out", "figs"],
                          capture_output=True, text=True, cwd=elsewhere)
    assert done.returncode == 0, done.stderr
    assert sorted(p.name for p in (elsewhere / "figs").iterdir()) == [
        "uh60_part1_rest_vs_hover.png", "uh60_part2_rest_vs_hover.png"]
