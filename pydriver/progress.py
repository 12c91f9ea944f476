"""Progress of a long run on stderr: the refinement level, the revolution, the simulated time.

Silent by default (a library call prints nothing).  The command line turns it on:

* normal (``rotorcable run``): one line, rewritten in place, on a terminal only, and only once a
  run has taken more than ``DELAY_S`` (a short run stays quiet); cleared when the run ends;
* ``-v``: every message on its own line with the elapsed time, terminal or not (for logs);
* ``-q``: nothing.

Analyses call :func:`report` with a stage and a detail; :func:`stage` names the refinement
level that every later message (and a failure) belongs to.
"""

from __future__ import annotations

import sys
import time
from contextlib import contextmanager

QUIET, NORMAL, VERBOSE = 0, 1, 2
#: A run shorter than this shows no progress line (issue 22: "runs over ~2 s show progress").
DELAY_S = 2.0


class _Reporter:
    def __init__(self):
        self.level = QUIET
        self.stream = sys.stderr
        self.t0 = time.monotonic()
        self.prefix = ""
        self.shown = False

    def emit(self, text: str):
        elapsed = time.monotonic() - self.t0
        line = f"{self.prefix}{text}"
        if self.level >= VERBOSE:
            print(f"[{elapsed:7.1f} s] {line}", file=self.stream, flush=True)
        elif self.level == NORMAL and elapsed >= DELAY_S and self.stream.isatty():
            print("\r" + line[:110].ljust(110), end="", file=self.stream, flush=True)
            self.shown = True

    def clear(self):
        if self.shown:
            print("\r" + " " * 110 + "\r", end="", file=self.stream, flush=True)
            self.shown = False


_REPORTER = _Reporter()


def configure(level: int, stream=None) -> None:
    """Set the verbosity (QUIET, NORMAL, VERBOSE) and the stream (stderr by default)."""
    _REPORTER.level = level
    _REPORTER.stream = stream if stream is not None else sys.stderr


def report(text: str) -> None:
    """One progress message (e.g. ``"revolution 3: difference 2.1e-05 m"``)."""
    if _REPORTER.level > QUIET:
        _REPORTER.emit(text)


@contextmanager
def run_progress(name: str):
    """Around one deck's run: restarts the clock, clears the line at the end."""
    _REPORTER.t0 = time.monotonic()
    _REPORTER.prefix = ""
    try:
        report(f"{name}: started")
        yield
    finally:
        _REPORTER.clear()
        _REPORTER.prefix = ""


@contextmanager
def stage(text: str):
    """Messages inside the block are prefixed with ``text`` (a refinement level)."""
    old = _REPORTER.prefix
    _REPORTER.prefix = f"{old}{text}: "
    try:
        report("started")
        yield
    finally:
        _REPORTER.prefix = old
