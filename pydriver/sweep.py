"""Parameter sweeps: a grid of decks from one base deck, run locally or on a cluster.

Layout of a sweep directory ``DIR``::

    DIR/sweep.json         manifest: base deck (and its SHA-256), the --set specs, the grid
    DIR/decks/<id>.nml     one plain deck per grid point (re-runnable alone)
    DIR/runs/<id>/         the record of a finished deck: the files of `pydriver run`
                           (summary.json, table.csv, modes.csv, ...) or error.json
    DIR/sweep.csv          one row per record, sorted by id (rebuilt from runs/ every time)
    DIR/plots/             <result>_vs_<parameter>.png

A record appears in one step (the run writes into a hidden temporary directory that is
renamed to ``runs/<id>`` when complete), so a sweep killed at any moment leaves either a
whole record or none; a rerun skips the ids that have a record and ``sweep.csv`` is rebuilt
from the records, so no row can be lost or duplicated.

Execution engines: a local process pool (default, one deck per task), a running Dask
scheduler (``dask=ADDRESS``, e.g. started with dask-jobqueue on Slurm/PBS), or a Slurm job
array script (``write_slurm``).  All three call the same per-deck function, ``run_task``.
"""

from __future__ import annotations

import contextlib
import hashlib
import itertools
import json
import os
import re
import shutil
import sys
import tempfile
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from pydriver.errors import DeckError
from pydriver.run import deck_info, run_deck
from pydriver.results import (MANIFEST, REACTION_COLUMNS, TABLE, read_manifest, read_record,
                              rows_to_table, sweep_rows, table_csv_text)
from pydriver.study import override_deck

GRID_HELP = """\
grid syntax of --set GROUP.KEY=VALUES (VALUES is namelist text):
  v1,v2,v3       a list (strings quoted as in the deck: case.analysis="'static','modal'")
  a:b:n          n points from a to b inclusive, evenly spaced (1:70:24 = 1, 4, ..., 70;
                 integer end points with an integer step give integers)
  log:a:b:n      n log-spaced points from a to b inclusive (a, b > 0)
  items may be mixed: 0.5,1:70:24.  Several --set options span the Cartesian product
  (the last one varies fastest); grid points get ids 0000, 0001, ... in that order.
  Array keys (loads.gravity, clamp_b.position, shape.beta_deg, ...) are swept one element
  at a time: loads.gravity(3)=-9.81,-1.62."""

# Keys declared as arrays in src_fortran/deck.f90.  A bare value given to one of them would
# set only its first element (namelist semantics) and leave the rest of the base deck's
# array: a silent change of meaning, so such --set specs are refused.
ARRAY_KEYS = {"shape.gamma_deg", "shape.beta_deg", "shape.gamma_rate_deg", "shape.beta_rate_deg",
              "springs.rest_gamma_deg", "springs.rest_beta_deg", "clamp_b.position",
              "loads.gravity", "loads.rotor_offset", "loads.pulse_force", "loads.tip_force"}

PLOT_RESULTS = ["f1_hz", "f1_damped_hz", "zeta1"] + REACTION_COLUMNS


class SweepError(ValueError):
    """A sweep that cannot start: bad ``--set`` option, first deck invalid, directory mismatch."""


# --------------------------------------------------------------------------- grid


def _split_items(text: str) -> list[str]:
    """Split on commas outside quotes (namelist strings may contain commas)."""
    items, cur, quote = [], "", None
    for ch in text:
        if quote:
            cur += ch
            if ch == quote:
                quote = None
        elif ch in "'\"":
            cur += ch
            quote = ch
        elif ch == ",":
            items.append(cur)
            cur = ""
        else:
            cur += ch
    items.append(cur)
    return [s.strip() for s in items]


def _fmt(x: float) -> str:
    # 15 significant digits drop linspace round-off (0.30000000000000004 -> 0.3), so the deck,
    # the manifest and sweep.csv all carry the same short text.
    return repr(float(f"{x:.15g}"))


