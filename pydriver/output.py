"""Result files: summary.json, table.txt/.csv (thesis appendix layout), timeseries.csv or
timeseries.h5, modes.csv; all of one run in one directory, complete or not at all.

A run writes into a temporary sibling directory and swaps it into place when everything is
written (:class:`RunDirectory`): a failure, an interrupt or a kill never leaves a partial or
mixed directory, and files of an earlier run (another analysis, another deck) never survive
beside the new ones.  Time series are streamed in chunks (:class:`TimeseriesWriter`), never
built as one text in memory; large ones go to HDF5 (h5py), which every analysis tool reads.
"""

from __future__ import annotations

import ctypes
import errno
import json
import os
import shutil
import tempfile
from pathlib import Path

import numpy as np

#: Time series with more values than this go to HDF5 when the deck asks for 'auto'.
CSV_MAX_VALUES = 5_000_000


def _renameat2_exchange(a: Path, b: Path) -> bool:
    """Atomically exchange two paths (Linux renameat2 RENAME_EXCHANGE); False if unsupported."""
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        fn = libc.renameat2
    except (OSError, AttributeError):
        return False
    at_fdcwd, rename_exchange = -100, 2
    rc = fn(at_fdcwd, os.fsencode(str(a)), at_fdcwd, os.fsencode(str(b)), rename_exchange)
    if rc == 0:
        return True
    err = ctypes.get_errno()
    if err in (errno.ENOSYS, errno.EINVAL, errno.ENOTSUP):
        return False
    raise OSError(err, os.strerror(err), str(b))


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


class RunDirectory:
    """A run's output directory, written in a temporary sibling and swapped in at the end.

    Use as a context manager: on success ``commit`` swaps it in; on any exception the
    temporary directory is removed and the old output stays as it was.
    """

    def __init__(self, out):
        self.out = Path(out)
        parent = self.out.parent
        parent.mkdir(parents=True, exist_ok=True)
        self._clean_stale(parent)
        self.tmp = Path(tempfile.mkdtemp(prefix=f".{self.out.name}.tmp-{os.getpid()}-", dir=parent))
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(self.tmp, 0o777 & ~umask)        # mkdtemp makes 0700; a result is for others too
        self.committed = False

    def _clean_stale(self, parent: Path):
        """Remove temporaries of earlier runs into the same directory whose process is gone
        (a run killed with SIGKILL cannot clean up after itself)."""
        for p in parent.glob(f".{self.out.name}.tmp-*"):
            try:
                pid = int(p.name.rsplit(".tmp-", 1)[1].split("-")[0])
            except (IndexError, ValueError):
                continue
            if not _pid_alive(pid):
                shutil.rmtree(p, ignore_errors=True)
        for p in parent.glob(f".{self.out.name}.old-*"):
            shutil.rmtree(p, ignore_errors=True)

    def path(self, name: str) -> Path:
        """Where to write the file ``name`` of this run."""
        return self.tmp / name

    def commit(self) -> Path:
        """Put the finished directory in place of ``out`` (atomically where Linux allows)."""
        if self.out.is_symlink() or (self.out.exists() and not self.out.is_dir()):
            raise OSError(errno.EEXIST, "exists and is not a directory", str(self.out))
        if self.out.exists():
            if _renameat2_exchange(self.tmp, self.out):
                shutil.rmtree(self.tmp, ignore_errors=True)      # now holds the old run
            else:
                old = self.out.parent / f".{self.out.name}.old-{os.getpid()}"
                os.rename(self.out, old)
                os.rename(self.tmp, self.out)
                shutil.rmtree(old, ignore_errors=True)
        else:
            os.rename(self.tmp, self.out)
        self.committed = True
        return self.out

    def abort(self):
        shutil.rmtree(self.tmp, ignore_errors=True)

    def __enter__(self):
        return self

    def __exit__(self, exc_type, exc, tb):
        if exc_type is not None or not self.committed:
            self.abort()
        return False


def _fmt(x: float) -> str:
    return repr(float(x))


class TimeseriesWriter:
    """Streams time-series rows (chunks of columns) to CSV or HDF5."""

    def __init__(self, path: Path, columns: list[str], fmt: str):
        self.columns = columns
        self.fmt = fmt
        self.path = path
        self.rows = 0
        if fmt == "hdf5":
            import h5py
            # No chunk cache: rows are appended once, in order, so caching chunks only grows
            # memory (h5py's per-dataset cache, measured 500 -> 52 MiB for 1e6 x 140 values).
            self._h5 = h5py.File(path, "w", rdcc_nbytes=0)
            self._h5.attrs["columns"] = json.dumps(columns)
            self._sets = {c: self._h5.create_dataset(c, shape=(0,), maxshape=(None,), dtype="f8",
                                                     chunks=(16384,)) for c in columns}
        else:
            self._fh = open(path, "w", encoding="utf-8", newline="\n")
            self._fh.write(",".join(columns) + "\n")

    def write(self, chunk: dict):
        n = len(chunk[self.columns[0]])
        if self.fmt == "hdf5":
            for c in self.columns:
                ds = self._sets[c]
                ds.resize((self.rows + n,))
                ds[self.rows:] = chunk[c]
        else:
            data = np.column_stack([np.asarray(chunk[c], float) for c in self.columns])
            self._fh.write("".join(",".join(map(_fmt, row)) + "\n" for row in data))
        self.rows += n

    def close(self):
        if self.fmt == "hdf5":
            self._h5.close()
        else:
            self._fh.close()


