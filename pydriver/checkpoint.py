"""Checkpoints of dynamic runs, and continuing a finished run from one (issue 22 item 5,
issue 35).

A dynamic run integrates in segments: ``&solver checkpoint_interval`` (default 0: one segment,
the whole run) cuts it every interval / dt_out samples, where IDA is started afresh from the
state reached (as at a pulse edge: its step history restarts).  The run's directory gets
``checkpoint.npz`` (NumPy's own binary format: float64 bit for bit) with the state (t, q, v) at
its end, the deck's validated values and the format's version.

``rotorcable run DECK --restart DIR`` (``run_deck(deck, restart=DIR)``) continues the run of
``DIR`` from its end to the new deck's ``t_end``: the new deck must describe the same model
(every key equal but ``&solver t_end``, the output format and the case's name and text), the
time series of ``DIR`` is read back, and the continuation starts IDA afresh at the checkpoint.
When the uninterrupted run with the same interval starts IDA afresh at that very instant the
continuation makes exactly its calls and reproduces it bit for bit (sample times are counted in
whole steps of the decimal ``dt_out``: :mod:`pydriver.analyses.output_grid`); otherwise the
summary says so, with a warning.  The continuation's files hold the whole run from t = 0.

Everything in ``DIR`` is input like a deck, and is checked as one before anything is computed
(:func:`continuation`): a file that cannot be read, an array of the wrong kind, shape or size,
a non-finite or impossible time, a stored deck that is not the deck of this model, a time
series cut short or with rows missing, a state that is not the one the time series ends with
or that leaves the constraints: each is a :class:`CheckpointError` naming the file and what is
wrong with it.  Nothing in ``DIR`` is written or deleted (a continuation writes to its own
output directory, which may be ``DIR`` itself as one earlier run of its own).
"""

from __future__ import annotations

import json
import math
import warnings
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from pydriver.analyses.registry import analysis_of
from pydriver.errors import DeckError, RunError

FILE = "checkpoint.npz"
#: Format of checkpoint.npz.  2: the sample times of the time series beside it are counted in
#: decimal steps of dt_out (issue 35), which version 1's were not.
VERSION = 2
#: Keys that may differ between a run and its continuation.
FREE_KEYS = {("solver", "t_end"), ("solver", "output_format"), ("case", "name"), ("case", "description"),
             ("output", "table_language")}
#: The time series a dynamic run writes beside its checkpoint (one of them).
RECORDS = ("timeseries.csv", "timeseries.h5")
#: Largest checkpoint.npz read [bytes].  One written here holds two float64 vectors of the
#: coordinates and the deck's JSON (a few kB for the decks in inputs/; 1.6 MB for 10^5
#: coordinates): anything far larger is not one, and is refused before it is loaded.
MAX_BYTES = 64 * 2 ** 20
#: Relative tolerance of the checkpoint's state against the last row of its time series.  The
#: row holds the same doubles times 180/pi (one rounding, identical on any IEEE machine),
#: written with repr (17 significant digits: a double's exact round trip) or as float64 in
#: HDF5, so the two agree to the bit; 1e-12 (some 4500 ulp) leaves room for a time series
#: written with fewer digits (15 give 5e-16) and still refuses a change of 1e-11 rad in a
#: coordinate of one radian.
STATE_RTOL = 1e-12
#: What each array of the file must be: (numpy dtype kinds, number of dimensions).
_ARRAYS = {"version": ("iu", 0), "t": ("f", 0), "q": ("f", 1), "v": ("f", 1), "deck": ("U", 0)}


class CheckpointError(DeckError):
    """A ``--restart`` directory that cannot be continued: names the deck that asked, the
    directory, the file and what is wrong with it (a :class:`DeckError`: bad input)."""

    def __init__(self, deck: str, directory, file: str, reason: str):
        self.deck, self.group, self.key, self.reason = deck, "", "", reason
        self.directory, self.file = str(directory), file
        ValueError.__init__(self, f"deck '{deck}': --restart {directory}: {file}: {reason}")

    def __reduce__(self):
        return (CheckpointError, (self.deck, self.directory, self.file, self.reason))


