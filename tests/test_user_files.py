"""No command deletes or overwrites a file it did not write (issue 35, "A user's files").

One check over every command that writes (``run`` plain, with ``--plots --report``, ``--vtk``
and ``--restart``; every ``study``; ``sweep`` with ``--report`` and with ``--slurm``;
``sweep-task``; ``sweep-collect``; ``spectrum`` with ``--report`` and with ``--slurm``;
``examples``; ``init``), each sent to every kind of place a user may name as its output ``o``:

* ``new``: ``o`` does not exist;
* ``users_files``: ``o`` holds a user's files (one named like the deck ``init`` writes), a
  subdirectory, a link to a directory, a link and a dangling link named like example decks, and
  a crafted marker listing ``../victim.txt``, an absolute path and paths through the link;
* ``earlier``: ``o`` holds one earlier output of the same command, its marker edited to list
  those paths too;
* ``earlier_plus_note``: the same with a user's note put in it;
* ``other_kind``: ``o`` holds an output of another kind (a sweep for runs, a run otherwise);
* ``link``: ``o`` is a symbolic link to a user's directory.

Around ``o``, always, the user's tree: files, a subdirectory, a link, look-alike temporaries
``.o.tmp-<deadpid>-mine/`` and ``.o.old-<deadpid>/`` without a marker, temporaries whose marker
names another output or another process, and a crafted ``.o.old-<deadpid>/`` whose marker names
``o`` and lists ``../victim.txt``, an absolute path and a path through a link.

Every path of the tree is recorded before and after (a file by the SHA-256 of its bytes, a link
by its target, a directory as one).  The command either refuses (exit status not 0, a message
naming what is there, no traceback, nothing added, removed or changed anywhere) or succeeds, and
then every path the user made is still there, unchanged, and anything new is inside ``o``.
Which of the two is fixed per place (the table ``EXPECTED``, with the few exceptions a command's
own contract makes), so a command that refused everything would fail here too.

The commands run in this process through ``pydriver.__main__.main``: an exception escaping it
is the traceback a user would see, and fails the test.  The design study computes for about two
minutes, so it is exercised only where it must refuse (its directory check runs before any
computation); the other studies take a second or two.
"""

from __future__ import annotations

import hashlib
import json
import os
import socket
import subprocess
from dataclasses import dataclass, field
from pathlib import Path

import pytest
from conftest import INPUTS

import pydriver.__main__ as cli
from pydriver.ownership import MARKER, TMP_MARKER
from pydriver.study import override_deck

STATIC = INPUTS / "six_link_static.nml"
MODAL = INPUTS / "uh60_part2_modal.nml"
SWEEP_SET = ["--set", "springs.c_beta=20,35.531"]

SITUATIONS = ["new", "users_files", "earlier", "earlier_plus_note", "other_kind", "link"]
#: What every command must do in each place (Command.expect overrides it).
EXPECTED = {"new": "writes", "users_files": "refuses", "earlier": "writes",
            "earlier_plus_note": "refuses", "other_kind": "refuses", "link": "refuses"}


def dead_pid() -> int:
    """A process id no process has: above the kernel's largest."""
    try:
        return int(Path("/proc/sys/kernel/pid_max").read_text()) + 1
    except OSError:
        return 2 ** 22 + 1


DEAD = dead_pid()


@dataclass
class Command:
    """One command line that writes; ``{o}`` in an argument is the output's path."""

    name: str
    args: list
    kind: str                                   # of its output: run, sweep, study, examples, init
    setup: list | None = None                   # what makes an earlier output (default: args)
    expect: dict = field(default_factory=dict)  # overrides of EXPECTED
    computes: bool = True                       # False: only its refusals are exercised (slow)

    def argv(self, o: Path, args=None) -> list[str]:
        return [str(a).replace("{o}", str(o)) for a in (args or self.args)]

    def expected(self, situation: str) -> str:
        return self.expect.get(situation, EXPECTED[situation])