def read_timeseries(path: Path) -> dict:
    """The columns of a timeseries.csv or timeseries.h5 as numpy arrays."""
    path = Path(path)
    if path.suffix == ".h5":
        import h5py
        with h5py.File(path, "r") as h5:
            return {c: h5[c][:] for c in json.loads(h5.attrs["columns"])}
    return read_csv(path)


def read_csv(path: Path) -> dict:
    """The columns of a CSV file written here (numbers only)."""
    with open(path, encoding="utf-8") as fh:
        names = fh.readline().strip().split(",")
        data = np.loadtxt(fh, delimiter=",", ndmin=2) if names != [""] else np.zeros((0, 0))
    if data.size == 0:
        return {n: np.zeros(0) for n in names}
    return {n: data[:, i] for i, n in enumerate(names)}


def format_table(result) -> str:
    """The equilibrium table in the layout of the thesis's Tables A.3-A.6.

    Columns: Körper, gamma_i [°], beta_i [°] (2 decimals), x, y, z [m] (4 decimals), and a
    caption line with the case and the bending spring c_y (German decimal comma as printed).
    """
    s = result.summary
    t = result.table
    lines = [f"{'Körper':>6}  {'γ_i [°]':>8}  {'β_i [°]':>8}  {'x [m]':>8}  {'y [m]':>8}  {'z [m]':>8}"]
    for i in range(len(t["body"])):
        lines.append(f"{int(t['body'][i]):>6}  {t['gamma_deg'][i]:8.2f}  {t['beta_deg'][i]:8.2f}  "
                     f"{t['x_m'][i]:8.4f}  {t['y_m'][i]:8.4f}  {t['z_m'][i]:8.4f}")
    cy = f"{s.get('c_beta_Nm_per_rad', 0.0):.2f}".replace(".", ",")
    lines.append("")
    what = "Ruhelage" if "hover" in s["case"] else "Statische Ruhelage"
    lines.append(f"Tabelle: {what} {s['case']}, c_y = {cy} Nm/rad")
    return "\n".join(lines) + "\n"


def _cell(value, integer: bool) -> str:
    """One CSV cell; None (e.g. the life of a joint that takes no damage) is an empty cell."""
    if value is None:
        return ""
    if isinstance(value, str):                     # a name: quoted as RFC 4180 wants
        return '"' + value.replace('"', '""') + '"' if any(c in value for c in ',"\n') else value
    return str(int(value)) if integer else _fmt(value)


def _write_csv(path: Path, columns: dict, int_columns=("body", "mode", "joint")):
    names = list(columns)
    with open(path, "w", encoding="utf-8", newline="\n") as fh:
        fh.write(",".join(names) + "\n")
        n = len(columns[names[0]]) if names else 0
        for i in range(n):
            fh.write(",".join(_cell(columns[c][i], c in int_columns) for c in names) + "\n")


def write_files(result, run_dir: RunDirectory, plots: bool = False) -> None:
    """Write every file of a result into the run directory (before commit); summary.json last,
    so that wherever it exists the run's other files do too."""
    if result.table is not None:
        run_dir.path("table.txt").write_text(format_table(result), encoding="utf-8")
        _write_csv(run_dir.path("table.csv"), result.table)
        result.files["table.txt"] = run_dir.out / "table.txt"
        result.files["table.csv"] = run_dir.out / "table.csv"
    if result.timeseries is not None and not run_dir.path("timeseries.csv").exists() \
            and not run_dir.path("timeseries.h5").exists():
        writer = TimeseriesWriter(run_dir.path("timeseries.csv"), list(result.timeseries), "csv")
        writer.write(result.timeseries)
        writer.close()
        result.files["timeseries.csv"] = run_dir.out / "timeseries.csv"
    if result.modes is not None:
        _write_csv(run_dir.path("modes.csv"), result.modes)
        result.files["modes.csv"] = run_dir.out / "modes.csv"
    for name, columns in result.extra.get("tables", {}).items():
        _write_csv(run_dir.path(name), columns)
        result.files[name] = run_dir.out / name
    if plots:
        from pydriver.plots import plot_result
        for name in plot_result(result, run_dir.tmp):
            result.files[name] = run_dir.out / name
    (run_dir.path("summary.json")).write_text(json.dumps(result.summary, indent=2, allow_nan=False) + "\n",
                                              encoding="utf-8")
    result.files["summary.json"] = run_dir.out / "summary.json"


def write_result(result, out, plots: bool = False) -> list[Path]:
    """Write all files of a result into ``out`` as one unit; return the final paths."""
    with RunDirectory(out) as run_dir:
        write_files(result, run_dir, plots)
        run_dir.commit()
    return sorted(result.files.values())