def _range(item: str, opt: str) -> list[str]:
    log = item.lower().startswith("log:")
    parts = item[4:].split(":") if log else item.split(":")
    form = "log:a:b:n" if log else "a:b:n"
    if len(parts) != 3:
        raise SweepError(f"--set {opt}: range '{item}' is not of the form {form}")
    a, b, n = (p.strip() for p in parts)
    try:
        fa, fb = float(a.lower().replace("d", "e")), float(b.lower().replace("d", "e"))
        num = int(n)
    except ValueError:
        raise SweepError(f"--set {opt}: range '{item}': {form} needs numbers a, b and an "
                         f"integer n") from None
    if num < 2:
        raise SweepError(f"--set {opt}: range '{item}': n must be at least 2 (a list takes one value)")
    if log:
        if fa <= 0 or fb <= 0:
            raise SweepError(f"--set {opt}: log range '{item}' needs a > 0 and b > 0")
        return [_fmt(x) for x in np.geomspace(fa, fb, num)]
    integer = re.compile(r"^[+-]?\d+$")
    if integer.match(a) and integer.match(b) and (int(b) - int(a)) % (num - 1) == 0:
        step = (int(b) - int(a)) // (num - 1)
        return [str(int(a) + k * step) for k in range(num)]
    return [_fmt(x) for x in np.linspace(fa, fb, num)]


def _base_is_array(base_text: str, group: str, key: str) -> bool:
    """Whether the base deck assigns several values to group.key (an array key)."""
    m = re.search(rf"&{group}\b(.*?)\n\s*/", base_text, re.S | re.I)
    if not m:
        return False
    k = re.search(rf"^[ \t]*{key}[ \t]*=(.*)$", m.group(1), re.M | re.I)
    if not k:
        return False
    value = re.sub(r"!.*$", "", k.group(1))
    return len(_split_items(value)) > 1 or "*" in value


def parse_set(spec: str, base_text: str = "") -> tuple[str, list[str], str]:
    """Parse one ``--set GROUP.KEY=VALUES`` option.

    Parameters
    ----------
    spec : str
        ``GROUP.KEY=VALUES`` in the grid syntax (see ``GRID_HELP``).
    base_text : str
        Text of the base deck, to recognise array keys it assigns.

    Returns
    -------
    name : str
        ``group.key`` in lower case (``group.key(i)`` for one array element).
    values : list of str
        Namelist value texts, one per grid point along this parameter.
    scale : str
        ``"log"`` when every item is a log range (for plot axes), else ``"linear"``.

    Raises
    ------
    SweepError
        Malformed option, naming it.
    """
    if "=" not in spec:
        raise SweepError(f"--set {spec}: expected GROUP.KEY=VALUES")
    name, text = (s.strip() for s in spec.split("=", 1))
    m = re.fullmatch(r"([a-z_]\w*)\.([a-z_]\w*)(\(\s*\d+\s*\))?", name, re.I)
    if not m:
        raise SweepError(f"--set {spec}: '{name}' is not GROUP.KEY (e.g. springs.c_beta) "
                         f"or GROUP.KEY(i) for one array element")
    group, key, index = m.group(1).lower(), m.group(2).lower(), (m.group(3) or "").replace(" ", "")
    name = f"{group}.{key}{index}"
    if not index and (f"{group}.{key}" in ARRAY_KEYS or _base_is_array(base_text, group, key)):
        raise SweepError(f"--set {spec}: {group}.{key} is an array; sweep one element at a time, "
                         f"e.g. --set {group}.{key}(3)=...")
    if not text:
        raise SweepError(f"--set {spec}: no values")
    values, log_items = [], []
    for item in _split_items(text):
        if not item:
            raise SweepError(f"--set {spec}: empty value in the list")
        if item[0] in "'\"" or ":" not in item:
            values.append(item)
            log_items.append(False)
        else:
            values.extend(_range(item, spec))
            log_items.append(item.lower().startswith("log:"))
    return name, values, "log" if all(log_items) else "linear"


