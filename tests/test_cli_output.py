"""What the command line prints (issue 35): ``--json | head`` ends quietly, ``-q`` prints nothing.

* A reader that goes away (``rotorcable run DECK --json | head -c 10``) ended the command in a
  BrokenPipeError traceback; now the command stops as a Unix tool ended by SIGPIPE does: no
  message, status 141 (128 + SIGPIPE), its files written.
* ``-q`` printed the summary although the README says it prints nothing; now it prints nothing
  but errors, and with ``--json`` the JSON alone.

The runs are subprocesses, as a shell runs them.
"""

from __future__ import annotations

import json
import subprocess
import sys

from conftest import ROOT

#: A Campbell diagram of 2000 speeds: its summary.json (240 kB with --json's indent) is larger
#: than a pipe's buffer (64 kB on Linux), so the reader's going away is seen by the writer
#: whatever the timing.
BIG = """&case analysis = 'campbell' /
&chain n_bodies = 3, total_length = 0.6, diameter = 0.015, total_mass = 0.3, joint = 'xy', first_body = 'clamped' /
&clamp_a beta_deg = 90.0 /
&shape gamma_deg = 3*0.0, beta_deg = 0.0, 2*20.0 /
&springs c_beta = 10.0 /
&loads gravity = 0.0, 0.0, -9.81 /
&rotor rpm = 300.0, centre = 0.0, -0.5, 0.0 /
&campbell n_speeds = 2000, n_modes = 4 /
"""
COMMAND = [sys.executable, "-m", "pydriver", "run"]


def _deck(tmp_path, text=BIG, name="big.nml"):
    path = tmp_path / name
    path.write_text(text)
    return path


def _pipe_to_head(args, n_bytes=10):
    """``rotorcable ARGS | head -c N``: (head's output, rotorcable's stderr, rotorcable's status)."""
    writer = subprocess.Popen(COMMAND + args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, cwd=ROOT)
    head = subprocess.Popen(["head", "-c", str(n_bytes)], stdin=writer.stdout, stdout=subprocess.PIPE)
    writer.stdout.close()                     # head holds the only reading end
    out, _ = head.communicate(timeout=600)
    err = writer.stderr.read().decode()
    writer.stderr.close()
    return out, err, writer.wait(timeout=600)


def test_json_into_head_ends_quietly_with_the_files_written(tmp_path):
    out, err, status = _pipe_to_head([str(_deck(tmp_path)), "--out", str(tmp_path / "run"), "--json"])
    assert out == b'{\n "case":'
    assert err == "" and status == 141
    assert json.loads((tmp_path / "run" / "summary.json").read_text())["analysis"] == "campbell"


def test_a_reader_gone_before_anything_is_printed(tmp_path):
    """The reading end closed before the run prints (its summary or JSON): the same quiet end."""
    for flags in ((), ("--json",)):
        run = subprocess.Popen(COMMAND + [str(_deck(tmp_path, BIG.replace("2000", "5"))), "--out",
                                          str(tmp_path / f"run{len(flags)}"), *flags],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, cwd=ROOT)
        run.stdout.close()
        err = run.stderr.read().decode()
        assert run.wait(timeout=600) == 141 and err == "", err
        assert (tmp_path / f"run{len(flags)}" / "summary.json").is_file()


def test_quiet_prints_nothing(tmp_path):
    """-q: no summary, no progress; the files are written."""
    deck = _deck(tmp_path, BIG.replace("2000", "5"))
    done = subprocess.run(COMMAND + [str(deck), "--out", str(tmp_path / "q"), "-q"], capture_output=True,
                          text=True, cwd=ROOT, timeout=600)
    assert (done.returncode, done.stdout, done.stderr) == (0, "", "")
    assert (tmp_path / "q" / "summary.json").is_file()
    loud = subprocess.run(COMMAND + [str(deck), "--out", str(tmp_path / "loud")], capture_output=True, text=True,
                          cwd=ROOT, timeout=600)
    assert loud.returncode == 0 and "crossings with 1/rev" in loud.stdout     # what -q leaves out


def test_quiet_still_says_why_it_failed_and_gives_json_when_asked(tmp_path):
    bad = _deck(tmp_path, BIG.replace("n_modes = 4", "n_modes = 40"), "bad.nml")
    done = subprocess.run(COMMAND + [str(bad), "--out", str(tmp_path / "bad"), "-q"], capture_output=True,
                          text=True, cwd=ROOT, timeout=600)
    assert done.returncode == 1 and done.stdout == "" and "&campbell key 'n_modes'" in done.stderr
    deck = _deck(tmp_path, BIG.replace("2000", "5"))
    done = subprocess.run(COMMAND + [str(deck), "--out", str(tmp_path / "j"), "-q", "--json"], capture_output=True,
                          text=True, cwd=ROOT, timeout=600)
    assert done.returncode == 0 and done.stderr == ""
    assert json.loads(done.stdout) == json.loads((tmp_path / "j" / "summary.json").read_text())
