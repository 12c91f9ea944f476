"""Execution engines of a sweep: a local process pool, a Dask scheduler, a Slurm job array.

All three run the same per-deck task, :func:`pydriver.sweep.records.run_task`, on the decks
of a prepared sweep directory.  The pool and Dask engines take ``tasks`` as
``(id, deck, run_dir)`` tuples and report each finished task to ``done(id, exception, future)``.

The Slurm script ``DIR/sweep.slurm`` is read by two programs, each with its own rules, and
every path is written for the one that reads its line:

* bash runs the commands: there every path is quoted with :func:`shlex.quote`.
* sbatch reads the ``#SBATCH`` lines itself, before any shell (``get_argument`` in Slurm's
  ``src/sbatch/opt.c``): it splits them at white space, groups quoted text, takes a backslash
  as an escape and an unquoted ``#`` as the start of a comment (older versions: a ``#`` inside
  quotes too), and expands nothing.  A path there is put in double quotes with ``\\``, ``"``
  and ``#`` escaped.  The ``--output`` value is also a filename pattern: ``%%`` stands for
  ``%``, and a backslash anywhere turns every replacement off (``%A_%a`` would stay as it is),
  so an ``--out`` with a backslash is refused.

No path may hold a control character (:mod:`pydriver.sweep.given_paths`): a newline in a
comment or ``#SBATCH`` line starts a new line, which bash runs as a command (issue 20).
"""

from __future__ import annotations

import contextlib
import itertools
import os
import re
import shlex
import sys
from pathlib import Path

from pydriver.sweep import lifeline
from pydriver.sweep.directory import open_sweep
from pydriver.sweep.errors import SweepError
from pydriver.sweep.faults import writing
from pydriver.sweep.given_paths import checked_path, refuse_control_characters
from pydriver.sweep.layout import write_file
from pydriver.sweep.records import read_record, run_task

# Thread-count variables of the BLAS libraries numpy and the Fortran core may link.
BLAS_THREAD_VARS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


def default_jobs() -> int:
    """Cores this process may use (respects Slurm/cgroup CPU sets, unlike os.cpu_count())."""
    if hasattr(os, "process_cpu_count"):
        return os.process_cpu_count() or 1
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0)) or 1
    return os.cpu_count() or 1


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
    # worker importing numpy and the core (~0.3 s start-up per pool); the preload module also
    # ties the server to this process (lifeline).  '__main__' is the default preload, kept.
    # Takes effect when the server starts (first pool of the process).
    ctx.set_forkserver_preload(["__main__", "pydriver.sweep.forkserver_preload"])
    return ctx


def run_pool(tasks: list, jobs: int, done, maker: str = "run") -> None:
    """Run the tasks on a local pool of ``jobs`` worker processes (one deck per task; ``maker``:
    what each record holds, :data:`pydriver.sweep.records.MAKERS`).

    Ctrl-C cancels the decks not started; the ones running finish and keep their records, then
    KeyboardInterrupt is raised again.  Workers die with this process (:mod:`lifeline`).
    """
    from concurrent.futures import ProcessPoolExecutor, as_completed
    with _single_threaded_blas(), lifeline.sweep_process_mark(), \
            ProcessPoolExecutor(max_workers=min(jobs, len(tasks)), mp_context=_mp_context(),
                                initializer=lifeline.worker_init) as pool:
        # Workers start during these submits (forkserver/spawn start them on demand), so
        # they inherit the environment set above.
        futures = {pool.submit(run_task, deck, run_dir, maker): id_ for id_, deck, run_dir in tasks}
        try:
            for fut in as_completed(futures):
                done(futures[fut], fut.exception(), fut)
        except KeyboardInterrupt:
            pool.shutdown(wait=True, cancel_futures=True)
            raise


def run_dask(tasks: list, address: str, done, maker: str = "run") -> None:
    """Run the tasks on the Dask scheduler at ``address`` (workers share the file system;
    ``maker`` as for :func:`run_pool`).

    Raises
    ------
    SweepError
        dask.distributed missing, or no scheduler at ``address``.
    """
    try:
        from distributed import Client, as_completed
    except ImportError:
        raise SweepError("--dask needs dask.distributed (pip install 'dask[distributed]')") from None
    try:
        # 20 s: a scheduler on a busy login node may take seconds to answer; a wrong address
        # should still fail before the user gives up on it.
        client = Client(address, timeout="20s")
    except OSError as exc:
        raise SweepError(f"--dask {address}: cannot connect to the Dask scheduler: {exc}") from None
    token = os.urandom(4).hex()
    try:
        futures = client.map(run_task, [str(d) for _, d, _ in tasks], [str(r) for _, _, r in tasks],
                             [maker] * len(tasks), key=[f"rotorcable-{id_}-{token}" for id_, _, _ in tasks],
                             pure=False)
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


SCRIPT = "sweep.slurm"


def _array_spec(indices: list[int]) -> str:
    """Slurm --array text for a sorted index list: 0-23, or 3,7-9 for a partial resume."""
    parts = []
    for _, grp in itertools.groupby(enumerate(indices), lambda t: t[1] - t[0]):
        g = [i for _, i in grp]
        parts.append(str(g[0]) if len(g) == 1 else f"{g[0]}-{g[-1]}")
    return ",".join(parts)