@pytest.fixture(scope="module")
def decks(tmp_path_factory):
    """A short dynamic deck, a longer one, and a finished run of the short one to restart."""
    d = tmp_path_factory.mktemp("decks")
    short = override_deck(INPUTS / "six_link_dynamic.nml", d / "short.nml",
                          {"solver": {"t_end": "0.05", "dt_out": "1.0e-3"}})
    longer = override_deck(short, d / "longer.nml", {"solver": {"t_end": "0.1"}})
    assert run(["run", str(short), "--out", str(d / "first"), "-q"])[0] == 0
    spectrum = d / "spectrum.nml"                    # one regime of a 4-body cable: a second's work
    spectrum.write_text("""&case analysis = 'spectrum' /
&chain n_bodies = 4, total_length = 0.6, diameter = 0.015, joint = 'xy', first_body = 'clamped' /
&clamp_a beta_deg = 90.0 /
&shape gamma_deg = 4*0.0, beta_deg = 0.0, 3*40.0 /
&cable ei = 1.0, mass_per_length = 0.5, damping_time = 1.0e-3 /
&rotor rpm = 120.0, centre = 0.0, -0.5, 0.0 /
&clamp_b active = .true., from_start = .true., moves_with = 'blade' /
&blade flap_hinge = 0.0, -0.3, 0.0, flap_deg = 2.0, 0.3, 0.1 /
&fatigue sn_exponent = 5.0, sn_reference_amplitude = 1.0e-3, sn_reference_cycles = 1.0e6 /
&solver samples_per_rev = 16, periodic_tol = 1.0e-4, rtol = 1.0e-6, atol = 1.0e-8 /
&spectrum regimes = 'only', share = 1.0, flights_per_hour = 0.0 /
""")
    return {"short": short, "longer": longer, "first": d / "first", "spectrum": spectrum}


def commands(decks) -> list[Command]:
    init_new = {"earlier": "refuses", "other_kind": "writes", "link": "writes"}
    examples_merge = {"users_files": "writes", "earlier_plus_note": "writes", "other_kind": "writes",
                      "link": "writes"}
    sweep_dir = ["sweep", MODAL, *SWEEP_SET, "--out", "{o}", "--jobs", "1", "--quiet", "--no-plots"]
    cmds = [
        Command("run", ["run", STATIC, "--out", "{o}", "-q"], "run"),
        Command("run --plots --report", ["run", STATIC, "--out", "{o}", "--plots", "--report", "-q"], "run"),
        Command("run --vtk", ["run", decks["short"], "--out", "{o}", "--vtk", "-q"], "run"),
        Command("run --restart", ["run", decks["longer"], "--restart", decks["first"], "--out", "{o}", "-q"], "run"),
        Command("sweep --report", ["sweep", MODAL, *SWEEP_SET, "--out", "{o}", "--jobs", "1", "--quiet",
                                   "--report"], "sweep"),
        Command("sweep --slurm", ["sweep", MODAL, *SWEEP_SET, "--out", "{o}", "--slurm"], "sweep"),
        Command("sweep-task", ["sweep-task", "{o}", "1"], "sweep",
                setup=["sweep", MODAL, *SWEEP_SET, "--out", "{o}", "--slurm"], expect={"new": "refuses"}),
        Command("sweep-collect", ["sweep-collect", "{o}", "--report"], "sweep", setup=sweep_dir,
                expect={"new": "refuses"}),
        Command("spectrum --report", ["spectrum", decks["spectrum"], "--out", "{o}", "--jobs", "1", "--report"],
                "sweep"),
        Command("spectrum --slurm", ["spectrum", decks["spectrum"], "--out", "{o}", "--slurm"], "sweep"),
        Command("examples", ["examples", "{o}"], "examples", expect=examples_merge),
        Command("init", ["init", "{o}/mine.nml", "--like", "six_link_static"], "init", expect=init_new),
    ]
    for study in ("shapes", "cy-sweep", "refine"):
        cmds.append(Command(f"study {study}", ["study", study, "--out", "{o}"], "study"))
    cmds.append(Command("study design", ["study", "design", "--out", "{o}"], "study", computes=False,
                        setup=["study", "refine", "--out", "{o}"]))
    return cmds


COMMAND_NAMES = ["run", "run --plots --report", "run --vtk", "run --restart", "sweep --report",
                 "sweep --slurm", "sweep-task", "sweep-collect", "spectrum --report", "spectrum --slurm", "examples",
                 "init", "study shapes", "study cy-sweep", "study refine", "study design"]