@dataclass
class Checkpoint:
    """The end state of a dynamic run, and (once checked by :func:`continuation`) the time
    series it ends: ``record`` (columns up to and including t) from the file ``record_file``."""

    t: float
    q: np.ndarray
    v: np.ndarray
    deck_values: dict
    directory: Path
    record: dict | None = field(default=None, repr=False)
    record_file: str | None = None


def _plain(values: dict) -> dict:
    """Validated deck values as JSON-able plain data (arrays as lists)."""
    out = {}
    for group, keys in values.items():
        out[group] = {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in keys.items()}
    return out


def write(path: Path, model, t: float, q: np.ndarray, v: np.ndarray) -> None:
    """Write ``checkpoint.npz`` of a finished dynamic run (into its temporary directory)."""
    deck = json.dumps(_plain(model.deck.values), sort_keys=True)
    with open(path, "wb") as fh:
        np.savez(fh, version=np.array(VERSION), t=np.array(float(t)), q=np.asarray(q, float),
                 v=np.asarray(v, float), deck=np.array(deck))


def continuation(model, directory) -> Checkpoint:
    """The checkpoint of the run in ``directory``, checked as the start of a continuation of it
    by ``model``'s deck, with the run's time series read back (``Checkpoint.record``).

    Checks, in this order: the file (a zip of exactly the arrays written, each of its dtype and
    shape, finite, of this format's version); its stored deck (a JSON object of groups, equal to
    this deck in every key both ways but :data:`FREE_KEYS`, its ``t_end`` the checkpoint's t);
    the time series beside it (one file, readable, this model's columns, finite, exactly the
    sample times of the run up to t, none missing, none added); the state against the time
    series' last row (:data:`STATE_RTOL`) and against the constraints (:func:`check_state`).

    Raises
    ------
    CheckpointError
        Anything wrong with the files of ``directory``, naming the file.
    DeckError
        This deck cannot continue that run (another model, an earlier ``t_end``, another
        analysis): naming this deck's group and key.
    """
    from pydriver.analyses.record_columns import column_names
    from pydriver.analyses.output_grid import output_grid

    if not analysis_of(model).restartable:           # before the files: their sizes are a dynamic run's
        model.deck.fail("case", "analysis", "--restart continues a run with a checkpoint (a dynamic run); this deck's analysis is "
                                            f"'{model.analysis}'")
    ck = read(directory, model)
    check_same_model(model, ck)
    s = model.deck.values["solver"]
    try:
        times, _ = output_grid(s["t_end"], s["dt_out"], s["checkpoint_interval"], ck.t)
    except ValueError as exc:
        model.deck.fail("solver", "t_end", f"--restart {ck.directory}: the run there ended at a time that is not "
                                           f"one of this deck's samples ({exc})")
    n_rows = int(np.searchsorted(times, ck.t)) + 1
    ck.record_file, ck.record = source_record(model, ck, column_names(model), times[:n_rows])
    check_state(model, ck)
    return ck


def read(directory, model) -> Checkpoint:
    """The checkpoint of the run in ``directory``, its arrays checked against ``model``
    (a :class:`pydriver.model.Model`): structure, dtypes, shapes, finiteness, version, the
    stored deck's JSON type.  Whether it is the same model is :func:`check_same_model`'s.

    Raises
    ------
    CheckpointError
        No checkpoint there, or one that is not a checkpoint of a run of this model's size.
    """
    directory = Path(directory)
    path = directory / FILE

    def fail(reason):
        return CheckpointError(model.name, directory, FILE, reason)

    if not path.is_file():
        raise fail("not found (only a finished dynamic run writes one)")
    arrays = _load(path, model.nq, fail)
    version = int(arrays["version"])
    if version != VERSION:
        raise fail(f"format version {version}; this version of rotorcable reads version {VERSION} "
                   "(an earlier version wrote it, or it was edited): run the source run again")
    t = float(arrays["t"])
    if not math.isfinite(t) or t <= 0.0:
        raise fail(f"t = {t!r} s: a run ends at a finite time after its start at 0")
    for name in ("q", "v"):
        bad = np.flatnonzero(~np.isfinite(arrays[name]))
        if bad.size:
            raise fail(f"{name}[{bad[0]}] = {float(arrays[name][bad[0]])!r}: a state holds finite numbers only")
    try:
        deck = json.loads(str(arrays["deck"]))
    except (ValueError, RecursionError) as exc:
        raise fail(f"its deck is not JSON ({exc})") from None
    if not isinstance(deck, dict) or not all(isinstance(g, dict) for g in deck.values()):
        raise fail(f"its deck is a JSON {type(deck).__name__}, not an object of namelist groups")
    if not deck or not any(deck.values()):
        raise fail("its deck is empty: the model of the run cannot be compared with this deck's")
    return Checkpoint(t=t, q=arrays["q"], v=arrays["v"], deck_values=deck, directory=directory)