def expand_grid(specs: list[str], base_text: str = "") -> tuple[list[str], list[list[str]], dict]:
    """Cartesian product of several ``--set`` options.

    Returns
    -------
    params : list of str
        Parameter names in option order.
    points : list of list of str
        Value texts per grid point (last parameter varies fastest).
    scales : dict
        Parameter -> ``"log"`` or ``"linear"``.
    """
    if not specs:
        raise SweepError("a sweep needs at least one --set GROUP.KEY=VALUES")
    params, axes, scales = [], [], {}
    for spec in specs:
        name, values, scale = parse_set(spec, base_text)
        if name in params:
            raise SweepError(f"--set {spec}: {name} is set twice")
        params.append(name)
        axes.append(values)
        scales[name] = scale
    return params, [list(p) for p in itertools.product(*axes)], scales


def _changes(params, values) -> dict:
    changes: dict = {}
    for name, value in zip(params, values):
        group, key = name.split(".", 1)
        # An element key such as gravity(3) matches no existing line in override_deck (its
        # parentheses read as a regex group), so it is appended after the array's own line;
        # namelist reads assignments in order, so the element wins.
        changes.setdefault(group, {})[key] = value
    return changes


def _deck_text(base: Path, params, values, id_: str) -> str:
    with tempfile.TemporaryDirectory() as tmp:
        text = override_deck(base, Path(tmp) / "d.nml", _changes(params, values)).read_text()
    what = ", ".join(f"{p} = {v}" for p, v in zip(params, values))
    return (f"! sweep point {id_}: {what}\n"
            f"! (base deck {base.name}; written by `python -m pydriver sweep`)\n" + text)


# --------------------------------------------------------------------------- files


def _write_atomic(path: Path, text: str) -> None:
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write(text)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


@contextlib.contextmanager
def _lock(out: Path):
    """Hold DIR/.sweep.lock: a second sweep writing into the same directory is refused.

    The kernel drops the lock when the process dies, so a killed sweep never blocks a resume.
    """
    try:
        import fcntl
    except ImportError:          # not POSIX: no locking
        yield
        return
    import errno
    with open(out / ".sweep.lock", "w") as fh:
        try:
            fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as exc:
            if exc.errno in (errno.EAGAIN, errno.EACCES):
                raise SweepError(f"{out}: another sweep is running in this directory") from None
            # A file system without locks (some NFS set-ups): run unprotected rather than
            # refuse; the records stay consistent, only concurrent sweeps are not caught.
        yield


def _grid_of(manifest: dict) -> tuple:
    return (manifest["base_sha256"], manifest["params"],
            [p["values"] for p in manifest["points"]])


