"""Every corrupted or crafted restart directory is a clean error (issue 35, "Restarts").

A finished run of the decay deck (t_end = 0.1 s, 101 samples, IDA afresh every 0.05 s) is the
source, once with timeseries.csv and once with timeseries.h5.  Each case copies it, damages one
thing, and asks for a continuation to t = 0.2 s.  The damage is generated, not listed: the
checkpoint's bytes cut at lengths spread over the file, replaced by random bytes, with bytes
flipped at random places; each array of the checkpoint missing, of another dtype, shape or size,
non-finite, absurd; its deck's JSON of every other type, empty, lacking or adding groups and
keys, of another model; its state moved against the time series or against the constraints;
the time series cut at byte lengths, with rows removed, repeated or added, columns missing,
values non-finite, in both formats.

What every case must give: a :class:`pydriver.DeckError` (the command line prints it as one
line, no traceback; one case goes through the command line to show it) that names the damaged
file, no output directory, and the source directory byte for byte as it was (a continuation
reads it, never writes there).  A damaged byte that a zip reader does not check (a time stamp
in a zip header) may leave a valid checkpoint: such a case must then continue to exactly the
run the undamaged one gives.
"""

from __future__ import annotations

import io
import json
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest

import pydriver
from conftest import INPUTS
from pydriver.analyses.common import RAD2DEG
from pydriver.analyses.record_columns import coordinate_columns
from pydriver.model import Model
from pydriver.output import TimeseriesWriter, read_timeseries
from pydriver.study import override_deck

DECAY = INPUTS / "uh60_part2_decay.nml"
CK = "checkpoint.npz"


def _deck(directory: Path, name: str, t_end: str, **solver) -> Path:
    changes = {"solver": {"t_end": t_end, "dt_out": "1.0e-3", "checkpoint_interval": "0.05", **solver}}
    return override_deck(DECAY, directory / f"{name}.nml", changes)


@pytest.fixture(scope="module")
def world(tmp_path_factory):
    """The two source runs (csv, hdf5), the continuing model, and its undamaged continuation."""
    base = tmp_path_factory.mktemp("restart_sources")
    sources = {}
    for fmt in ("csv", "hdf5"):
        sources[fmt] = base / fmt
        pydriver.run_deck(_deck(base, f"source_{fmt}", "0.1", output_format=f"'{fmt}'"), out=sources[fmt])
    model = Model.from_deck(_deck(base, "continuation", "0.2"))
    clean = pydriver.run_deck(model, restart=sources["csv"]).timeseries
    return {"sources": sources, "model": model, "clean": clean}


def _snapshot(directory: Path) -> dict:
    return {str(p.relative_to(directory)): p.read_bytes() for p in sorted(directory.rglob("*")) if p.is_file()}


def _continue_damaged(world, tmp_path, fmt, damage):
    """Copy the source, damage it, continue it: (the DeckError or None, the result or None)."""
    src = tmp_path / "source"
    shutil.copytree(world["sources"][fmt], src)
    damage(src)
    before = _snapshot(src)
    out = tmp_path / "out"
    error = result = None
    try:
        result = pydriver.run_deck(world["model"], out=out, restart=src)
    except pydriver.DeckError as exc:
        error = exc
        assert not out.exists(), "a refused continuation wrote its output directory"
        assert sorted(p.name for p in tmp_path.iterdir()) == ["source"], "a refused continuation left files"
    assert _snapshot(src) == before, "the continuation changed the directory it continued"
    shutil.rmtree(src)                    # an HDF5 copy is 8 MB: kept by no case
    shutil.rmtree(out, ignore_errors=True)
    return error, result


def _assert_refused(world, tmp_path, fmt, damage, names_file, words=()):
    error, _ = _continue_damaged(world, tmp_path, fmt, damage)
    assert error is not None, "the damaged source was continued"
    text = str(error)
    assert names_file in text, text
    for w in words:
        assert w in text, text
    assert "\n" not in text and "Traceback" not in text
    return error


# -- the checkpoint's bytes ---------------------------------------------------------------
#: Where to cut: absolute lengths from the start, fractions of the file, lengths from its end
#: (negative); the zip's central directory sits in its last bytes, the arrays before it.
CUTS = [0, 1, 2, 4, 22, 30, 100, 0.1, 0.25, 0.5, 0.75, 0.9, -200, -100, -46, -22, -2, -1]