def _load(path: Path, nq: int, fail) -> dict:
    """The arrays of ``checkpoint.npz``, each header checked before its data is read."""
    expect = {"version": (), "t": (), "q": (nq,), "v": (nq,), "deck": ()}
    try:
        size = path.stat().st_size
        if size > MAX_BYTES:
            raise fail(f"{size} bytes: far more than a checkpoint holds (at most {MAX_BYTES} read)")
        with zipfile.ZipFile(path) as zf:
            members = zf.namelist()
            names = {m.removesuffix(".npy") for m in members}
            missing = [n for n in _ARRAYS if n not in names]
            if missing:
                raise fail(f"lacks the array{'s' if len(missing) > 1 else ''} {', '.join(missing)}")
            if len(members) != len(_ARRAYS) or names != set(_ARRAYS):
                raise fail(f"holds {', '.join(sorted(members))}; a checkpoint holds exactly "
                           f"{', '.join(f'{n}.npy' for n in _ARRAYS)}")
            arrays = {}
            for name, (kinds, ndim) in _ARRAYS.items():
                with zf.open(f"{name}.npy") as fh:
                    shape, dtype = _header(fh)
                if dtype.kind not in kinds or (kinds == "f" and dtype.itemsize != 8):
                    raise fail(f"{name} has dtype {dtype}; a checkpoint's is "
                               f"{'float64' if kinds == 'f' else 'an integer' if kinds == 'iu' else 'a string'}")
                if shape != expect[name]:
                    what = f"{nq} values (this deck's model has {nq} coordinates)" if ndim else "a scalar"
                    raise fail(f"{name} has shape {shape}; a checkpoint's is {what}")
                with zf.open(f"{name}.npy") as fh:
                    arrays[name] = np.lib.format.read_array(fh, allow_pickle=False)
    except DeckError:
        raise
    except Exception as exc:   # noqa: BLE001 - zipfile, zlib and numpy raise many kinds for one cause
        raise fail(f"cannot be read ({type(exc).__name__}: {exc})") from None
    return arrays


def _header(fh) -> tuple[tuple, np.dtype]:
    """(shape, dtype) from the header of an .npy stream, without reading its data."""
    version = np.lib.format.read_magic(fh)
    readers = {(1, 0): np.lib.format.read_array_header_1_0, (2, 0): np.lib.format.read_array_header_2_0}
    if version not in readers:
        raise ValueError(f".npy format version {version}")
    shape, _, dtype = readers[version](fh)
    return tuple(shape), dtype


def check_same_model(model, ck: Checkpoint) -> None:
    """Refuse a continuation whose deck describes another model than the checkpointed run:
    every key of either deck but :data:`FREE_KEYS` must be in both and equal, and the
    checkpoint's t must be its deck's t_end (the end of that run)."""
    if not analysis_of(model).restartable:
        model.deck.fail("case", "analysis", "--restart continues a run with a checkpoint (a dynamic run); this deck's analysis is "
                                            f"'{model.analysis}'")
    new = _plain(model.deck.values)
    stored = ck.deck_values
    where = f"the run in {ck.directory}"
    for group in sorted(set(new) | set(stored)):
        ours, theirs = new.get(group, {}), stored.get(group, {})
        for key in sorted(set(ours) | set(theirs)):
            if (group, key) in FREE_KEYS:
                continue
            if key not in theirs:
                model.deck.fail(group, key, f"is missing from the deck stored in the {FILE} of {where}: a "
                                            "continuation must describe the same model (only t_end may change)")
            if key not in ours:
                model.deck.fail(group, key, f"is in the deck stored in the {FILE} of {where} ({theirs[key]!r}) but "
                                            "is not a key of this deck: a continuation must describe the same model")
            if ours[key] != theirs[key]:
                model.deck.fail(group, key, f"differs from {where} ({theirs[key]!r} in its {FILE}): a "
                                            "continuation must describe the same model (only t_end may change)")
    t_end = stored.get("solver", {}).get("t_end")
    if t_end != ck.t:
        raise CheckpointError(model.name, ck.directory, FILE, f"t = {ck.t!r} s, but the run's t_end was "
                              f"{t_end!r} s: the state is not where that run ended")
    if not model.deck["solver.t_end"] > ck.t:
        model.deck.fail("solver", "t_end", f"the run in {ck.directory} ended at t = {ck.t:g} s: a continuation "
                                           "needs a later t_end")