def prepare(base, sets: list[str], out) -> dict:
    """Expand the grid, validate it and write ``DIR/sweep.json`` and ``DIR/decks/``.

    Parameters
    ----------
    base : str or Path
        Base deck.
    sets : list of str
        ``GROUP.KEY=VALUES`` options (grid syntax in ``GRID_HELP``).
    out : str or Path
        Sweep directory, created if needed.  If it already holds a sweep, its grid and base
        deck must be the same (a resume); decks already written are left untouched.

    Returns
    -------
    dict
        The manifest.

    Raises
    ------
    SweepError
        Bad option (named), first grid point not a valid deck, or ``out`` holding a
        different sweep or other files.
    """
    base, out = Path(base).resolve(), Path(out).resolve()
    if not base.is_file():
        raise SweepError(f"base deck '{base}' not found")
    base_text = base.read_text()
    params, points, scales = expand_grid(list(sets), base_text)
    width = max(4, len(str(len(points) - 1)))
    manifest = {
        "format": "rotorcable-sweep/1",
        "base_deck": str(base),
        "base_sha256": hashlib.sha256(base_text.encode()).hexdigest(),
        "sets": list(sets),
        "params": params,
        "scales": scales,
        "points": [{"id": f"{i:0{width}d}", "values": v} for i, v in enumerate(points)],
        "python": sys.executable,
    }
    # Validate the first grid point before anything is written: unknown groups or keys and
    # malformed values show up there, and the error can name the --set option.
    first = manifest["points"][0]
    with tempfile.TemporaryDirectory() as tmp:
        probe = Path(tmp) / f"{first['id']}.nml"
        probe.write_text(_deck_text(base, params, first["values"], first["id"]))
        try:
            deck_info(probe)
        except DeckError as exc:
            # The option to blame: the one setting the key the deck check names (or, for an
            # unknown group, the one introducing the group).
            bad = [s for s, p in zip(sets, params)
                   if p.split("(")[0] == f"{exc.group}.{exc.key}".lower()
                   or (not exc.key and p.split(".")[0] == exc.group.lower())]
            where = f"--set {bad[0]}" if bad else f"base deck {base.name}"
            raise SweepError(f"{where}: first grid point ({first['id']}: "
                             + ", ".join(f"{p} = {v}" for p, v in zip(params, first["values"]))
                             + f") is not a valid deck: {exc}") from None
    if (out / MANIFEST).is_file():
        old = read_manifest(out)
        if _grid_of(old) != _grid_of(manifest):
            what = ("its base deck differs" if old["base_sha256"] != manifest["base_sha256"]
                    else f"its grid differs (it was {' '.join('--set ' + s for s in old['sets'])})")
            raise SweepError(f"{out} holds another sweep: {what}.  Resume with the same base deck "
                             f"and --set options, or choose a new --out.")
        manifest = old                      # keep the original record of how it was made
    elif out.is_dir() and any(p.name in ("runs", "decks", TABLE) for p in out.iterdir()):
        raise SweepError(f"{out} holds sweep files but no {MANIFEST}; choose a new --out")
    else:
        out.mkdir(parents=True, exist_ok=True)
        _write_atomic(out / MANIFEST, json.dumps(manifest, indent=1) + "\n")
    (out / "decks").mkdir(exist_ok=True)
    (out / "runs").mkdir(exist_ok=True)
    for p in manifest["points"]:
        deck = out / "decks" / f"{p['id']}.nml"
        text = _deck_text(base, params, p["values"], p["id"])
        if not deck.is_file() or deck.read_text() != text:
            _write_atomic(deck, text)
    return manifest


# --------------------------------------------------------------------------- one deck


def run_task(deck, run_dir) -> dict:
    """Run one deck and store its record in ``run_dir``: the task of every engine.

    Parameters
    ----------
    deck : str or Path
        The deck (absolute path when run on a cluster).
    run_dir : str or Path
        Record directory ``DIR/runs/<id>``; it appears complete or not at all.

    Returns
    -------
    dict
        ``{"id", "error", "skipped"}``: ``error`` is None or ``"DeckError: ..."`` /
        ``"RunError: ..."``; ``skipped`` is True when a record already existed.

    Notes
    -----
    Any exception of the run is recorded in ``error.json`` instead of raised, so one failed
    deck does not stop the others.  If two tasks finish the same id (a requeued Slurm task,
    an orphaned worker), the first record stays and the second is discarded.
    """
    deck, run_dir = Path(deck), Path(run_dir)
    done = read_record(run_dir)
    if done is not None:
        return {"id": run_dir.name, "error": done.get("error"), "skipped": True}
    run_dir.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{run_dir.name}.", dir=run_dir.parent))
    try:
        try:
            run_deck(deck, out=tmp)
            error = None
        except Exception as exc:    # recorded, not raised: see Notes
            error = f"{type(exc).__name__}: {exc}"
            _write_atomic(tmp / "error.json", json.dumps(
                {"id": run_dir.name, "deck": str(deck), "error": error}, indent=1) + "\n")
        try:
            os.rename(tmp, run_dir)
        except OSError:
            if read_record(run_dir) is None:
                raise
    finally:
        shutil.rmtree(tmp, ignore_errors=True)      # gone already after the rename
    return {"id": run_dir.name, "error": error, "skipped": False}