def sbatch_quote(value: str) -> str:
    """``value`` as one argument of an ``#SBATCH`` line (sbatch's own parsing: module doc).

    Parameters
    ----------
    value : str
        The argument or option value, e.g. ``/a b/%A.out``; no control characters.

    Returns
    -------
    str
        ``value`` in double quotes, with ``\\``, ``"`` and ``#`` escaped by a backslash: sbatch
        reads it back as ``value``, also after ``--output=`` (quotes may open mid-argument).
    """
    return '"' + re.sub(r'([\\"#])', r"\\\1", value) + '"'


def output_pattern(directory: Path) -> str:
    """The ``#SBATCH --output`` filename pattern of the array tasks' logs in ``directory``.

    Parameters
    ----------
    directory : Path
        Absolute directory of the logs (``DIR/slurm``).

    Returns
    -------
    str
        ``directory/%A_%a.out`` with every ``%`` of ``directory`` doubled (Slurm reads ``%%``
        as ``%``), still to be quoted for sbatch (:func:`sbatch_quote`).

    Raises
    ------
    SweepError
        ``directory`` holds a backslash: Slurm would then leave ``%A_%a`` unexpanded.
    """
    text = str(directory)
    if "\\" in text:
        raise SweepError(f"--out {text}: a backslash in the path cannot be written into the "
                         "#SBATCH --output line (Slurm then expands no %A_%a and drops the "
                         "backslashes); choose a path without one")
    return text.replace("%", "%%") + "/%A_%a.out"


def _job_name(out: Path) -> str:
    # Only letters, digits and ._-: a job name is cosmetic, and this one needs no quoting.
    return "rc-sweep-" + re.sub(r"[^A-Za-z0-9_.-]", "_", out.name)


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
        The ``sbatch`` command and the aggregation command to run afterwards (shell-quoted).

    Raises
    ------
    SweepError
        As ``run_sweep``; also an ``--out`` with a backslash, or an interpreter path with a
        control character.  Every path is checked before anything is written.
    """
    out = checked_path(out, "--out", link_ok=False)
    output_pattern(out / "slurm")                        # refused before anything is written
    refuse_control_characters(sys.executable, "Python interpreter")
    collect_cmd = f"{shlex.quote(sys.executable)} -m pydriver sweep-collect {shlex.quote(str(out))}"
    with open_sweep(base, sets, out) as manifest:
        return write_array_script(out, manifest, "sweep", collect_cmd)


def write_array_script(out: Path, manifest: dict, what: str, collect_cmd: str) -> tuple[Path, list[str]]:
    """Write ``DIR/sweep.slurm``, the job array of the points of ``manifest`` without a record,
    for a caller that holds the directory's lock and has written its decks (:func:`write_slurm`,
    a usage spectrum's :func:`pydriver.sweep.spectrum.write_spectrum_slurm`).

    Parameters
    ----------
    out : Path
        The directory (checked: :func:`checked_path`).
    manifest : dict
        Its manifest.
    what : str
        What the points are, for the script's first comment (``"sweep"``, ``"spectrum"``).
    collect_cmd : str
        The shell command that aggregates the records when every task is done.

    Returns
    -------
    script, commands
        As :func:`write_slurm`.
    """
    logs = out / "slurm"
    output = output_pattern(logs)
    q = shlex.quote
    py = sys.executable
    refuse_control_characters(py, "Python interpreter")
    venv = ""
    if sys.prefix != sys.base_prefix:
        activate = str(Path(sys.prefix) / "bin" / "activate")
        refuse_control_characters(activate, "virtual environment")
        venv = f"source {q(activate)}\n"
    path = out / SCRIPT
    submit_cmd = f"sbatch {q(str(path))}"
    todo = [i for i, p in enumerate(manifest["points"])
            if read_record(out / "runs" / p["id"]) is None]
    array = _array_spec(todo) if todo else "0"
    script = f"""#!/bin/bash
# rotorcable {what} {out.name}: one deck per array task ({len(todo)} of {len(manifest['points'])} points).
# Written by `python -m pydriver {what} --slurm`; add the #SBATCH lines your site needs
# (--partition, --account, --time) before submitting.  DIR must be on a shared file system.
#   submit:                  {submit_cmd}
#   when all tasks are done: {collect_cmd}
#SBATCH --job-name={_job_name(out)}
#SBATCH --array={array}
#SBATCH --ntasks=1
#SBATCH --cpus-per-task=1
#SBATCH --output={sbatch_quote(output)}
set -eo pipefail
{venv}# One core per task: keep BLAS single-threaded.
export OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1
{q(py)} -m pydriver sweep-task {q(str(out))} "$SLURM_ARRAY_TASK_ID"
"""
    with writing(path):
        logs.mkdir(exist_ok=True)
        write_file(out, SCRIPT, script, mode=0o777)   # executable, as far as the umask allows
    return path, [submit_cmd, collect_cmd]