def source_record(model, ck: Checkpoint, names: list[str], times: np.ndarray) -> tuple[str, dict]:
    """(file name, columns): the time series of the checkpointed run, checked to be the whole
    record of that run up to its end: one file, readable, exactly the columns ``names``,
    finite, and its sample times exactly ``times`` (the run's own grid up to ``ck.t``): a
    record cut short or with rows removed or added is refused, never continued."""
    present = [f for f in RECORDS if (ck.directory / f).exists()]
    if not present:
        raise CheckpointError(model.name, ck.directory, RECORDS[0], "not found, nor "
                              f"{RECORDS[1]}: the time series of the run is part of its continuation")
    if len(present) > 1:
        raise CheckpointError(model.name, ck.directory, present[0], f"is there beside {present[1]}: a run writes "
                              "one of them, so which one belongs to the checkpoint is unknown")
    name = present[0]

    def fail(reason):
        return CheckpointError(model.name, ck.directory, name, reason)

    from pydriver.output import read_timeseries
    try:
        with warnings.catch_warnings():
            # numpy warns of a CSV without rows; what was read is checked in full below.
            warnings.simplefilter("ignore")
            cols = read_timeseries(ck.directory / name)
        cols = {c: np.asarray(cols[c], dtype=float) for c in cols}
        if len({a.shape for a in cols.values()}) > 1 or any(a.ndim != 1 for a in cols.values()):
            raise ValueError("its columns differ in length")
    except Exception as exc:   # noqa: BLE001 - a text or HDF5 file of any content: every failure is one
        raise fail(f"cannot be read ({type(exc).__name__}: {exc})") from None
    missing = [c for c in names if c not in cols]
    extra = [c for c in cols if c not in names]
    if missing or extra:
        raise fail(("lacks " + ", ".join(missing[:4]) + (" ..." if len(missing) > 4 else "") if missing else
                    "has columns this model does not write: " + ", ".join(extra[:4]))
                   + " (written by another model or version)")
    t = cols["t"]
    n = len(times)
    run = f"the run that {FILE} ends (t = {ck.t!r} s, {n} rows)"
    if len(t) < n and np.array_equal(t, times[:len(t)]):
        last = f"t = {float(t[-1])!r} s ({len(t)} rows)" if len(t) else "no row"
        raise fail(f"ends at {last}, short of {run}: the time series was cut short, and a continuation needs "
                   "the whole history")
    if not np.array_equal(t, times):
        k = next((i for i in range(min(len(t), n)) if not t[i] == times[i]), min(len(t), n))
        got = f"t = {float(t[k])!r} s" if k < len(t) else "nothing"
        want = f"t = {float(times[k])!r} s" if k < n else "no further row"
        raise fail(f"row {k + 1} holds {got} where {run} wrote {want} (the file has {len(t)} rows): rows were "
                   f"removed, added or changed, or the file and {FILE} are not of one run")
    for c in names:
        bad = np.flatnonzero(~np.isfinite(cols[c]))
        if bad.size:
            raise fail(f"{c} is {float(cols[c][bad[0]])!r} at row {bad[0] + 1} (t = {float(t[bad[0]])!r} s): a run "
                       "writes finite numbers only")
    return name, {c: cols[c] for c in names}


