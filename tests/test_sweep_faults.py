"""Faults of the sweep found by a reliability review.

1. Paths written into ``sweep.slurm``: a newline in ``--out`` became a command of the script
   (issue 20).  Paths with control characters are refused by every sweep command before
   anything is written, and every other path is written so that bash (shell quoting) and
   sbatch (its own parsing of the ``#SBATCH`` lines) both read it back unchanged.
2. A full disk: it failed ``sweep.csv`` with a traceback, and a grid point that met it got a
   permanent failure record that no resume ran again.  Now a failure of the machine leaves the
   point without a record (reported as not run, with the reason; the next sweep runs it), and
   a file of the sweep that cannot be written is a clean SweepError naming it, with the old
   file left whole.

The disk is filled by monkeypatching (in this process), so the points that must run really
are run in-process through ``run_point``/``run_task``, or by a fake engine that calls
``run_task`` the way the pool does.  The deck is the UH-60 part 2 modal case: milliseconds.
"""

from __future__ import annotations

import errno
import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

import pydriver.__main__ as cli
import pydriver.sweep.files as files
import pydriver.sweep.records as records
import pydriver.sweep.run as sweep_run
from pydriver.errors import DeckError, RunError
from pydriver.sweep import SweepError, collect, prepare, run_point, run_task
from conftest import INPUTS

BASE = INPUTS / "uh60_part2_modal.nml"
GRID = "springs.c_beta=20,35.531"
ENOSPC_TEXT = "no space left on device"


def sweep_args(out, *extra):
    return ["sweep", str(BASE), "--set", GRID, "--out", str(out), "--quiet", "--no-plots", *extra]


def full_disk(path="") -> OSError:
    return OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))


# --- 1. Paths -----------------------------------------------------------------------------

@pytest.mark.parametrize("engine", [["--slurm"], ["--jobs", "1"], ["--dask", "tcp://127.0.0.1:9"]],
                         ids=["slurm", "local", "dask"])
def test_newline_in_out_is_refused_before_anything_is_written(tmp_path, capsys, engine):
    # Guards issue 20: `--out` with a newline wrote sweep.slurm with the text after the newline
    # as a command line.  Every engine refuses it before creating a file or directory (the Dask
    # engine before it connects: nothing listens on port 9).
    parent = tmp_path / "parent"
    parent.mkdir()
    out = parent / "sweep\ntouch INJECTED\n"
    assert cli.main(sweep_args(out, *engine)) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: --out ") and "control character ('\\n') is refused" in err, err
    assert list(parent.iterdir()) == []


def test_relative_out_in_a_directory_with_a_newline_is_refused(tmp_path, capsys, monkeypatch):
    # Guards the absolute form of --out: a relative --out takes the working directory's name,
    # which is written into the script as well.
    cwd = tmp_path / "work\ndir"
    cwd.mkdir()
    monkeypatch.chdir(cwd)
    assert cli.main(sweep_args("sweep", "--slurm")) == 2
    err = capsys.readouterr().err
    assert "--out (as an absolute path)" in err and "control character" in err, err
    assert list(cwd.iterdir()) == []


