"""Preload of the sweep's forkserver; imported there only (``set_forkserver_preload``).

Importing the sweep package once in the forkserver makes every worker a fork that already
has numpy and the compiled core (instead of ~0.3 s of imports per worker), and ties the
forkserver to the sweep process (:func:`pydriver.sweep.lifeline.guard_forkserver`).
"""

import pydriver.sweep  # noqa: F401  (the preload itself)
from pydriver.sweep.lifeline import guard_forkserver

guard_forkserver()
