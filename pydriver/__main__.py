"""Command line (``rotorcable`` or ``python -m pydriver``): ``run DECK [--out DIR] [--plots]
[--report] [--vtk] [--json]``, ``study NAME``, ``keys [GROUP or KEY]``, ``outputs [FILE]``, ``docs``,
``sweep BASE --set GROUP.KEY=VALUES ... --out DIR`` (and ``sweep-task``/``sweep-collect`` for
Slurm arrays), ``spectrum DECK --out DIR`` (a usage spectrum's regimes on the sweep engines)."""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

from pydriver.errors import DeckError, OutputError, RunError
from pydriver.run import run_deck


#: The signal that ended the command, once one has (see _exit_on_termination).
_TERMINATED: list[int] = []


def _exit_on_termination():
    """SIGTERM and SIGHUP end the command like Ctrl-C: as an exception, so that a run's
    temporary directory is removed on the way out (the default action ends the process at
    once and left 10 MB of partial time series behind, issue 20)."""
    import signal
    import threading

    def terminate(signum, frame):
        _TERMINATED.append(signum)
        sys.unraisablehook = redeliver_or_quiet
        raise SystemExit(128 + signum)

    def redeliver_or_quiet(unraisable):
        # A signal that came while a finalizer ran (a weakref callback inside h5py) raised its
        # SystemExit there, where Python drops it ("Exception ignored in ..."): the run went on
        # to its end and the command exited 0 (about 1 in 10 SIGTERMs while an HDF5 time series
        # is being set up).  Deliver it again, to be raised where the run sees it.  Other
        # complaints of objects half-built when the signal came are noise once the command is
        # ending.
        # Raised again from here it would be dropped again (Python ignores an exception of the
        # hook), so a timer thread sends the signal anew 10 ms later: it lands outside the
        # finalizer, or it is delivered again.
        if unraisable.exc_type is SystemExit and _TERMINATED:
            timer = threading.Timer(0.01, os.kill, (os.getpid(), _TERMINATED[0]))
            timer.daemon = True
            timer.start()

    for sig in (signal.SIGTERM, getattr(signal, "SIGHUP", None)):
        if sig is not None:
            signal.signal(sig, terminate)


def _default_outputs(decks: list[str]) -> dict:
    """``results/<deck stem>`` for each deck; two decks with one stem are refused before
    anything runs (the second would replace the first's results silently)."""
    outs: dict[Path, str] = {}
    for deck in decks:
        out = Path("results") / Path(deck).stem
        if out in outs and Path(outs[out]).resolve() != Path(deck).resolve():
            raise SystemExit(f"error: decks '{outs[out]}' and '{deck}' would both write {out}/: "
                             "run them one at a time, each with its own --out")
        outs.setdefault(out, deck)
    return {deck: out for out, deck in outs.items()}


#: The exit status of a command whose reader went away (``run --json | head``): 128 + SIGPIPE,
#: what a Unix tool ended by the signal reports, so that ``set -o pipefail`` sees what it sees
#: with ``yes | head``.
BROKEN_PIPE_STATUS = 141


def main(argv=None) -> int:
    """The command line; returns the exit status."""
    try:
        status = _main(argv)
        sys.stdout.flush()             # a closed pipe shows here, not in Python's exit handler
        return status
    except BrokenPipeError:
        # The reader has gone (``--json | head -c 10``): stop quietly, as a Unix tool ended by
        # SIGPIPE would, instead of a traceback and, at exit, Python's second complaint about
        # flushing stdout.  A run's files were committed before anything was printed.
        devnull = os.open(os.devnull, os.O_WRONLY)
        for stream in (sys.stdout, sys.stderr):
            try:
                os.dup2(devnull, stream.fileno())
            except (OSError, ValueError):
                pass
        return BROKEN_PIPE_STATUS