def run_point(out, index: int) -> dict:
    """Run grid point ``index`` of the sweep in ``out`` (a Slurm array task).

    Skips the point if it has a record already, so a requeued or repeated task is harmless.
    """
    out = Path(out).resolve()
    manifest = read_manifest(out)
    points = manifest["points"]
    if not 0 <= index < len(points):
        raise SweepError(f"{out}: task index {index} outside the grid 0-{len(points) - 1}")
    id_ = points[index]["id"]
    return run_task(out / "decks" / f"{id_}.nml", out / "runs" / id_)


# --------------------------------------------------------------------------- engines


def _worker_init():
    """Pool worker set-up: ignore Ctrl-C, and exit when the sweep process is gone.

    Ctrl-C reaches the whole process group; the sweep process handles it (cancels the decks
    not started) and the workers finish the deck in hand, so its record is not lost.  A
    worker blocks on its task queue forever if the sweep process is killed (SIGKILL, OOM
    killer); its parent id changes then (re-parented), which a daemon thread notices.
    """
    import signal
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    ppid = os.getppid()

    def watch():
        while os.getppid() == ppid:
            time.sleep(1.0)
        os._exit(1)
    threading.Thread(target=watch, daemon=True).start()


def _mp_context():
    import multiprocessing as mp
    # Not "fork": the parent may hold threads (tqdm's monitor, BLAS, a Dask client), and
    # forking a threaded process can deadlock; its BLAS would also keep the parent's thread
    # count.  forkserver forks workers from a clean single-threaded server; spawn where it
    # is unavailable.
    if "forkserver" not in mp.get_all_start_methods():
        return mp.get_context("spawn")
    ctx = mp.get_context("forkserver")
    # The server imports pydriver once and every worker is a fork of it, instead of each
    # worker importing numpy and the core (~0.3 s start-up per pool).  '__main__' is the
    # default preload, kept.  Takes effect when the server starts (first pool of the process).
    ctx.set_forkserver_preload(["__main__", "pydriver.sweep"])
    return ctx


def default_jobs() -> int:
    """Cores this process may use (respects Slurm/cgroup CPU sets, unlike os.cpu_count())."""
    if hasattr(os, "process_cpu_count"):
        return os.process_cpu_count() or 1
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0)) or 1
    return os.cpu_count() or 1


# Thread-count variables of the BLAS libraries numpy and the Fortran core may link.
BLAS_THREAD_VARS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


@contextlib.contextmanager
def _single_threaded_blas():
    """Environment for starting pool workers: one BLAS thread each, unless the user chose.

    One deck per core already fills the machine, so BLAS threads would only oversubscribe
    it.  It also makes the numbers independent of the engine: a multithreaded OpenBLAS sums
    in another order (differences of ~1e-14 in the frequencies), and Dask's nanny starts its
    workers with these variables set to 1, so the pool does the same.
    """
    saved = {k: os.environ.get(k) for k in BLAS_THREAD_VARS}
    for k in BLAS_THREAD_VARS:
        os.environ.setdefault(k, "1")
    try:
        yield
    finally:
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)


def _run_pool(tasks, jobs, done):
    from concurrent.futures import ProcessPoolExecutor, as_completed
    with _single_threaded_blas(), ProcessPoolExecutor(max_workers=min(jobs, len(tasks)), mp_context=_mp_context(),
                             initializer=_worker_init) as pool:
        # Workers start during these submits (forkserver/spawn start them on demand), so
        # they inherit the single-threaded BLAS environment.
        futures = {pool.submit(run_task, deck, run_dir): id_ for id_, deck, run_dir in tasks}
        try:
            for fut in as_completed(futures):
                done(futures[fut], fut.exception(), fut)
        except KeyboardInterrupt:
            # Cancel what has not started; the decks in flight finish and keep their records.
            pool.shutdown(wait=True, cancel_futures=True)
            raise


