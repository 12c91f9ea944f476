"""rotorcable driver: run Fortran namelist decks and post-process the results.

The numerical work happens in the compiled Fortran core (``pydriver._rotorcable``,
built by meson/f2py); this package reads nothing itself, it turns the core's arrays
into tables, time series, plots and ``summary.json``.

Examples
--------
>>> import pydriver
>>> res = pydriver.run_deck("inputs/six_link_static.nml")
>>> res.summary["reactions"]["B"]["F"]
[0.0, 0.0, 75.13...]
"""

from pydriver.deck import DeckError, RunError, Result, deck_info, run_deck, evaluate_model, shape
from pydriver.results import load_results
from pydriver.sweep import SweepError, run_sweep

__all__ = ["DeckError", "RunError", "Result", "deck_info", "run_deck", "evaluate_model", "shape",
           "load_results", "run_sweep", "SweepError"]
