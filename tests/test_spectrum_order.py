"""The order of a spectrum's points: the run-up first (the shipped spectrum's longest run, which
started last ran alone at the end: pydriver.sweep.spectrum.plan), then the regimes in the deck's
order; the pool and Dask are handed them in that order, and a Slurm array's task i is point i."""

from __future__ import annotations

import json

import pydriver.sweep.spectrum as spectrum
from test_spectrum import TWO, spectrum_text


def test_the_runup_is_the_first_point_on_every_engine(tmp_path, monkeypatch):
    deck = tmp_path / "two.nml"
    deck.write_text(spectrum_text(TWO))
    handed = []

    def engine(tasks, *args):
        handed.append([(id_, deck_path.name, run_dir.name) for id_, deck_path, run_dir in tasks])
    monkeypatch.setattr(spectrum, "run_pool", engine)
    monkeypatch.setattr(spectrum, "run_dask", engine)
    for options in ({"jobs": 2}, {"dask": "tcp://127.0.0.1:1"}):
        status = spectrum.run_spectrum(deck, tmp_path / "out", **options)
        assert not status.ok and status.missing == ["run-up", "slow", "fast"]        # nothing ran
    order = [("0000", "0000.nml", "0000"), ("0001", "0001.nml", "0001"), ("0002", "0002.nml", "0002")]
    assert handed == [order, order]
    manifest = json.loads((tmp_path / "out" / "sweep.json").read_text())
    assert [(p["id"], p["values"]) for p in manifest["points"]] == [
        ("0000", ["run-up"]), ("0001", ["slow"]), ("0002", ["fast"])]
    assert "analysis = 'dynamic'" in (tmp_path / "out" / "decks" / "0000.nml").read_text()     # the run-up's deck
    script, _ = spectrum.write_spectrum_slurm(deck, tmp_path / "out")
    assert "#SBATCH --array=0-2\n" in script.read_text() and "sweep-task" in script.read_text()