def _run_dask(tasks, address, done):
    try:
        from distributed import Client, as_completed
    except ImportError:
        raise SweepError("--dask needs dask.distributed (pip install 'dask[distributed]')") from None
    try:
        client = Client(address, timeout="20s")
    except OSError as exc:
        raise SweepError(f"--dask {address}: cannot connect to the Dask scheduler: {exc}") from None
    token = os.urandom(4).hex()
    try:
        futures = client.map(run_task, [str(d) for _, d, _ in tasks], [str(r) for _, _, r in tasks],
                             key=[f"rotorcable-{id_}-{token}" for id_, _, _ in tasks], pure=False)
        ids = {f.key: id_ for f, (id_, _, _) in zip(futures, tasks)}
        try:
            for fut in as_completed(futures):
                done(ids[fut.key], fut.exception(), fut)
        except KeyboardInterrupt:
            # Dask cannot stop a running task: those finish and write their records.
            client.cancel(futures)
            raise
    finally:
        client.close()


# --------------------------------------------------------------------------- aggregation


@dataclass
class SweepStatus:
    """Outcome of ``run_sweep`` / ``collect``.

    Attributes
    ----------
    out : Path
        Sweep directory.
    n_points : int
        Grid size.
    ran : list of str
        Ids run by this call.
    skipped : list of str
        Ids that had a record already (resume).
    failed : list of str
        Ids whose record is an error (``error`` column of sweep.csv).
    missing : list of str
        Ids without a record (interrupted, lost worker, not yet run).
    interrupted : bool
        The run was stopped by Ctrl-C; rerun the same command to resume.
    lost : dict
        Id -> message for tasks the engine lost (worker crash), not deck failures.
    """

    out: Path
    n_points: int
    ran: list = field(default_factory=list)
    skipped: list = field(default_factory=list)
    failed: list = field(default_factory=list)
    missing: list = field(default_factory=list)
    interrupted: bool = False
    lost: dict = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        """Every grid point has a record and none failed."""
        return not (self.failed or self.missing)

    def line(self) -> str:
        """One-line report."""
        n_ok = self.n_points - len(self.failed) - len(self.missing)
        s = (f"sweep {self.out}: {self.n_points} points, {n_ok} ok, {len(self.failed)} failed, "
             f"{len(self.missing)} missing")
        if self.ran or self.skipped:
            s += f" ({len(self.ran)} run now, {len(self.skipped)} done before)"
        s += f" -> {self.out / TABLE}"
        if self.interrupted:
            s += "; interrupted: rerun the same command to resume"
        elif self.missing:
            s += "; rerun the sweep to run the missing ones"
        return s


def _plot(out: Path, table: dict, params: list, scales: dict):
    """One PNG per (main result, swept parameter) into DIR/plots/; written atomically."""
    from pydriver.plots import _plt, _save_replace
    plt = _plt()
    plots = out / "plots"
    plots.mkdir(exist_ok=True)
    ok = table["error"] == ""
    written = []
    for p in params:
        x = table[p]
        if x.dtype.kind != "f":
            continue                                    # non-numeric parameter (strings)
        others = [q for q in params if q != p]
        groups = sorted({tuple(str(table[q][i]) for q in others) for i in range(len(x))})
        for name in PLOT_RESULTS:
            y = table.get(name)
            if y is None or not np.any(np.isfinite(y[ok])):
                continue
            fig, ax = plt.subplots(figsize=(6.5, 4))
            for g in groups:
                sel = ok & np.array([tuple(str(table[q][i]) for q in others) == g
                                     for i in range(len(x))], dtype=bool)
                order = np.argsort(x[sel])
                label = ", ".join(f"{q} = {v}" for q, v in zip(others, g)) or None
                ax.plot(x[sel][order], y[sel][order], "o-", ms=3, label=label)
            if scales.get(p) == "log":
                ax.set_xscale("log")
            ax.set_xlabel(p)
            ax.set_ylabel(name)
            ax.grid(True)
            if others and len(groups) <= 8:
                ax.legend(fontsize=7)
            fig.suptitle(f"{name} against {p}", fontsize=10)
            # File names without the parentheses of element keys (loads.gravity(3)).
            final = plots / (re.sub(r"[^\w.-]", "_", f"{name}_vs_{p}") + ".png")
            _save_replace(fig, final)
            written.append(final)
    return written