def build_parser() -> argparse.ArgumentParser:
    """The command line's parser (every subcommand and flag)."""
    parser = argparse.ArgumentParser(prog="rotorcable", description=__doc__)
    parser.add_argument("--version", action="version", version=f"rotorcable {_version()}")
    sub = parser.add_subparsers(dest="command", required=True)
    run = sub.add_parser("run", help="run one or more decks")
    run.add_argument("decks", nargs="+", help="namelist deck(s)")
    run.add_argument("--out", help="output directory (default results/<deck stem>/; one deck only)")
    run.add_argument("--plots", action="store_true", help="also write PNG plots (matplotlib)")
    run.add_argument("--report", action="store_true",
                     help="also write report.html: inputs, results and plots on one self-contained page")
    run.add_argument("--vtk", action="store_true",
                     help="also write the cable for ParaView: cable.pvd and cable_NNNN.vtu (the time series of a "
                          "flight or dynamic run, a static run's equilibrium) and, of a modal or Campbell run, "
                          "each mode as an animation mode<k>.pvd")
    run.add_argument("--restart", metavar="DIR",
                     help="continue the dynamic run in DIR from its end to this deck's t_end (same model; "
                          "&solver checkpoint_interval makes it match the uninterrupted run exactly)")
    run.add_argument("--json", action="store_true", help="print summary.json instead of the readable summary")
    loud = run.add_mutually_exclusive_group()
    loud.add_argument("-v", "--verbose", action="store_true",
                      help="progress messages on stderr, one per line with the elapsed time (also when not a terminal)")
    loud.add_argument("-q", "--quiet", action="store_true",
                      help="print nothing: no progress, no summary (errors still go to stderr; with --json the "
                           "JSON alone)")
    run.add_argument("--refine", action="store_true",
                     help="run the cable at n, 2n, 4n bodies and print every number with its Richardson "
                          "extrapolation and error estimate (&refinement levels = 3; needs &cable)")
    study = sub.add_parser("study", help="UH-60 studies: figures 5.6/5.12, 5.9, refinement and the design "
                                         "study (fatigue life before and after optimisation)")
    study.add_argument("name", choices=["shapes", "cy-sweep", "refine", "design"],
                       help="shapes: rest vs hover plots; cy-sweep: frequency against &springs c_beta and the "
                            "flap crossing; refine: first frequency for n = 11, 22, 44, 88")
    study.add_argument("--out", help="output directory (default results/studies/<name>/): new, empty or "
                                     "an earlier output of the same study")
    examples = sub.add_parser("examples", help="copy the example decks (and the tables they read) into a directory "
                                               "(never overwrites)")
    examples.add_argument("dir", nargs="?", default="rotorcable-examples", help="target directory")
    init = sub.add_parser("init", help="write a new deck that starts as one of the examples")
    init.add_argument("deck", help="the new deck's path (must not exist)")
    init.add_argument("--like", default="uh60_part2_forward_flight_cable",
                      help="the example to start from (see `rotorcable examples`)")
    _add_reference_parsers(sub)
    _add_sweep_parsers(sub)
    _add_spectrum_parser(sub)
    return parser


def _main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command in ("keys", "outputs", "docs"):
        return _reference_command(args)
    if args.command in ("examples", "init"):
        return _examples_command(args)
    if args.command in ("sweep", "sweep-task", "sweep-collect"):
        return _sweep_command(args)
    if args.command == "spectrum":
        return _spectrum_command(args)
    if args.command == "study":
        return _study_command(args)
    if args.out and len(args.decks) > 1:
        parser.error("--out takes one deck")
    _exit_on_termination()
    from pydriver import progress
    progress.configure(progress.QUIET if args.quiet else progress.VERBOSE if args.verbose else progress.NORMAL)
    decks = {args.decks[0]: Path(args.out)} if args.out else _default_outputs(args.decks)
    status = 0
    for deck, out in decks.items():
        try:
            target = deck
            if args.refine:
                from pydriver.model import Model
                target = Model.from_deck(deck).with_changes({"refinement.levels": 3})
            try:
                with progress.run_progress(Path(deck).name):
                    res = run_deck(target, out=out, plots=args.plots, report=args.report, vtk=args.vtk,
                                  restart=args.restart)
            except BaseException:
                # SIGTERM raised SystemExit wherever Python was; a library's clean-up on the way
                # out (h5py closing a half-written file, say) may raise something else: the
                # command still ends as terminated, quietly (its temporaries are gone already).
                if _TERMINATED:
                    raise SystemExit(128 + _TERMINATED[0]) from None
                raise
        except (DeckError, RunError) as exc:
            print(f"error: {exc}", file=sys.stderr)
            status = 1
            continue
        except OutputError as exc:           # an output directory a run must not replace
            print(f"error: deck '{Path(deck).name}': {exc}", file=sys.stderr)
            status = 1
            continue
        except OSError as exc:               # an output directory that cannot be written
            print(f"error: deck '{Path(deck).name}': cannot write the results to {out}: "
                  f"{exc.strerror or exc}", file=sys.stderr)
            status = 1
            continue
        if args.json:
            print(json.dumps(res.summary, indent=1))
        elif not args.quiet:
            from pydriver.report_text import text_summary
            print(text_summary(res.summary, res.files))
    return status


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version
    try:
        return version("rotorcable")
    except PackageNotFoundError:          # a source tree without an installation
        return "(not installed)"


