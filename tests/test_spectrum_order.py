"""The order in which a spectrum's runs are handed to an engine: the run-up first (its longest
run in the shipped spectrum: pydriver.sweep.spectrum.runup_first), the regimes in the deck's
order; the ids, records and Slurm array indices keep the manifest's order."""

from __future__ import annotations

import json

import pydriver.sweep.spectrum as spectrum
from test_spectrum import TWO, spectrum_text


def test_the_pool_and_dask_start_the_runup_first(tmp_path, monkeypatch):
    deck = tmp_path / "two.nml"
    deck.write_text(spectrum_text(TWO))
    handed = {}

    def engine(tasks, *args):
        handed.setdefault("tasks", [(id_, run_dir.name) for id_, _, run_dir in tasks])
    monkeypatch.setattr(spectrum, "run_pool", engine)
    monkeypatch.setattr(spectrum, "run_dask", engine)
    for options in ({"jobs": 2}, {"dask": "tcp://127.0.0.1:1"}):
        handed.clear()
        status = spectrum.run_spectrum(deck, tmp_path / "out", **options)
        assert not status.ok and status.missing == ["slow", "fast", "run-up"]     # nothing ran
        assert handed["tasks"] == [("0002", "0002"), ("0000", "0000"), ("0001", "0001")], options
    manifest = json.loads((tmp_path / "out" / "sweep.json").read_text())
    assert [(p["id"], p["values"]) for p in manifest["points"]] == [
        ("0000", ["slow"]), ("0001", ["fast"]), ("0002", ["run-up"])]