def collect(out, plots: bool = True) -> SweepStatus:
    """Aggregate the records of a sweep into ``DIR/sweep.csv`` (and plots).

    Parameters
    ----------
    out : str or Path
        Sweep directory.
    plots : bool
        Also draw ``DIR/plots/<result>_vs_<parameter>.png`` (matplotlib).

    Returns
    -------
    SweepStatus
        With ``failed`` and ``missing`` filled in.

    Notes
    -----
    ``sweep.csv`` is rebuilt from ``runs/*`` each time and replaced atomically, so it always
    holds exactly one row per finished run, sorted by id.  Safe to run while tasks are still
    running (e.g. a Slurm array): it shows what has finished.
    """
    out = Path(out).resolve()
    manifest = read_manifest(out)
    columns, rows = sweep_rows(out, manifest)
    _write_atomic(out / TABLE, table_csv_text(columns, rows))
    done = {r["id"] for r in rows}
    status = SweepStatus(out=out, n_points=len(manifest["points"]),
                         failed=[r["id"] for r in rows if r["error"]],
                         missing=[p["id"] for p in manifest["points"] if p["id"] not in done])
    if plots and rows:
        _plot(out, rows_to_table(columns, rows, manifest["params"]), manifest["params"],
              manifest.get("scales", {}))
    return status


def _progress(total, initial, enabled):
    if enabled and sys.stderr.isatty():
        try:
            from tqdm import tqdm
            return tqdm(total=total, initial=initial, unit="run", desc="sweep", smoothing=0.1)
        except ImportError:
            pass
    return None


def run_sweep(base, sets: list[str], out, *, jobs: int | None = None, dask: str | None = None,
              progress: bool = True, plots: bool = True, retry_failed: bool = False) -> SweepStatus:
    """Run a grid of decks and aggregate their results into ``DIR/sweep.csv``.

    Parameters
    ----------
    base : str or Path
        Base deck.
    sets : list of str
        ``GROUP.KEY=VALUES`` specs (``GRID_HELP``); several span the Cartesian product.
    out : str or Path
        Sweep directory.  Rerunning into the same directory with the same base deck and
        options resumes: decks with a record are not run again.
    jobs : int, optional
        Worker processes of the local pool (default: the cores this process may use).
    dask : str, optional
        Address of a running Dask scheduler (``tcp://host:8786``): the decks run as Dask
        tasks instead of a local pool.  ``out`` must be on a file system the workers share.
    progress : bool
        Show a tqdm progress bar (only on a terminal).
    plots : bool
        Draw ``DIR/plots/`` after the runs.
    retry_failed : bool
        Run the decks whose record is an error again (e.g. after fixing the cause).

    Returns
    -------
    SweepStatus

    Raises
    ------
    SweepError
        Bad option, invalid first grid point, or ``out`` holding another sweep.

    Notes
    -----
    Ctrl-C stops the sweep cleanly: decks not started are cancelled, the ones running
    finish, ``sweep.csv`` is written for what finished and ``interrupted`` is set.  A hard
    kill loses at most the decks in flight; their records are simply missing and the next
    run makes them.
    """
    out = Path(out).resolve()
    manifest = prepare(base, sets, out)
    with _lock(out):
        runs = out / "runs"
        for stale in runs.glob(".*"):
            # Temporary directories of runs killed before finishing; under the lock nothing
            # of this sweep is running, so they are dead.
            shutil.rmtree(stale, ignore_errors=True)
        tasks, skipped = [], []
        for p in manifest["points"]:
            id_ = p["id"]
            rec = read_record(runs / id_)
            if rec is not None and "error" in rec and retry_failed:
                shutil.rmtree(runs / id_)
                rec = None
            if rec is None:
                tasks.append((id_, out / "decks" / f"{id_}.nml", runs / id_))
            else:
                skipped.append(id_)
        lost = {}
        bar = _progress(len(manifest["points"]), len(skipped), progress)

        def done(id_, exc, fut):
            if exc is not None:
                lost[id_] = f"{type(exc).__name__}: {exc}"
            if bar is not None:
                bar.update(1)
        interrupted = False
        try:
            if tasks and dask:
                _run_dask(tasks, dask, done)
            elif tasks:
                _run_pool(tasks, jobs or default_jobs(), done)
        except KeyboardInterrupt:
            interrupted = True
        finally:
            if bar is not None:
                bar.close()
        status = collect(out, plots=plots)
    # From the records, not the callbacks: decks that finish while an interrupted pool shuts
    # down count too.
    have = set(skipped) | set(status.missing)
    status.ran = [p["id"] for p in manifest["points"] if p["id"] not in have]
    status.skipped = skipped
    status.interrupted, status.lost = interrupted, lost
    return status