def run(argv) -> tuple[int, str]:
    """The command's exit status and what it wrote to stderr (an exception escapes: a traceback)."""
    import contextlib
    import io
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        try:
            status = cli.main([str(a) for a in argv])
        except SystemExit as exc:             # argparse, or a command ending on purpose
            status = exc.code if isinstance(exc.code, int) else 1
    return status, err.getvalue()


def snapshot(root: Path) -> dict:
    """Every path below ``root``: ('file', sha256), ('link', target) or ('dir',)."""
    seen = {}
    for here, dirs, files in os.walk(root):            # does not follow links
        for name in dirs + files:
            p = Path(here) / name
            rel = str(p.relative_to(root))
            if p.is_symlink():
                seen[rel] = ("link", os.readlink(p))
            elif p.is_dir():
                seen[rel] = ("dir",)
            else:
                seen[rel] = ("file", hashlib.sha256(p.read_bytes()).hexdigest())
    return seen


def crafted_files(ws: Path, link: str) -> list[str]:
    """Names a crafted marker lists: outside, absolute, through a link."""
    return ["../victim.txt", str(ws / "victim.txt"), f"{link}/thesis.tex", link, "sub/data.bin"]


def users_tree(ws: Path) -> None:
    """The user's tree around the output ``ws/o``."""
    (ws / "notes" / "sub").mkdir(parents=True)
    (ws / "victim.txt").write_text("the user's file beside the output\n")
    (ws / "notes" / "thesis.tex").write_text("\\documentclass{article}\n")
    (ws / "notes" / "sub" / "data.bin").write_bytes(bytes(range(256)))
    (ws / "link_to_notes").symlink_to("notes")
    host = socket.gethostname()
    # Look-alike temporaries of o: no marker, or a marker naming another output or process.
    for name in (f".o.tmp-{DEAD}-mine", f".o.old-{DEAD}", f".o.tmp-{DEAD}-other", f".o.tmp-{DEAD}-pid"):
        (ws / name).mkdir()
        (ws / name / "keep.txt").write_text(f"the user's {name}\n")
    (ws / f".o.tmp-{DEAD}-other" / TMP_MARKER).write_text(json.dumps(
        {"program": "rotorcable", "pid": DEAD, "host": host, "out": str(ws.resolve() / "other")}))
    (ws / f".o.tmp-{DEAD}-pid" / TMP_MARKER).write_text(json.dumps(
        {"program": "rotorcable", "pid": DEAD + 1, "host": host, "out": str(ws.resolve() / "o")}))
    # A moved-aside output of o with a crafted marker: nothing it lists is a file directly in it.
    crafted = ws / f".o.old-{DEAD + 2}"
    crafted.mkdir()
    (crafted / "lnk").symlink_to("../notes")
    (crafted / MARKER).write_text(json.dumps({"program": "rotorcable", "kind": "run", "out": str(ws.resolve() / "o"),
                                              "files": crafted_files(ws, "lnk")}))


def users_directory(o: Path, ws: Path) -> None:
    """``o`` as a user's directory with a crafted marker."""
    (o / "sub").mkdir(parents=True)
    (o / "thesis.tex").write_text("\\documentclass{book}\n")
    (o / "mine.nml").write_text("&case name = 'mine' /\n")
    (o / "sub" / "data.bin").write_bytes(b"\x00\x01")
    (o / "lnk").symlink_to("../notes")
    (o / "six_link_static.nml").symlink_to("../victim.txt")      # where examples would write
    (o / "three_body.nml").symlink_to("../created_through_a_link.txt")
    (o / MARKER).write_text(json.dumps({"program": "rotorcable", "files": crafted_files(ws, "lnk")}))


def tamper(o: Path, ws: Path) -> None:
    """An earlier output's marker, edited to list the user's files outside it."""
    marker = o / MARKER
    if marker.is_file():
        data = json.loads(marker.read_text())
        data["files"] += crafted_files(ws, "lnk")
        marker.write_text(json.dumps(data))


def names_in(o: Path) -> list[str]:
    try:
        return [p.name for p in o.iterdir()] if o.is_dir() and not o.is_symlink() else []
    except OSError:
        return []