def _cut_at(length: int, where) -> int:
    return int(where * length) if isinstance(where, float) else where if where >= 0 else length + where


@pytest.mark.parametrize("where", CUTS, ids=[f"cut{w}" for w in CUTS])
def test_a_truncated_checkpoint_is_refused(world, tmp_path, where):
    def damage(src):
        data = (src / CK).read_bytes()
        (src / CK).write_bytes(data[:_cut_at(len(data), where)])
    _assert_refused(world, tmp_path, "csv", damage, CK)


@pytest.mark.parametrize("seed,size", [(0, 0), (1, 7), (2, 512), (3, None), (4, 70_000)])
def test_random_bytes_for_a_checkpoint_are_refused(world, tmp_path, seed, size):
    def damage(src):
        n = len((src / CK).read_bytes()) if size is None else size
        (src / CK).write_bytes(np.random.default_rng(seed).integers(0, 256, n, dtype=np.uint8).tobytes())
    _assert_refused(world, tmp_path, "csv", damage, CK)


#: Places in checkpoint.npz to change one byte at: in each array's zip entry (its local
#: header's fields, its .npy header, its data) and in the zip's directory at the end.
ENTRY_PLACES = ["signature", "mod_time", "crc", "size", "name_length", "name", "npy_magic", "npy_header_length",
                "npy_header_text", "first_data_byte", "last_data_byte"]
FLIPS = [(m, p) for m in ("version", "t", "q", "v", "deck") for p in ENTRY_PLACES]
FLIPS += [("zip", p) for p in ("central_directory", "central_name", "end_record", "end_record_count",
                               "end_record_offset")]


def _flip_offset(data: bytes, member: str, place: str) -> int:
    """The offset of ``place`` in the zip ``data`` (PKWARE APPNOTE 4.3.7, 4.3.12, 4.3.16)."""
    with zipfile.ZipFile(io.BytesIO(data)) as zf:
        infos = {i.filename: i for i in zf.infolist()}
    end = data.rindex(b"PK\x05\x06")
    central = int.from_bytes(data[end + 16:end + 20], "little")
    if member == "zip":
        return {"central_directory": central, "central_name": central + 46, "end_record": end,
                "end_record_count": end + 10, "end_record_offset": end + 16}[place]
    h = infos[f"{member}.npy"].header_offset
    name_len = int.from_bytes(data[h + 26:h + 28], "little")
    extra_len = int.from_bytes(data[h + 28:h + 30], "little")
    npy = h + 30 + name_len + extra_len
    header_len = int.from_bytes(data[npy + 8:npy + 10], "little")        # .npy format 1.0
    size = infos[f"{member}.npy"].compress_size
    return {"signature": h, "mod_time": h + 10, "crc": h + 14, "size": h + 18, "name_length": h + 26,
            "name": h + 30, "npy_magic": npy, "npy_header_length": npy + 8, "npy_header_text": npy + 12,
            "first_data_byte": npy + 10 + header_len, "last_data_byte": npy + size - 1}[place]


@pytest.mark.parametrize("member,place", FLIPS, ids=[f"{m}-{p}" for m, p in FLIPS])
def test_a_changed_byte_in_the_checkpoint_is_refused_or_harmless(world, tmp_path, member, place):
    """One byte changed at each field of the file: the zip's checksums catch the arrays'
    bytes, the checks here the headers and the deck; a byte nothing reads (a time stamp) must
    change nothing."""
    def damage(src):
        data = bytearray((src / CK).read_bytes())
        data[_flip_offset(bytes(data), member, place)] ^= 0xFF
        (src / CK).write_bytes(bytes(data))
    error, result = _continue_damaged(world, tmp_path, "csv", damage)
    if error is None:
        clean = world["clean"]
        assert all(np.array_equal(result.timeseries[k], clean[k]) for k in clean)
    else:
        assert CK in str(error) or "timeseries.csv" in str(error)


def _write_npz(path: Path, arrays: dict):
    with open(path, "wb") as fh:
        np.savez(fh, **arrays)