def _study_command(args) -> int:
    from pydriver.study import run_study
    _exit_on_termination()
    out = Path(args.out) if args.out else Path("results") / "studies" / args.name
    try:
        print(run_study(args.name, out))
    except OutputError as exc:               # an output directory the study must not write
        print(f"error: study {args.name}: {exc}", file=sys.stderr)
        return 1
    except (DeckError, RunError, RuntimeError) as exc:
        print(f"error: study {args.name}: {exc}", file=sys.stderr)
        return 1
    except OSError as exc:                   # a directory that cannot be written, or no decks
        where = f"cannot write the results to {out}: " if exc.errno is not None else ""
        print(f"error: study {args.name}: {where}{exc.strerror or exc}", file=sys.stderr)
        return 1
    return 0


def _examples_command(args) -> int:
    from pydriver.examples import copy_examples, init_deck
    try:
        if args.command == "init":
            print(f"wrote {init_deck(args.deck, args.like)} (from the example {args.like})")
            return 0
        written, kept = copy_examples(args.dir)
    except (OSError, ValueError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print(f"copied {len(written)} example files (decks and the tables they read) to {args.dir}/"
          + (f"; kept {len(kept)} already there: {', '.join(p.name for p in kept)}" if kept else ""))
    return 0


def _add_reference_parsers(sub):
    from pydriver.reference import FORMATS
    fmt = dict(choices=FORMATS, default="text",
               help="text for the terminal (default), markdown, or html (one self-contained page)")
    keys = sub.add_parser("keys", help="the deck reference: every group and key a deck may have",
                          description="Print the deck reference (generated from the schema): a group's keys "
                                      "(rotorcable keys chain), the groups that have a key (rotorcable keys "
                                      "t_end), one key (rotorcable keys solver.t_end), or all of them.")
    keys.add_argument("name", nargs="?", default="", metavar="GROUP or KEY",
                      help="a group (chain, &chain), a key (t_end) or group.key (solver.t_end)")
    keys.add_argument("--format", **fmt)
    outputs = sub.add_parser("outputs", help="the output reference: every file a run writes and its columns",
                             description="Print the output reference: every file a run, a sweep or a study "
                                         "writes, its columns with units and meanings.")
    outputs.add_argument("file", nargs="?", default="", metavar="FILE",
                         help="one output file (fatigue.csv, or fatigue)")
    outputs.add_argument("--format", **fmt)
    docs = sub.add_parser("docs", help="the whole reference: deck keys and output files",
                          description="Print the deck reference and the output reference together, e.g. "
                                      "rotorcable docs --format html > rotorcable.html")
    docs.add_argument("--format", **fmt)


def _reference_command(args) -> int:
    from pydriver.reference import full_reference, keys_reference, outputs_reference
    from pydriver.reference_output import print_text
    try:
        if args.command == "keys":
            text = keys_reference(args.name, args.format)
        elif args.command == "outputs":
            text = outputs_reference(args.file, args.format)
        else:
            text = full_reference(args.format)
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print_text(text)
    return 0


def _add_sweep_parsers(sub):
    from pydriver.sweep import GRID_HELP
    sweep = sub.add_parser(
        "sweep", help="run a grid of decks made from one base deck (parameter sweep)",
        description="Expand a grid of --set values into decks DIR/decks/<id>.nml, run them "
                    "(local process pool, a Dask scheduler, or a Slurm job array) and aggregate "
                    "each run's results into DIR/sweep.csv and DIR/plots/.  Rerunning the same "
                    "command resumes an interrupted sweep; finished decks are not run again.",
        epilog=GRID_HELP, formatter_class=argparse.RawDescriptionHelpFormatter)
    sweep.add_argument("base", help="base deck")
    sweep.add_argument("--set", dest="sets", action="append", required=True,
                       metavar="GROUP.KEY=VALUES", help="swept parameter (repeat for a product grid)")
    sweep.add_argument("--out", required=True, help="sweep directory (resumes if it holds this sweep)")
    engine = sweep.add_mutually_exclusive_group()
    engine.add_argument("--jobs", type=int, metavar="N",
                        help="local worker processes (default: all cores this process may use)")
    engine.add_argument("--dask", metavar="ADDRESS",
                        help="run the decks on a running Dask scheduler, e.g. tcp://host:8786 "
                             "(DIR must be on a file system the workers share)")
    engine.add_argument("--slurm", action="store_true",
                        help="write the decks and a Slurm job-array script DIR/sweep.slurm, run "
                             "nothing, print the sbatch and aggregation commands")
    sweep.add_argument("--quiet", action="store_true", help="no progress bar")
    sweep.add_argument("--no-plots", action="store_true", help="do not draw DIR/plots/")
    sweep.add_argument("--report", action="store_true", help="also write DIR/report.html (grid, table, plots)")
    sweep.add_argument("--retry-failed", action="store_true",
                       help="run the decks whose record is an error again")
    task = sub.add_parser("sweep-task", help="run one grid point of a prepared sweep (Slurm array task)")
    task.add_argument("out", help="sweep directory")
    task.add_argument("index", type=int, help="grid point index ($SLURM_ARRAY_TASK_ID)")
    coll = sub.add_parser("sweep-collect", help="aggregate a sweep's finished runs into sweep.csv and plots")
    coll.add_argument("out", help="sweep directory")
    coll.add_argument("--no-plots", action="store_true", help="do not draw DIR/plots/")
    coll.add_argument("--report", action="store_true", help="also write DIR/report.html")


def _sweep_command(args) -> int:
    from pydriver.sweep import SweepError, collect, run_point, run_sweep, write_slurm
    try:
        if args.command == "sweep-task":
            rec = run_point(args.out, args.index)
            state = "done before" if rec["skipped"] else "ok" if rec["error"] is None else "failed"
            print(f"{rec['id']}: {state}" + (f": {rec['error']}" if rec["error"] else ""))
            return 0 if rec["error"] is None else 1
        if args.command == "sweep-collect":
            status = collect(args.out, plots=not args.no_plots, report=args.report)
            print(status.line())
            return 0 if status.ok else 1
        if args.jobs is not None and args.jobs < 1:
            raise SweepError(f"--jobs {args.jobs}: needs at least 1")
        if args.slurm:
            script, commands = write_slurm(args.base, args.sets, args.out)
            print(f"wrote the decks and {script} (nothing run)")
            print(f"submit:                   {commands[0]}")
            print(f"when all tasks are done:  {commands[1]}")
            return 0
        status = run_sweep(args.base, args.sets, args.out, jobs=args.jobs, dask=args.dask,
                           progress=not args.quiet, plots=not args.no_plots,
                           retry_failed=args.retry_failed, report=args.report)
    except (SweepError, FileNotFoundError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    for id_, msg in status.lost.items():
        print(f"warning: {id_} not run: {msg}", file=sys.stderr)
    print(status.line())
    if status.interrupted:
        return 130
    return 0 if status.ok else 1


def _add_spectrum_parser(sub):
    spectrum = sub.add_parser(
        "spectrum", help="life over a usage spectrum: run its regimes on a process pool, Dask or Slurm (resumable)",
        description="Write the regimes of a usage-spectrum deck (&case analysis = 'spectrum') and its rotor run-up "
                    "as decks DIR/decks/<id>.nml, run them (local process pool, a Dask scheduler, or a Slurm job "
                    "array) and combine their records into DIR/summary.json and DIR/spectrum.csv: the life at "
                    "the worst jacket point with its error bar, the damage by regime and from ground-air-ground "
                    "cycles.  Running the same command again resumes; a regime whose deck changed runs again.")
    spectrum.add_argument("deck", help="usage-spectrum deck")
    spectrum.add_argument("--out", required=True, help="spectrum directory (resumes if it holds this spectrum)")
    engine = spectrum.add_mutually_exclusive_group()
    engine.add_argument("--jobs", type=int, metavar="N",
                        help="local worker processes (default: all cores this process may use)")
    engine.add_argument("--dask", metavar="ADDRESS",
                        help="run the regimes on a running Dask scheduler, e.g. tcp://host:8786 (DIR on a file "
                             "system the workers share)")
    engine.add_argument("--slurm", action="store_true",
                        help="write the decks and a Slurm job-array script DIR/sweep.slurm, run nothing, print the "
                             "sbatch command and the command that combines the records afterwards")
    spectrum.add_argument("--report", action="store_true", help="also write DIR/report.html")
    spectrum.add_argument("--retry-failed", action="store_true",
                          help="run the regimes whose record is an error again (a changed regime runs again anyway)")
    spectrum.add_argument("--json", action="store_true", help="print the spectrum's summary.json when complete")


def _spectrum_command(args) -> int:
    from pydriver.sweep import SweepError
    from pydriver.sweep.spectrum import run_spectrum, write_spectrum_slurm
    _exit_on_termination()
    try:
        if args.jobs is not None and args.jobs < 1:
            raise SweepError(f"--jobs {args.jobs}: needs at least 1")
        if args.slurm:
            script, commands = write_spectrum_slurm(args.deck, args.out)
            print(f"wrote the decks and {script} (nothing run)")
            print(f"submit:                   {commands[0]}")
            print(f"when all tasks are done:  {commands[1]}")
            return 0
        status = run_spectrum(args.deck, args.out, jobs=args.jobs, dask=args.dask,
                              retry_failed=args.retry_failed, report=args.report)
    except (SweepError, FileNotFoundError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except (DeckError, RunError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    for name, msg in status.lost.items():
        print(f"warning: {name} not run: {msg}", file=sys.stderr)
    if args.json and status.summary is not None:
        print(json.dumps(status.summary, indent=1))
    else:
        print(status.line())
    if status.interrupted:
        return 130
    return 0 if status.ok else 1


if __name__ == "__main__":
    sys.exit(main())