def test_base_deck_with_a_newline_is_refused(tmp_path, capsys):
    # Guards the base deck path (its name goes into every deck's header comment and the
    # manifest): refused before the sweep directory is made.
    base = tmp_path / "uh60\nmodal.nml"
    base.write_text(BASE.read_text())
    out = tmp_path / "out"
    assert cli.main(["sweep", str(base), "--set", GRID, "--out", str(out), "--slurm"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: base deck ") and "control character" in err, err
    assert not out.exists()


def test_task_and_collect_refuse_a_directory_with_a_newline(tmp_path, capsys):
    # Guards sweep-task and sweep-collect: a sweep directory renamed to hold a newline is
    # refused, and neither a record nor sweep.csv is written into it.
    prepare(BASE, [GRID], tmp_path / "ok")
    out = tmp_path / "sweep\nrenamed"
    os.rename(tmp_path / "ok", out)
    assert cli.main(["sweep-task", str(out), "0"]) == 2
    assert cli.main(["sweep-collect", str(out), "--no-plots"]) == 2
    err = capsys.readouterr().err
    assert err.count("control character") == 2, err
    assert list((out / "runs").iterdir()) == [] and not (out / "sweep.csv").exists()


# sbatch reads the #SBATCH lines itself; this is its parser, get_argument() in Slurm's
# src/sbatch/opt.c (24.x), in Python: C isspace() splits, '...' or "..." group, a backslash
# escapes the next character, an unquoted '#' ends the line, an unmatched quote is fatal.
_C_SPACE = " \t\n\v\f\r"


def sbatch_arguments(line: str) -> list[str]:
    assert line.startswith("#SBATCH")
    s, i, args = line[len("#SBATCH"):], 0, []
    while True:
        while i < len(s) and s[i] in _C_SPACE:
            i += 1
        arg, quote, escape, comment = [], None, False, False
        while i < len(s) and (quote or s[i] not in _C_SPACE):
            c = s[i]
            if escape:
                escape = False
            elif c == "\\":
                i += 1
                if i < len(s) and s[i] == " ":
                    arg.append(" ")
                    i += 1
                else:
                    escape = True
                continue
            elif quote:
                if c == quote:
                    quote, i = None, i + 1
                    continue
            elif c in "\"'":
                quote, i = c, i + 1
                continue
            elif c == "#":
                comment = True
                break
            arg.append(c)
            i += 1
        if quote:
            raise ValueError(f"sbatch: unmatched {quote} in {line!r}")
        if arg:
            args.append("".join(arg))
        if comment or i >= len(s) or not arg:
            return args


def slurm_output_file(pattern: str, job: str, task: str) -> str:
    """The file a batch task's --output pattern names (Slurm's src/slurmd/common/fname.c):
    with a backslash, no replacement at all; else %% is %, %A and %a the array job and task,
    and any other %<letter> something else (shown as <letter>)."""
    if "\\" in pattern:
        return pattern.replace("\\", "")
    return re.sub(r"%([%A-Za-z])",
                  lambda m: {"%": "%", "A": job, "a": task}.get(m.group(1), f"<{m.group(1)}>"), pattern)


def test_slurm_script_quotes_every_path(tmp_path, capsys):
    # Guards the quoting of sweep.slurm: an --out with spaces, both quotes, $(...), backticks,
    # ';', '#' and '%' must come back unchanged to bash (the task command) and to sbatch (the
    # #SBATCH lines, where shell quoting does not apply: the old script split the --output
    # line at the space and left the '%A' of the path to Slurm), and running the script
    # executes nothing of it.
    out = tmp_path / "my sweeps" / "a'b\"c $(touch INJECTED) `touch INJECTED2`; touch INJECTED3 #%A 100%"
    assert cli.main(["sweep", str(BASE), "--set", GRID, "--out", str(out), "--slurm"]) == 0
    stdout = capsys.readouterr().out
    script = out / "sweep.slurm"
    text = script.read_text()
    assert subprocess.run(["bash", "-n", str(script)]).returncode == 0
    # sbatch: one argument per directive line, and the log file is in DIR/slurm.
    directives = {}
    for line in text.splitlines():
        if line.startswith("#SBATCH"):
            args = sbatch_arguments(line)
            assert len(args) == 1, (line, args)
            key, _, value = args[0].partition("=")
            directives[key] = value
    assert slurm_output_file(directives["--output"], "1234", "7") == f"{out}/slurm/1234_7.out"
    assert directives["--array"] == "0-1" and re.fullmatch(r"rc-sweep-[\w.-]+", directives["--job-name"])
    # bash: the task line and the printed commands split back into the exact paths.
    task_line = next(line for line in text.splitlines() if " sweep-task " in line)
    assert shlex.split(task_line) == [sys.executable, "-m", "pydriver", "sweep-task", str(out),
                                      "$SLURM_ARRAY_TASK_ID"]
    submit = next(line for line in stdout.splitlines() if line.startswith("submit:"))
    assert shlex.split(submit.split(":", 1)[1]) == ["sbatch", str(script)]
    # Run as an array task would be (no Slurm here: bash reads #SBATCH lines as comments).
    work = tmp_path / "work"
    work.mkdir()
    run = subprocess.run(["bash", str(script)], cwd=work, capture_output=True, text=True,
                         env=dict(os.environ, SLURM_ARRAY_TASK_ID="1"))
    assert run.returncode == 0 and "0001: ok" in run.stdout, run.stderr
    assert (out / "runs" / "0001" / "summary.json").is_file()
    assert list(work.iterdir()) == [] and not list(tmp_path.rglob("INJECTED*"))


def test_sbatch_output_with_a_backslash_is_refused(tmp_path, capsys):
    # Guards the one path sbatch cannot take in --output: a backslash turns off Slurm's %A_%a
    # replacement (and is dropped), so the logs would land elsewhere; refused, nothing written.
    out = tmp_path / "back\\slash"
    assert cli.main(["sweep", str(BASE), "--set", GRID, "--out", str(out), "--slurm"]) == 2
    assert "backslash" in capsys.readouterr().err
    assert not out.exists()


# --- 2. A full disk -----------------------------------------------------------------------

class DiskFillsUp:
    """Stands for the ``os`` module of :mod:`pydriver.sweep.files`: a file whose name
    ``fails(name)`` accepts takes half of the data written to it, then the disk is full
    (ENOSPC), as when a disk fills up in the middle of a file."""

    def __init__(self, fails=lambda name: True):
        self.fails, self.last = fails, ""

    def __getattr__(self, name):
        return getattr(os, name)

    def open(self, path, *args, **kw):
        self.last = Path(path).name
        return os.open(path, *args, **kw)

    def fdopen(self, fd, *args, **kw):
        fh = os.fdopen(fd, *args, **kw)
        return HalfWriter(fh) if self.fails(self.last) else fh


class HalfWriter:
    def __init__(self, fh):
        self.fh = fh

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.fh.close()

    def write(self, data):
        self.fh.write(data[:len(data) // 2])
        self.fh.flush()
        raise full_disk()


@pytest.fixture
def swept(tmp_path):
    """A two-point sweep with both records and its sweep.csv."""
    out = tmp_path / "sweep"
    prepare(BASE, [GRID], out)
    for i in range(2):
        assert run_point(out, i)["error"] is None
    assert collect(out, plots=False).ok
    return out


def test_full_disk_writing_sweep_csv(swept, monkeypatch, capsys):
    # Guards sweep.csv on a full disk: a clean SweepError naming the file and the reason (the
    # old code raised the OSError), and the old table left whole, no temporary beside it.
    before = (swept / "sweep.csv").read_bytes()
    monkeypatch.setattr(files, "os", DiskFillsUp())
    with pytest.raises(SweepError, match=f"cannot write {re.escape(str(swept / 'sweep.csv'))}: "
                                         f"{ENOSPC_TEXT}"):
        collect(swept, plots=False)
    assert (swept / "sweep.csv").read_bytes() == before
    assert not list(swept.glob(".sweep.csv*"))
    # Through the command line: a message, no traceback; and no sweep.csv at all when there
    # was none before.
    (swept / "sweep.csv").unlink()
    assert cli.main(["sweep-collect", str(swept), "--no-plots"]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"error: cannot write {swept / 'sweep.csv'}: {ENOSPC_TEXT}"), err
    assert "Traceback" not in err
    assert not (swept / "sweep.csv").exists() and not list(swept.glob(".sweep.csv*"))


@pytest.mark.parametrize("what", ["plots", "report"])
def test_full_disk_writing_plots_or_report(swept, monkeypatch, what):
    # Guards the plots and report.html on a full disk: a SweepError naming the file, and no
    # partial file left (sweep.csv, written before them, is whole).
    ext = ".png." if what == "plots" else ".report.html."
    monkeypatch.setattr(files, "os", DiskFillsUp(lambda name: ext in name))
    with pytest.raises(SweepError, match=ENOSPC_TEXT) as exc:
        collect(swept, plots=what == "plots", report=what == "report")
    name = "plots/" if what == "plots" else "report.html"
    assert f"cannot write {swept}/{name}" in str(exc.value)
    assert not (swept / "report.html").exists()
    assert not list(swept.rglob(".*.png.*")) and not list(swept.glob(".report.html*"))
    assert (swept / "sweep.csv").read_text().count("\n") == 3


def _raises(exc):
    def run_deck(deck, out=None, **kw):
        raise exc
    return run_deck


def _deck_error_from_eio():
    # read_deck's way: an unreadable deck file becomes a DeckError raised `from None`, which
    # keeps the OSError as its context.
    try:
        raise OSError(errno.EIO, os.strerror(errno.EIO), "0001.nml")
    except OSError:
        try:
            raise DeckError("0001.nml", "", "", "cannot read the deck") from None
        except DeckError as exc:
            return exc


@pytest.mark.parametrize("exc", [full_disk("table.csv"), OSError(errno.EDQUOT, "Disk quota exceeded"),
                                 OSError(errno.EROFS, "Read-only file system"), MemoryError(),
                                 _deck_error_from_eio()],
                         ids=["ENOSPC", "EDQUOT", "EROFS", "MemoryError", "DeckError-from-EIO"])
def test_failure_of_the_machine_leaves_no_record(tmp_path, monkeypatch, exc):
    # Guards the per-point record: a failure of the machine during one grid point is no
    # error.json (the old code stored it, and no resume ran the point again): the Slurm task
    # says "not run" with the reason, and running it again runs the point.
    out = tmp_path / "sweep"
    prepare(BASE, [GRID], out)
    monkeypatch.setattr(records, "run_deck", _raises(exc))
    with pytest.raises(SweepError, match="0001 not run: ") as err:
        run_point(out, 1)
    assert "has no record" in str(err.value)
    assert list((out / "runs").iterdir()) == []            # no record, no temporary
    monkeypatch.undo()
    rec = run_point(out, 1)
    assert rec["error"] is None and not rec["skipped"]
    assert (out / "runs" / "0001" / "summary.json").is_file()


@pytest.mark.parametrize("exc", [DeckError("0001.nml", "springs", "c_beta", "must not be negative"),
                                 RunError("Newton did not converge")], ids=["DeckError", "RunError"])
def test_deck_and_solver_errors_stay_records(tmp_path, monkeypatch, exc):
    # Guards the other side: a genuine deck or solver error is still a permanent record.
    out = tmp_path / "sweep"
    prepare(BASE, [GRID], out)
    monkeypatch.setattr(records, "run_deck", _raises(exc))
    rec = run_point(out, 1)
    assert rec["error"].startswith(f"{type(exc).__name__}: ")
    assert (out / "runs" / "0001" / "error.json").is_file()


def test_full_disk_writing_error_json_leaves_no_record(tmp_path, monkeypatch):
    # Guards a deck error met on a full disk: its error.json cannot be written, so the point
    # has no record (not a partial one) and run_task raises the OSError.
    out = tmp_path / "sweep"
    prepare(BASE, [GRID], out)
    monkeypatch.setattr(records, "run_deck", _raises(RunError("diverged")))
    monkeypatch.setattr(files, "os", DiskFillsUp(lambda name: name.startswith(".error.json.")))
    with pytest.raises(OSError, match="No space left on device"):
        run_task(out / "decks" / "0001.nml", out / "runs" / "0001")
    assert list((out / "runs").iterdir()) == []


def test_sweep_reports_full_disk_as_not_run_and_reruns_it(tmp_path, monkeypatch, capsys):
    # Guards the whole sweep: point 0001 meets a full disk, the others finish; the command
    # prints "0001 not run: no space left on device", counts it missing and stores no record;
    # the same command run again (a real pool, in a new process) runs only 0001, successfully.
    out = tmp_path / "sweep"
    real_run_deck = records.run_deck

    def run_deck(deck, out=None, **kw):
        if Path(deck).name == "0001.nml":
            raise full_disk(Path(out) / "table.csv")
        return real_run_deck(deck, out=out, **kw)

    def in_process_pool(tasks, jobs, done):
        # The pool's contract (engines.run_pool): run_task per task, its exception to done().
        for id_, deck, run_dir in tasks:
            try:
                run_task(deck, run_dir)
                done(id_, None, None)
            except Exception as exc:  # noqa: BLE001 (what a future would hold)
                done(id_, exc, None)

    monkeypatch.setattr(records, "run_deck", run_deck)
    monkeypatch.setattr(sweep_run, "run_pool", in_process_pool)
    grid = "springs.c_beta=20,35.531,50"
    args = ["sweep", str(BASE), "--set", grid, "--out", str(out), "--quiet", "--no-plots", "--jobs", "1"]
    assert cli.main(args) == 1
    captured = capsys.readouterr()
    assert f"warning: 0001 not run: {ENOSPC_TEXT}: " in captured.err, captured.err
    assert "3 points, 2 ok, 0 failed, 1 missing" in captured.out
    assert sorted(p.name for p in (out / "runs").iterdir()) == ["0000", "0002"]
    monkeypatch.undo()
    again = subprocess.run([sys.executable, "-m", "pydriver", *args], capture_output=True, text=True)
    assert again.returncode == 0, again.stderr
    assert "3 ok, 0 failed, 0 missing (1 run now, 2 done before)" in again.stdout
    assert (out / "runs" / "0001" / "summary.json").is_file()