class TestNoCommandTouchesAUsersFile:
    """Every command that writes, in every place a user may send it (module doc)."""

    @pytest.fixture(params=COMMAND_NAMES)
    def command(self, request, decks):
        return next(c for c in commands(decks) if c.name == request.param)

    @pytest.mark.parametrize("situation", SITUATIONS)
    def test_refuses_or_leaves_every_users_file(self, command, situation, tmp_path, monkeypatch):
        monkeypatch.setattr(cli, "_exit_on_termination", lambda: None)     # no signal handlers in pytest
        expected = command.expected(situation)
        if expected == "writes" and not command.computes:
            pytest.skip(f"{command.name} computes for minutes; its refusals are checked")
        ws = tmp_path / "ws"
        ws.mkdir()
        o = ws / "o"
        ours: set[str] = set()                 # paths the program wrote itself (may be replaced)
        if situation in ("earlier", "earlier_plus_note"):
            status, err = run(command.argv(o, command.setup))
            assert status == 0, err
            ours = {f"o/{rel}" for rel in snapshot(o)} | {"o"}
            tamper(o, ws)
            if situation == "earlier_plus_note":
                (o / "notes.txt").write_text("my remarks on this output\n")
        elif situation == "other_kind":
            other = (["sweep", MODAL, *SWEEP_SET, "--out", o, "--slurm"] if command.kind == "run"
                     else ["run", STATIC, "--out", o, "-q"])
            assert run(other)[0] == 0
        users_tree(ws)
        if situation == "users_files":
            users_directory(o, ws)
        elif situation == "link":
            o.symlink_to("notes")
        before = snapshot(ws)
        there = names_in(o)

        status, err = run(command.argv(o))

        after = snapshot(ws)
        assert "Traceback" not in err
        if expected == "refuses":
            assert status != 0 and "error" in err, (command.name, situation, status, err)
            # The message names what is there: an entry of o, or why o is not a place to write.
            assert any(name in err for name in there) or any(
                words in err for words in ("symbolic link", "not a sweep directory")), err
            assert after == before, (command.name, situation)
            return
        assert status == 0, (command.name, situation, err)
        for rel, what in before.items():
            if rel in ours or rel == f"o/{MARKER}":
                continue                         # the program's own earlier output
            assert after.get(rel) == what, (command.name, situation, rel)
        inside = ("o/", "notes/") if situation == "link" else ("o/",)
        new = [rel for rel in set(after) - set(before) if rel != "o" and not rel.startswith(inside)]
        assert not new, (command.name, situation, new)       # nothing written outside o


def test_a_crafted_marker_lists_no_file_outside_its_directory(tmp_path):
    """The marker's names are input: refused unless relative, normalised, inside and (but for a
    sweep's) directly in the directory; only regular files reached through no link count."""
    from pydriver.ownership import read_marker, remove_output
    d = tmp_path / "d"
    (d / "sub").mkdir(parents=True)
    (tmp_path / "victim.txt").write_text("v")
    (d / "lnk").symlink_to(tmp_path)
    (d / "a.txt").write_text("a")
    (d / "sub" / "b.txt").write_text("b")
    listed = ["../victim.txt", str(tmp_path / "victim.txt"), "lnk/victim.txt", "lnk", "./a.txt", "a.txt",
              "sub/b.txt", "sub/../a.txt", "", None, 7, "a.txt/", "sub//b.txt"]
    (d / MARKER).write_text(json.dumps({"program": "rotorcable", "kind": "run", "files": listed}))
    assert read_marker(d).files == {"a.txt", "lnk"}
    assert not remove_output(d, "run")       # a.txt goes; the link, the subdirectory and the marker stay
    assert sorted(p.name for p in d.iterdir()) == [MARKER, "lnk", "sub"]
    assert (tmp_path / "victim.txt").read_text() == "v" and (d / "sub" / "b.txt").read_text() == "b"
    # A sweep's marker may list its subdirectories' files, never outside them.
    (d / MARKER).write_text(json.dumps({"program": "rotorcable", "kind": "sweep", "files": listed}))
    assert read_marker(d).files == {"a.txt", "lnk", "sub/b.txt", "lnk/victim.txt"}