def _not_npz(kind: str):
    def damage(src):
        p = src / CK
        if kind == "npy":                  # one array in NumPy's format, not a zip of them
            p.unlink()
            with open(p, "wb") as fh:
                np.save(fh, np.arange(3.0))
        elif kind == "empty_zip":
            p.unlink()
            with zipfile.ZipFile(p, "w"):
                pass
        elif kind == "other_zip":
            p.unlink()
            with zipfile.ZipFile(p, "w") as zf:
                zf.writestr("readme.txt", "not a checkpoint")
        elif kind == "text":
            p.write_text(json.dumps({"t": 0.1, "q": [0.0] * 20}))
        elif kind == "directory":
            p.unlink()
            p.mkdir()
        elif kind == "missing":
            p.unlink()
    return damage


@pytest.mark.parametrize("kind", ["npy", "empty_zip", "other_zip", "text", "directory", "missing"])
def test_something_else_than_a_checkpoint_is_refused(world, tmp_path, kind):
    _assert_refused(world, tmp_path, "csv", _not_npz(kind), CK)


# -- the checkpoint's arrays ------------------------------------------------------------
def _pristine(world) -> dict:
    with np.load(world["sources"]["csv"] / CK) as data:
        return {k: data[k] for k in data.files}


def _array_cases():
    """(id, change of the arrays) for every array: missing, of another dtype, shape, size,
    non-finite, absurd."""
    cases = [(f"missing-{name}", lambda a, n=name: {k: v for k, v in a.items() if k != n})
             for name in ("version", "t", "q", "v", "deck")]
    cases.append(("extra-array", lambda a: {**a, "extra": np.zeros(3)}))
    other_values = {
        "version": [np.array(1), np.array(3), np.array(-2), np.array("2"), np.array(2.0), np.array([2, 2]),
                    np.array(True)],
        "t": [np.array("0.1"), np.float32(0.1), np.array([0.1]), np.array([[0.1]]), np.array(1),
              np.array(0.1 + 0j), np.array(np.nan), np.array(np.inf), np.array(-np.inf), np.array(-1e300),
              np.array(1e300), np.array(0.0), np.array(-0.0), np.array(5e-324), np.array(0.05),
              np.array(np.nextafter(0.1, 1.0)), np.array(0.2), np.array(0.1, dtype=np.longdouble)],
        "deck": [np.array(b"{}"), np.array(["{}"]), np.array(1.0)],
    }
    for name, values in other_values.items():
        cases += [(f"{name}={v.dtype}{v.shape}{str(v.tolist())[:12]}", lambda a, n=name, v=v: {**a, n: v})
                  for v in values]

    def state_variants(x):
        n = len(x)
        return {"short": x[:-1], "long": np.append(x, 0.0), "empty": x[:0], "column": x[:, None],
                "row": x[None, :], "scalar": x[0], "float32": x.astype(np.float32), "int": x.astype(int),
                "complex": x.astype(complex), "str": x.astype(str), "object": x.astype(object),
                "nan": np.where(np.arange(n) == n // 2, np.nan, x), "inf": np.where(np.arange(n) == 0, np.inf, x),
                "-inf": np.where(np.arange(n) == n - 1, -np.inf, x), "huge": x + 1e300}
    for name in ("q", "v"):
        for label in state_variants(np.zeros(3)):
            cases.append((f"{name}-{label}", lambda a, n=name, lab=label: {**a, n: state_variants(a[n])[lab]}))
    return cases


ARRAY_CASES = _array_cases()


@pytest.mark.parametrize("change", [c for _, c in ARRAY_CASES], ids=[i for i, _ in ARRAY_CASES])
def test_a_crafted_checkpoint_array_is_refused(world, tmp_path, change):
    arrays = change(_pristine(world))
    _assert_refused(world, tmp_path, "csv", lambda src: _write_npz(src / CK, arrays), CK)


# -- the deck the checkpoint stores -------------------------------------------------------
def _deck_cases():
    """(id, the stored deck's new text from the pristine deck dict)."""
    def edit(f):
        def text(d):
            d = json.loads(json.dumps(d))
            f(d)
            return json.dumps(d)
        return text

    cases = [(f"json-{i}", (lambda d, s=s: s)) for i, s in enumerate(
        ["", "{", "[]", "[1, 2]", "3", '"deck"', "null", "true", "{}", '{"case": {}}', '{"case": 1}',
         '{"case": []}', "[" * 100_000 + "]" * 100_000, "NaN", '{"solver": {"t_end": 0.1}}'])]
    for group in ("case", "chain", "solver", "loads", "springs"):
        cases.append((f"no-group-{group}", edit(lambda d, g=group: d.pop(g))))
    cases += [
        ("no-key-rtol", edit(lambda d: d["solver"].pop("rtol"))),
        ("no-key-c_beta", edit(lambda d: d["springs"].pop("c_beta"))),
        ("extra-key", edit(lambda d: d["solver"].update(unknown_key=1.0))),
        ("extra-group", edit(lambda d: d.update(unknown_group={"a": 1}))),
        ("other-c_beta", edit(lambda d: d["springs"].update(c_beta=[30.0] * len(d["springs"]["c_beta"])
                                                            if isinstance(d["springs"]["c_beta"], list) else 30.0))),
        ("other-dt_out", edit(lambda d: d["solver"].update(dt_out=2e-3))),
        ("other-interval", edit(lambda d: d["solver"].update(checkpoint_interval=0.1))),
        ("other-n_bodies", edit(lambda d: d["chain"].update(n_bodies=12))),
        ("other-analysis", edit(lambda d: d["case"].update(analysis="static"))),
        ("nan-value", edit(lambda d: d["solver"].update(rtol=float("nan")))),
        ("t_end-earlier", edit(lambda d: d["solver"].update(t_end=0.05))),
        ("t_end-string", edit(lambda d: d["solver"].update(t_end="0.1"))),
        ("group-is-list", edit(lambda d: d.update(solver=list(d["solver"].items())))),
    ]
    return cases


DECK_CASES = _deck_cases()


@pytest.mark.parametrize("text", [c for _, c in DECK_CASES], ids=[i for i, _ in DECK_CASES])
def test_a_crafted_stored_deck_is_refused(world, tmp_path, text):
    arrays = _pristine(world)
    arrays["deck"] = np.array(text(json.loads(str(arrays["deck"]))))
    _assert_refused(world, tmp_path, "csv", lambda src: _write_npz(src / CK, arrays), CK)


def test_the_stored_deck_and_t_moved_together_do_not_fit_the_time_series(world, tmp_path):
    """A checkpoint claiming the run ended at 0.05 s, deck and t alike: the time series beside it
    ends at 0.1 s, so the two are not of one run."""
    arrays = _pristine(world)
    deck = json.loads(str(arrays["deck"]))
    deck["solver"]["t_end"] = 0.05
    arrays.update(deck=np.array(json.dumps(deck)), t=np.array(0.05))
    _assert_refused(world, tmp_path, "csv", lambda src: _write_npz(src / CK, arrays), CK,
                    words=("timeseries.csv",))


# -- the state against the time series and the constraints --------------------------------
def _rewrite_record(src: Path, fmt: str, change):
    """Rewrite the time series through the writer of the runs, with ``change(columns)``."""
    path = src / ("timeseries.csv" if fmt == "csv" else "timeseries.h5")
    cols = {k: np.array(v, float) for k, v in read_timeseries(path).items()}
    cols = change(cols)
    path.unlink()
    writer = TimeseriesWriter(path, list(cols), "csv" if fmt == "csv" else "hdf5")
    writer.write(cols)
    writer.close()


def _shift_state(world, which: str, index: int, by: float, in_record: bool):
    """Move q or v of the checkpoint (and, if ``in_record``, the time series' last row with it,
    written as a run writes it) by ``by``."""
    model = world["model"]

    def damage(src):
        arrays = _pristine(world)
        arrays[which] = arrays[which].copy()
        arrays[which][index] += by
        _write_npz(src / CK, arrays)
        if in_record:
            coordinate, rate = next((c, r) for c, r, i in coordinate_columns(model) if i == index)
            column = rate if which == "v" else coordinate

            def change(cols):
                cols[column][-1] = arrays[which][index] * RAD2DEG
                return cols
            _rewrite_record(src, "csv", change)
    return damage


STATE_CASES = [("q", i, by, False) for i in (0, 1, 10, 19) for by in (3.0, -3.0, 1e-3, 1e-8)]
STATE_CASES += [("v", i, by, False) for i in (0, 7, 19) for by in (1.0, 1e-6)]
STATE_CASES += [("q", 0, 3.0, True), ("q", 5, 1.0, True), ("q", 19, 0.1, True), ("q", 19, -3.0, True)]
STATE_CASES += [("v", 1, 1.0, True), ("v", 7, 1e-3, True), ("v", 19, 1e-5, True)]


@pytest.mark.parametrize("which,index,by,in_record", STATE_CASES,
                         ids=[f"{w}[{i}]{b:+g}{'-with-record' if r else ''}" for w, i, b, r in STATE_CASES])
def test_a_moved_state_is_refused(world, tmp_path, which, index, by, in_record):
    """Moved alone, the state no longer ends the time series (to 1e-12 relative, which a
    change of 1e-8 exceeds by 4 orders); moved with the time series' last row, it leaves the
    constraints (positions: by 2e-3 m and more; rates: beyond 7 error weights)."""
    damage = _shift_state(world, which, index, by, in_record)
    _assert_refused(world, tmp_path, "csv", damage, CK,
                    words=("constraints",) if in_record else ("last row of timeseries.csv",))


# -- the time series ----------------------------------------------------------------------
def _csv_lines(change):
    def damage(src):
        p = src / "timeseries.csv"
        lines = p.read_bytes().split(b"\n")[:-1]
        p.write_bytes(b"".join(x + b"\n" for x in change(lines[0], lines[1:])))
    return damage


def _csv_bytes(change):
    def damage(src):
        p = src / "timeseries.csv"
        p.write_bytes(change(p.read_bytes()))
    return damage


def _columns(change):
    return lambda fmt: (lambda src: _rewrite_record(src, fmt, change))


def _record_cases():
    """(id, damage(fmt) -> damage(src)) for both formats, and (id, damage(src)) of the CSV's text."""
    def drop_rows(rows):
        return _columns(lambda c: {k: np.delete(v, rows) for k, v in c.items()})

    def set_value(column, row, value):
        def change(c):
            c[column] = c[column].copy()
            c[column][row] = value
            return c
        return _columns(change)

    both = [
        ("rows-first-half", _columns(lambda c: {k: v[:len(v) // 2] for k, v in c.items()})),
        ("rows-all-but-last", _columns(lambda c: {k: v[:-1] for k, v in c.items()})),
        ("rows-header-only", _columns(lambda c: {k: v[:0] for k, v in c.items()})),
        ("drop-row-first", drop_rows([0])), ("drop-row-middle", drop_rows([50])),
        ("drop-row-last", drop_rows([100])), ("drop-every-other", drop_rows(np.arange(1, 101, 2))),
        ("drop-row-at-boundary", drop_rows([50, 51])),
        ("repeat-row", _columns(lambda c: {k: np.insert(v, 30, v[30]) for k, v in c.items()})),
        ("extra-row", _columns(lambda c: {k: np.append(v, 0.101 if k == "t" else v[-1]) for k, v in c.items()})),
        ("swap-rows", _columns(lambda c: {k: v[np.r_[0:40, 41, 40, 42:len(v)]] for k, v in c.items()})),
        ("t-shifted", _columns(lambda c: {**c, "t": c["t"] + 1e-3})),
        ("t-row-changed", set_value("t", 70, 0.0705)),
        ("nan-middle", set_value("z6", 40, np.nan)), ("inf-first", set_value("FA_x", 0, np.inf)),
        ("nan-t", set_value("t", 20, np.nan)),
        ("coordinate-last-row", set_value("beta2_coord_deg", -1, 12.5)),
        ("rate-last-row", set_value("gamma5_rate_degps", -1, 1.0)),
        ("column-missing", _columns(lambda c: {k: v for k, v in c.items() if k != "tip_z"})),
        ("coordinate-column-missing", _columns(lambda c: {k: v for k, v in c.items() if k != "beta2_coord_deg"})),
        ("extra-column", _columns(lambda c: {**c, "zz_extra": c["t"] * 0.0})),
    ]
    text = [
        ("empty-file", _csv_bytes(lambda b: b"")),
        ("cut-mid-line", _csv_bytes(lambda b: b[:len(b) // 2])),
        ("cut-mid-number", _csv_bytes(lambda b: b[:b.rindex(b",") - 3])),
        ("cut-at-line-90", _csv_lines(lambda h, rows: [h] + rows[:90])),
        ("header-cut", _csv_bytes(lambda b: b[:200])),
        ("header-renamed", _csv_lines(lambda h, rows: [h.replace(b"z6", b"z66", 1)] + rows)),
        ("no-header", _csv_lines(lambda h, rows: rows)),
        ("random-bytes", _csv_bytes(lambda b: np.random.default_rng(7).integers(0, 256, len(b), dtype=np.uint8)
                                    .tobytes())),
        ("not-utf8", _csv_bytes(lambda b: b[:5000] + b"\xff\xfe" + b[5002:])),
        ("word-for-number", _csv_lines(lambda h, rows: [h] + rows[:60] + [rows[60].replace(b",", b",abc,", 1)]
                                       + rows[61:])),
        ("short-row", _csv_lines(lambda h, rows: [h] + rows[:60] + [rows[60][:40]] + rows[61:])),
        ("missing", lambda src: (src / "timeseries.csv").unlink()),
        ("both-formats", lambda src: shutil.copy(src / "timeseries.csv", src / "timeseries.h5")),
    ]
    return both, text


RECORD_BOTH, RECORD_TEXT = _record_cases()


@pytest.mark.parametrize("fmt", ["csv", "hdf5"])
@pytest.mark.parametrize("damage", [d for _, d in RECORD_BOTH], ids=[i for i, _ in RECORD_BOTH])
def test_a_damaged_time_series_is_refused(world, tmp_path, fmt, damage):
    name = "timeseries.csv" if fmt == "csv" else "timeseries.h5"
    _assert_refused(world, tmp_path, fmt, damage(fmt), name)


@pytest.mark.parametrize("damage", [d for _, d in RECORD_TEXT], ids=[i for i, _ in RECORD_TEXT])
def test_a_damaged_csv_text_is_refused(world, tmp_path, damage):
    _assert_refused(world, tmp_path, "csv", damage, "timeseries.csv")


H5_BYTES = [("cut", w) for w in (0, 8, 512, 0.25, 0.5, 0.9, -1)] + [("random", s) for s in (0, 1)]


@pytest.mark.parametrize("kind,arg", H5_BYTES, ids=[f"{k}{a}" for k, a in H5_BYTES])
def test_a_damaged_hdf5_file_is_refused(world, tmp_path, kind, arg):
    def damage(src):
        p = src / "timeseries.h5"
        data = p.read_bytes()
        if kind == "cut":
            data = data[:_cut_at(len(data), arg)]
        else:
            data = np.random.default_rng(arg).integers(0, 256, len(data), dtype=np.uint8).tobytes()
        p.write_bytes(data)
    _assert_refused(world, tmp_path, "hdf5", damage, "timeseries.h5")


def test_an_hdf5_file_without_its_column_list_is_refused(world, tmp_path):
    import h5py

    def damage(src):
        with h5py.File(src / "timeseries.h5", "a") as h5:
            del h5.attrs["columns"]
    _assert_refused(world, tmp_path, "hdf5", damage, "timeseries.h5")


# -- what a valid source gives, and the command line ---------------------------------------
@pytest.mark.parametrize("fmt", ["csv", "hdf5"])
def test_the_undamaged_source_continues_in_either_format(world, tmp_path, fmt):
    """The control: the same copy-and-continue without damage runs, and both formats give the
    same continuation bit for bit (both store float64 exactly)."""
    error, result = _continue_damaged(world, tmp_path, fmt, lambda src: None)
    assert error is None
    clean = world["clean"]
    assert len(result.timeseries["t"]) == 201
    assert all(np.array_equal(result.timeseries[k], clean[k]) for k in clean)
    assert result.summary["restarted_from"]["same_as_uninterrupted_run"] is True


def test_the_command_line_prints_one_line_and_no_traceback(world, tmp_path):
    src = tmp_path / "source"
    shutil.copytree(world["sources"]["csv"], src)
    data = (src / CK).read_bytes()
    (src / CK).write_bytes(data[:len(data) // 2])
    deck = _deck(tmp_path, "continuation", "0.2")
    out = tmp_path / "out"
    done = subprocess.run([sys.executable, "-m", "pydriver", "run", str(deck), "--restart", str(src), "--out",
                           str(out)], capture_output=True, text=True, timeout=300)
    assert done.returncode == 1
    assert "Traceback" not in done.stderr and CK in done.stderr
    assert done.stderr.startswith("error: ") and done.stderr.count("\n") == 1, done.stderr
    assert not out.exists()
