"""rotorcable driver: run Fortran namelist decks and post-process the results.

The numerical work happens in the compiled Fortran core (``pydriver._rotorcable``, built by
meson/f2py, reached only through :mod:`pydriver.core`).  A deck is read once (f90nml and the
schema of :mod:`pydriver.schema`), built once into a :class:`Model`, and every analysis runs on
that model.

Examples
--------
>>> import pydriver
>>> res = pydriver.run_deck("inputs/six_link_static.nml")
>>> res.summary["reactions"]["B"]["F"]
[0.0, 0.0, 75.13...]
>>> m = pydriver.Model.from_deck("inputs/uh60_part2_modal.nml").with_changes({"springs.c_beta": 20.0})
"""

import os as _os

# The core's LAPACK calls work on small matrices (tens to hundreds of rows), where BLAS
# threads cost more than they save, and batch users run one deck per core: single-threaded
# BLAS unless the user chose otherwise.  Must be set before the extension loads OpenBLAS.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS"):
    _os.environ.setdefault(_var, "1")

from pydriver.errors import DeckError, OutputError, RunError
from pydriver.model import Model
from pydriver.run_result import Result
from pydriver.run import deck_info, run_deck, shape
from pydriver.stored_results import load_results
from pydriver.scene import Scene, scene
from pydriver.sweep import SweepError, run_sweep

__all__ = ["DeckError", "OutputError", "RunError", "Result", "Model", "deck_info", "run_deck", "shape",
           "Scene", "scene", "load_results", "run_sweep", "SweepError"]