def test_only_verified_temporaries_of_gone_processes_are_removed(tmp_path, monkeypatch):
    """A killed run's temporary goes (its marker names it, its process and host); the look-alikes
    of users_tree stay."""
    import sys
    import time
    monkeypatch.setattr(cli, "_exit_on_termination", lambda: None)
    out = tmp_path / "killed"
    deck = override_deck(INPUTS / "six_link_dynamic.nml", tmp_path / "long.nml",
                         {"solver": {"t_end": "2000.0", "dt_out": "1.0e-3"}})
    proc = subprocess.Popen([sys.executable, "-m", "pydriver", "run", str(deck), "--out", str(out)],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 120              # seconds normally; only bounds a hang
    while not list(tmp_path.glob(".killed.tmp-*/timeseries.*")):
        assert time.monotonic() < deadline and proc.poll() is None, "the run did not start writing"
        time.sleep(0.02)
    proc.kill()
    proc.wait()
    (tmp, ) = tmp_path.glob(".killed.tmp-*")
    marker = json.loads((tmp / TMP_MARKER).read_text())
    assert marker["pid"] == proc.pid and marker["out"] == str(out.resolve())
    users_tree(tmp_path / "ws")
    before = snapshot(tmp_path / "ws")
    assert run(["run", STATIC, "--out", tmp_path / "ws" / "other", "-q"])[0] == 0
    assert run(["run", STATIC, "--out", tmp_path / "other", "-q"])[0] == 0
    assert not tmp.exists()                                      # verified, its process gone
    after = snapshot(tmp_path / "ws")
    assert {k: v for k, v in after.items() if not k.startswith("other")} == before


def test_a_sweep_removes_only_what_its_killed_tasks_left(tmp_path):
    """In runs/, a resume removes a verified temporary and the records being made of gone
    processes (their own files only); --retry-failed removes a failed record's listed files.
    A user's file in any of them stays, and one in a record stops the sweep, naming it."""
    from pydriver.sweep import SweepError, prepare, run_point, run_sweep
    grid = ["springs.c_beta=35.531,-1"]                    # point 0001 fails: a negative spring
    out = tmp_path / "sweep"
    prepare(MODAL, grid, out)
    assert run_point(out, 0)["error"] is None and run_point(out, 1)["error"].startswith("DeckError")
    runs = out / "runs"
    empty = runs / f".0000.{DEAD}.0123456789abcdef"        # a task killed before its run finished
    empty.mkdir()
    users = runs / f".0001.{DEAD}.fedcba9876543210"        # the same name with a user's file in it
    users.mkdir()
    (users / "keep.txt").write_text("mine")
    temporary = runs / f"..0000.{DEAD}.0123456789abcdef.tmp-{DEAD}-abc"
    temporary.mkdir()
    (temporary / TMP_MARKER).write_text(json.dumps({"program": "rotorcable", "pid": DEAD, "host": socket.gethostname(),
                                                    "out": str(runs.resolve() / empty.name)}))
    (temporary / "timeseries.csv").write_text("t\n")
    look_alike = runs / f".other.tmp-{DEAD}-x"               # no marker: never removed
    look_alike.mkdir()
    (look_alike / "keep.txt").write_text("mine")
    before = (out / "runs" / "0001" / "error.json").read_text()
    status = run_sweep(MODAL, grid, out, jobs=1, progress=False, plots=False, retry_failed=True)
    assert status.ran == ["0001"] and status.failed == ["0001"]
    assert not empty.exists() and not temporary.exists()
    assert (users / "keep.txt").read_text() == "mine" and (look_alike / "keep.txt").read_text() == "mine"
    assert (out / "runs" / "0001" / "error.json").read_text() == before        # made again, the same
    # A user's note in a record: the sweep's directory is no longer only the sweep's.
    (out / "runs" / "0001" / "note.txt").write_text("why did this fail?")
    with pytest.raises(SweepError, match="runs/0001/"):
        run_sweep(MODAL, grid, out, jobs=1, progress=False, plots=False, retry_failed=True)
    assert (out / "runs" / "0001" / "note.txt").read_text() == "why did this fail?"
    assert (out / "runs" / "0001" / "error.json").read_text() == before
