"""Checkpoints of dynamic runs, and continuing a finished run from one (issue 22 item 5).

A dynamic run integrates in segments: ``&solver checkpoint_interval`` (default 0: one segment,
the whole run) cuts it at t = k * interval, where IDA is started afresh from the state reached
(as at a pulse edge: its step history restarts).  The run's directory gets ``checkpoint.npz``
(NumPy's own binary format: float64 bit for bit) with the state (t, q, v) at its end, the deck's
validated values and the checkpoint interval.

``rotorcable run DECK --restart DIR`` (``run_deck(deck, restart=DIR)``) continues the run of
``DIR`` from its end to the new deck's ``t_end``: the new deck must describe the same model
(every key equal but ``&solver t_end``, the output format and the case name), the time series
of ``DIR`` is read back, and the continuation starts IDA afresh at the checkpoint exactly as the
uninterrupted run with the same interval does there.  So the continued run reproduces the
uninterrupted one (tests/test_restart.py: to 1e-12; bit for bit in practice), and its files
hold the whole run from t = 0.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pydriver.errors import DeckError

FILE = "checkpoint.npz"
VERSION = 1
#: Keys that may differ between a run and its continuation.
FREE_KEYS = {("solver", "t_end"), ("solver", "output_format"), ("case", "name"), ("case", "description"),
             ("output", "table_language")}


@dataclass
class Checkpoint:
    """The end state of a dynamic run."""

    t: float
    q: np.ndarray
    v: np.ndarray
    deck_values: dict
    directory: Path


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


def read(directory, deck_name: str) -> Checkpoint:
    """The checkpoint of the run in ``directory``.

    Raises
    ------
    DeckError
        No checkpoint there, or an unreadable one (named as the deck's problem: the deck asked
        to continue it).
    """
    directory = Path(directory)
    path = directory / FILE
    if not path.is_file():
        raise DeckError(deck_name, "solver", "checkpoint_interval",
                        f"--restart {directory}: no {FILE} there (only a finished dynamic run writes one)")
    try:
        with np.load(path, allow_pickle=False) as data:
            if int(data["version"]) != VERSION:
                raise ValueError(f"version {int(data['version'])}")
            return Checkpoint(t=float(data["t"]), q=np.array(data["q"]), v=np.array(data["v"]),
                              deck_values=json.loads(str(data["deck"])), directory=directory)
    except (OSError, ValueError, KeyError) as exc:
        raise DeckError(deck_name, "solver", "checkpoint_interval",
                        f"--restart {directory}: {FILE} cannot be read ({exc})") from None


def check_same_model(model, ck: Checkpoint) -> None:
    """Refuse a continuation whose deck describes another model than the checkpointed run."""
    new = _plain(model.deck.values)
    if model.analysis != "dynamic":
        model.deck.fail("case", "analysis", "--restart continues a dynamic run; this deck's analysis is "
                                            f"'{model.analysis}'")
    for group, keys in ck.deck_values.items():
        for key, value in keys.items():
            if (group, key) in FREE_KEYS:
                continue
            if new.get(group, {}).get(key) != value:
                model.deck.fail(group, key, f"differs from the run in {ck.directory} ({value!r} there): a "
                                            "continuation must describe the same model (only t_end may change)")
    if not model.deck["solver.t_end"] > ck.t:
        model.deck.fail("solver", "t_end", f"the run in {ck.directory} ended at t = {ck.t:g} s: a continuation "
                                           "needs a later t_end")