def check_state(model, ck: Checkpoint) -> None:
    """Refuse a checkpoint whose state (q, v) is not the one its time series ends with (every
    joint coordinate and rate, :data:`STATE_RTOL`), or that violates the constraints by more
    than the integration allows: positions by their residual (:func:`constraint_bound`), rates
    by how far the consistent start moves them."""
    from pydriver.analyses.common import RAD2DEG
    from pydriver.analyses.record_columns import coordinate_columns

    last = {c: float(ck.record[c][-1]) for c in ck.record}
    worst = None
    for coord, rate, i in coordinate_columns(model):
        for column, state in ((coord, ck.q), (rate, ck.v)):
            ours, theirs = float(state[i] * RAD2DEG), last[column]      # as the time series was written
            gap = abs(ours - theirs)
            if gap > STATE_RTOL * max(abs(ours), abs(theirs)) and (worst is None or gap > worst[0]):
                worst = (gap, column, ours, theirs)
    if worst is not None:
        _, column, ours, theirs = worst
        raise CheckpointError(model.name, ck.directory, FILE, f"its state has {column} = {ours!r}, but the last "
                              f"row of {ck.record_file} (t = {ck.t!r} s) has {theirs!r}: the state is not the one "
                              "the run ended with")
    if model.nc == 0:
        return
    try:
        g = float(np.max(np.abs(model.core.constraint_residual(ck.q, ck.t))))
        start = model.core.consistent_start(ck.q, ck.v, ck.t)
    except (DeckError, RunError) as exc:
        raise CheckpointError(model.name, ck.directory, FILE, f"its state cannot be evaluated ({exc})") from None
    bound = constraint_bound(model, ck.q)
    if not g <= bound:
        raise CheckpointError(model.name, ck.directory, FILE, f"its state violates the constraints by {g:.3g} "
                              f"(m or rad); a state the run reached meets them to {bound:.3g}")
    # The velocity constraints: how far the continuation's consistent start (eq. 3.55, what
    # IDA starts from at every segment) moves the rates, in IDA's error weights.  IDA accepted
    # the run's last state with its Newton correction below 1 in their RMS norm over all N
    # unknowns, so no rate is further than sqrt(N) weights from the constrained one; the decay
    # deck's checkpoints move by 1e-4 to 1e-2 (the six-link deck's, at rtol 1e-8, by 0.07), a
    # rate changed by 1e-6 rad/s by 7 to 36.  The projection's own rounding (some ulp of the
    # largest rate) is added to the weights, for decks with tolerances near it.
    s = model.deck.values["solver"]
    rounding = 64 * np.finfo(float).eps * max(float(np.max(np.abs(ck.v))), 1.0)
    moved = np.abs(start["v"] - ck.v) / (s["rtol"] * np.abs(ck.v) + s["atol"] + rounding)
    limit = math.sqrt(2 * model.nq + 2 * model.nc)
    i = int(np.argmax(moved))
    if not moved[i] <= limit:
        raise CheckpointError(model.name, ck.directory, FILE, f"its rates violate the velocity constraints: the "
                              f"consistent start moves v[{i}] by {abs(start['v'][i] - ck.v[i]):.3g} rad/s, "
                              f"{moved[i]:.3g} times its error weight; a state the run reached moves by less "
                              f"than {limit:.3g}")


def constraint_bound(model, q: np.ndarray) -> float:
    """The largest constraint residual |g(q)| (m for positions, rad for rotations) a state of
    a run of ``model`` can have.

    IDA holds g(q) = 0 as one of the DAE's equations (GGL): its Newton iteration stops when the
    correction's RMS norm weighted by 1/(rtol |y_i| + atol) is below 1, so each of the
    N = 2 nq + 2 nc unknowns y_i is within sqrt(N) (rtol |y_i| + atol) of the solution.  A coordinate
    error e turns the chain beyond its joint by e, moving clamp B's end by at most L e (L the
    cable's length, a lever no longer than the chain) and turning it by e; with all nq
    coordinates off by their whole tolerance in one direction:
    |g| <= sqrt(N) nq max(L / 1 m, 1) (rtol max(|q|, 1) + atol).  Runs stay far below it (the
    decay deck: 3e-12 m over a run, 1e-16 to 6e-13 at its ends, against a bound of 2.6e-4); a
    coordinate moved by a few milliradians or more is beyond it (a smaller change of the state is
    the time series' check to find, :data:`STATE_RTOL`).
    """
    s = model.deck.values["solver"]
    length = float(np.sum(model.description["bodies"].lengths))
    n_unknowns = 2 * model.nq + 2 * model.nc
    tol = s["rtol"] * max(float(np.max(np.abs(q))), 1.0) + s["atol"]
    return math.sqrt(n_unknowns) * model.nq * max(length, 1.0) * tol
