"""A usage spectrum on the sweep engines: ``rotorcable spectrum DECK --out DIR [--jobs N |
--dask ADDRESS | --slurm]`` (issue 38, item 4).

The regimes of a spectrum deck (:mod:`pydriver.usage_spectrum`) and its run-up are the points
of a sweep directory, in the sweep's own layout (:mod:`pydriver.sweep.layout`, kind ``sweep``)::

    DIR/sweep.json          manifest: the spectrum deck, one point for the run-up (the first,
                            id 0000) and one per regime in the deck's order, each with its
                            deck's SHA-256; "maker": "spectrum"
    DIR/decks/<id>.nml      the regime's flight deck (the run-up's dynamic deck), runs alone
    DIR/runs/<id>/          its record: summary.json, fatigue.csv, refinement.csv and every
                            level's jacket points, fatigue_points.csv
                            (:mod:`pydriver.analyses.spectrum_records`), or error.json
    DIR/spectrum.csv        one row per regime, the ground-air-ground cycles and the start-stops
    DIR/summary.json        the spectrum's summary (as ``rotorcable run`` writes it)
    DIR/refinement.csv      the life at n, 2n, 4n and its extrapolation
    DIR/report.html         with --report

So the same engines run them (the local pool, a Dask scheduler, a Slurm job array whose task i
is ``python -m pydriver sweep-task DIR i``), a killed run resumes where it stopped (a record is
whole or absent), and a 20-regime spectrum at n = 11, 22, 44 takes the time of its slowest
regime on as many cores.  A regime that fails is a record too (``error.json``): the others are
kept, and the spectrum says which regime failed and why.  Running the command again runs what
has no record: a regime whose deck changed (the spectrum deck's values for it, its blade table)
has its old record removed and runs again, the others are kept; ``--retry-failed`` runs a
failed regime whose deck did not change.  A spectrum with another list of regimes is another
spectrum: refused, as a sweep with another grid is.

When every point has a record, the records are combined (:func:`pydriver.analyses.spectrum.spectrum_result`)
into the files above; the numbers are those of ``rotorcable run DECK`` bit for bit (every record
holds its numbers exactly).  When some are missing or failed, those files are removed (they
would describe another spectrum) and the status names the regimes.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import shlex
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

from pydriver.deckfile import read_deck
from pydriver.ownership import read_marker, unlink_plain_file
from pydriver.sweep.engines import default_jobs, run_dask, run_pool, write_array_script
from pydriver.sweep.errors import SweepError
from pydriver.sweep.faults import not_run_reason, writing
from pydriver.sweep.files import write_atomic
from pydriver.sweep.given_paths import checked_path, refuse_control_characters
from pydriver.sweep.layout import (
    FORMAT,
    MANIFEST,
    SPECTRUM_FILES,
    check_sweep_directory,
    claim,
    existing_manifest,
    remove_record,
    write_file,
)
from pydriver.sweep.lock import hold_lock
from pydriver.sweep.records import read_record
from pydriver.sweep.run import _tasks

#: The record maker of a spectrum's points (pydriver.sweep.records.MAKERS).
MAKER = "spectrum"
#: The run-up's name among the points.
RUNUP = "run-up"


def _sha(text: str) -> str:
    return hashlib.sha256(text.encode()).hexdigest()


def plan(deck_path) -> tuple[dict, dict, object]:
    """The manifest, the deck texts by id and the :class:`pydriver.usage_spectrum.Spectrum` of a
    spectrum deck, checked, without writing anything.

    Raises
    ------
    SweepError
        The deck is missing or not a spectrum deck.
    DeckError
        The deck or a regime is invalid (naming the key and the regime).
    """
    from pydriver.usage_spectrum import is_spectrum, spectrum_of
    path = checked_path(deck_path, "spectrum deck")
    if not path.is_file():
        raise SweepError(f"spectrum deck '{path}' not found")
    deck = read_deck(path)
    if not is_spectrum(deck):
        raise SweepError(f"{path.name}: not a usage spectrum (&case analysis = 'spectrum'); a grid of decks is "
                         "`rotorcable sweep`")
    from pydriver.model import Model
    Model(deck)                                # the base builds (the regimes are checked by spectrum_of)
    spec = spectrum_of(deck)
    # The run-up first.  Every engine starts the points in this order (the pool and Dask as they
    # are handed over, a Slurm array by task number), and the run-up, a dynamic run from rest
    # through the whole run-up time at every level, is the shipped spectrum's longest run (~10 s
    # against 2-6 s for a regime at n = 11, 22, 44): started last, it ran alone while the other
    # cores had nothing left to do (benchmarks/README.md, "Usage spectrum on the engines").  A
    # short run-up put first delays the end by no more than its own short time.
    texts = ([(RUNUP, spec.runup_text)] if spec.runup is not None else []) + [(r.name, r.text) for r in spec.regimes]
    width = max(4, len(str(len(texts) - 1)))
    points = [{"id": f"{i:0{width}d}", "values": [name], "deck_sha256": _sha(text)}
              for i, (name, text) in enumerate(texts)]
    manifest = {"format": FORMAT, "maker": MAKER, "base_deck": str(path),
                "base_sha256": _sha(path.read_text(encoding="utf-8")), "sets": [], "params": ["regime"],
                "scales": {}, "points": points, "python": sys.executable}
    return manifest, {p["id"]: text for p, (_, text) in zip(points, texts)}, spec


def _adopt(out: Path, manifest: dict) -> dict:
    """Under the lock: keep the records of ``out`` whose decks are unchanged, remove the others',
    write the manifest.  Another spectrum (other regimes) or a sweep in ``out`` is refused."""
    old = existing_manifest(out)
    if old is None:
        if any((out / name).exists() for name in ("runs", "decks")):
            raise SweepError(f"{out} holds sweep files but no {MANIFEST}; choose a new --out")
    else:
        names = [p["values"] for p in manifest["points"]]
        if old.get("maker") != MAKER or [p["values"] for p in old["points"]] != names \
                or [p["id"] for p in old["points"]] != [p["id"] for p in manifest["points"]]:
            what = ("a sweep" if old.get("maker") != MAKER else
                    f"the spectrum of the regimes {', '.join(p['values'][0] for p in old['points'])}")
            raise SweepError(f"{out} holds {what}, not the regimes of {Path(manifest['base_deck']).name} "
                             "(a spectrum with other regimes is another spectrum): choose a new --out")
        for before, now in zip(old["points"], manifest["points"]):
            if before.get("deck_sha256") != now["deck_sha256"]:
                # Its deck changed: its record is of another deck (and is the spectrum's own).
                if not remove_record(out / "runs" / now["id"]) and (out / "runs" / now["id"]).exists():
                    raise SweepError(f"{out / 'runs' / now['id']}: cannot remove the record of the changed regime "
                                     f"'{now['values'][0]}': it holds files this spectrum did not write")
        if old == manifest:
            return old
    write_file(out, MANIFEST, json.dumps(manifest, indent=1) + "\n")
    return manifest


def _write_decks(out: Path, manifest: dict, texts: dict) -> None:
    (out / "decks").mkdir(exist_ok=True)
    (out / "runs").mkdir(exist_ok=True)
    claim(out, [f"decks/{p['id']}.nml" for p in manifest["points"]])
    for p in manifest["points"]:
        deck = out / "decks" / f"{p['id']}.nml"
        text = texts[p["id"]]
        if not deck.is_file() or deck.read_text() != text:
            write_atomic(deck, text)


@contextlib.contextmanager
def _opened(deck_path, out: Path):
    """Plan, check the directory, hold its lock, adopt it and write the decks; yields (manifest,
    spectrum).  Nothing is written before the deck and the directory pass."""
    manifest, texts, spec = plan(deck_path)
    check_sweep_directory(out, manifest)
    with writing(out):
        out.mkdir(parents=True, exist_ok=True)
    with hold_lock(out):
        check_sweep_directory(out, manifest)        # again, now that no other run can write
        with writing(out):
            manifest = _adopt(out, manifest)
            _write_decks(out, manifest, texts)
        yield manifest, spec


@dataclass
class SpectrumStatus:
    """Outcome of :func:`run_spectrum` (and :func:`collect_spectrum`)."""

    out: Path
    points: dict = field(default_factory=dict)      #: id -> regime name (the run-up: "run-up")
    ran: list = field(default_factory=list)
    skipped: list = field(default_factory=list)
    failed: dict = field(default_factory=dict)      #: regime name -> error
    missing: list = field(default_factory=list)     #: regime names without a record
    lost: dict = field(default_factory=dict)        #: id -> why the engine did not run it
    interrupted: bool = False
    summary: dict | None = None                     #: the spectrum's summary when complete

    @property
    def ok(self) -> bool:
        return self.summary is not None

    def line(self) -> str:
        """One-line report."""
        n = len(self.points)
        done = n - len(self.failed) - len(self.missing)
        text = (f"spectrum {self.out}: {n} runs (regimes and run-up), {done} ok, {len(self.failed)} failed, "
                f"{len(self.missing)} missing ({len(self.ran)} run now, {len(self.skipped)} done before)")
        for name, error in self.failed.items():
            text += f"\n  regime '{name}' failed: {error}" if name != RUNUP else f"\n  the run-up failed: {error}"
        if self.failed:
            text += ("\n  fix the deck and run the command again: a changed regime runs again, the others are kept "
                     "(--retry-failed runs an unchanged failed one again)")
        if self.interrupted:
            text += "\n  interrupted: run the same command again to resume"
        elif self.missing:
            text += f"\n  not run yet: {', '.join(self.missing)}; run the same command again to resume"
        if self.summary is not None:
            s = self.summary["spectrum"]
            life = s["life_converged_hours"]
            err = f" +- {s['life_error_hours']:.3g}" if "life_error_hours" in s else ""
            text += (f"\n  life {life:.4g}{err} h over the spectrum, safe life {s['safe_life_hours']:.4g} h "
                     if life is not None else "\n  no point takes damage: the life is unbounded ")
            text += f"-> {self.out / 'summary.json'}, {self.out / 'spectrum.csv'}"
        return text


def collect_spectrum(out: Path, manifest: dict, spec, report: bool = False) -> SpectrumStatus:
    """Combine the records of a spectrum directory (under its lock) into its files; incomplete
    records leave no result files (module docstring)."""
    from pydriver.analyses.spectrum import spectrum_result
    from pydriver.analyses.spectrum_records import read_record as read_regime
    t0 = time.perf_counter()
    status = SpectrumStatus(out=out, points={p["id"]: p["values"][0] for p in manifest["points"]})
    runs = {}
    for p in manifest["points"]:
        name, rec = p["values"][0], read_record(out / "runs" / p["id"])
        if rec is None:
            status.missing.append(name)
        elif "error" in rec:
            status.failed[name] = rec["error"]
        else:
            try:
                runs[name] = read_regime(out / "runs" / p["id"])
            except (OSError, ValueError, KeyError) as exc:
                status.failed[name] = f"its record {out / 'runs' / p['id']} cannot be read ({exc}): remove it"
    if status.failed or status.missing:
        marker = read_marker(out)
        for name in (*SPECTRUM_FILES, "report.html"):
            if marker is not None and name in marker.files:
                unlink_plain_file(out, name)        # the spectrum's own: it would describe another one
        return status
    from pydriver.model import Model
    model = Model(spec.deck)
    runup = runs.pop(RUNUP, None)
    result = spectrum_result(model, spec, runs, runup, time.perf_counter() - t0)
    from pydriver.analyses import finish
    finish(model, result)               # as analyses.run ends: ignored keys, limits
    from pydriver.output import csv_text
    from pydriver.run_result import require_finite
    require_finite(result, model.name)
    with writing(out):
        for name, columns in result.extra["tables"].items():
            write_file(out, name, csv_text(name, columns))
        if report:
            from pydriver.report_html import html_report
            write_file(out, "report.html", html_report(result, model))
        write_file(out, "summary.json", json.dumps(result.summary, indent=2, allow_nan=False) + "\n")
    status.summary = result.summary
    return status


def run_spectrum(deck, out, *, jobs: int | None = None, dask: str | None = None, retry_failed: bool = False,
                 report: bool = False) -> SpectrumStatus:
    """Run a spectrum deck's regimes and run-up on a sweep engine into ``out`` and combine them.

    Parameters
    ----------
    deck : str or Path
        The spectrum deck (``analysis = 'spectrum'``).
    out : str or Path
        The spectrum directory; running again resumes (module docstring).
    jobs : int, optional
        Worker processes of the local pool (default: the cores this process may use).
    dask : str, optional
        Address of a running Dask scheduler; ``out`` on a file system its workers share.
    retry_failed : bool
        Run the regimes whose record is an error again although their decks did not change.
    report : bool
        Also write ``report.html``.

    Returns
    -------
    SpectrumStatus

    Raises
    ------
    SweepError
        A directory that holds anything but this spectrum, another spectrum or a sweep, a path
        with a control character, or a file that cannot be written (named).
    DeckError
        The deck or a regime of it is invalid (before anything is written).
    """
    out = checked_path(out, "--out", link_ok=False)
    with _opened(deck, out) as (manifest, spec):
        tasks, skipped = _tasks(out, manifest, retry_failed)
        lost, interrupted = {}, False

        def done(id_, exc, fut):
            if exc is not None:
                lost[id_] = not_run_reason(exc)
        try:
            if tasks and dask:
                run_dask(tasks, dask, done, MAKER)
            elif tasks:
                run_pool(tasks, jobs or default_jobs(), done, MAKER)
        except KeyboardInterrupt:
            interrupted = True
        status = collect_spectrum(out, manifest, spec, report)
    status.skipped = [status.points[i] for i in skipped]
    have = set(skipped)
    status.ran = [status.points[p["id"]] for p in manifest["points"]
                  if p["id"] not in have and status.points[p["id"]] not in status.missing]
    status.lost = {status.points[i]: why for i, why in lost.items()}
    status.interrupted = interrupted
    return status


def write_spectrum_slurm(deck, out) -> tuple[Path, list[str]]:
    """Write a spectrum directory's decks and a Slurm job array ``DIR/sweep.slurm`` of its regimes
    (and run-up) without a record; nothing is run.  When the array is done, the printed command
    (``rotorcable spectrum DECK --out DIR`` again) finds every record and combines them.

    Returns
    -------
    script : Path
    commands : list of str
        The ``sbatch`` command and the combining command (shell-quoted).

    Raises
    ------
    SweepError, DeckError
        As :func:`run_spectrum`; every path is checked before anything is written.
    """
    out = checked_path(out, "--out", link_ok=False)
    from pydriver.sweep.engines import output_pattern
    output_pattern(out / "slurm")                   # refused before anything is written
    refuse_control_characters(sys.executable, "Python interpreter")
    deck_path = checked_path(deck, "spectrum deck").resolve()
    collect_cmd = (f"{shlex.quote(sys.executable)} -m pydriver spectrum {shlex.quote(str(deck_path))} "
                   f"--out {shlex.quote(str(out))}")
    with _opened(deck_path, out) as (manifest, _):
        return write_array_script(out, manifest, "spectrum", collect_cmd)