# --------------------------------------------------------------------------- Slurm


def _array_spec(indices: list[int]) -> str:
    """Slurm --array text for a sorted index list: 0-23, or 3,7-9 for a partial resume."""
    parts = []
    for _, grp in itertools.groupby(enumerate(indices), lambda t: t[1] - t[0]):
        g = [i for _, i in grp]
        parts.append(str(g[0]) if len(g) == 1 else f"{g[0]}-{g[-1]}")
    return ",".join(parts)


def write_slurm(base, sets: list[str], out) -> tuple[Path, list[str]]:
    """Write the decks, the manifest and a Slurm job-array script ``DIR/sweep.slurm``.

    Nothing is run.  Array task ``i`` runs grid point ``i`` with
    ``python -m pydriver sweep-task DIR i`` (the same ``run_task`` as the local pool), in
    the Python environment of ``sys.executable``; points that already have a record are
    left out of the array.

    Parameters
    ----------
    base, sets, out
        As for ``run_sweep``.

    Returns
    -------
    script : Path
        ``DIR/sweep.slurm``.
    commands : list of str
        The ``sbatch`` command and the aggregation command to run afterwards.
    """
    import shlex
    out = Path(out).resolve()
    manifest = prepare(base, sets, out)
    todo = [i for i, p in enumerate(manifest["points"])
            if read_record(out / "runs" / p["id"]) is None]
    (out / "slurm").mkdir(exist_ok=True)
    py = sys.executable
    q = shlex.quote
    venv = ""
    if sys.prefix != sys.base_prefix:
        venv = f"source {q(str(Path(sys.prefix) / 'bin' / 'activate'))}\n"
    collect_cmd = f"{q(py)} -m pydriver sweep-collect {q(str(out))}"
    array = _array_spec(todo) if todo else "0"
    script = f"""#!/bin/bash
# rotorcable sweep {out.name}: one deck per array task ({len(todo)} of {len(manifest['points'])} points).
# Written by `python -m pydriver sweep --slurm`; add the #SBATCH lines your site needs
# (--partition, --account, --time) before submitting.  DIR must be on a shared file system.
#   submit:                 sbatch {out / 'sweep.slurm'}
#   when all tasks are done: {collect_cmd}
#SBATCH --job-name=rc-sweep-{out.name}
#SBATCH --array={array}
#SBATCH --ntasks=1
#SBATCH --cpus-per-task=1
#SBATCH --output={out / 'slurm'}/%A_%a.out
set -eo pipefail
{venv}# One core per task: keep BLAS single-threaded.
export OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1
{q(py)} -m pydriver sweep-task {q(str(out))} "$SLURM_ARRAY_TASK_ID"
"""
    path = out / "sweep.slurm"
    _write_atomic(path, script)
    path.chmod(0o755)
    return path, [f"sbatch {q(str(path))}", collect_cmd]
