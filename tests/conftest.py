"""Shared helpers for the rotorcable tests."""

from __future__ import annotations

import os

# Single-threaded BLAS: the reference model's small dense solves are several times slower when
# OpenBLAS spreads them over the cores (measured on a 2-core VM), and the core calls LAPACK on
# matrices of tens of rows.  Set before numpy is imported by the tests.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import contextlib
import json
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
INPUTS = ROOT / "inputs"
DATA = Path(__file__).resolve().parent / "data"


def thesis(name: str) -> dict:
    """Reference numbers typed from the thesis (tests/data/<name>.json)."""
    return json.loads((DATA / f"{name}.json").read_text())


def edit_deck(src: Path, dst: Path, group: str, assignments: dict | None = None,
              drop_group: bool = False, raw: str | None = None) -> Path:
    """Copy a deck with keys of one group replaced (pydriver.study.override_deck), or with
    the group dropped."""
    from pydriver.study import override_deck
    if drop_group:
        text = Path(src).read_text()
        m = re.search(rf"&{group}\b.*?\n\s*/", text, re.S | re.I)
        assert m, f"group {group} not in {src}"
        Path(dst).write_text(text[:m.start()] + text[m.end():])
        return Path(dst)
    return override_deck(src, dst, {group: assignments or {}})


@pytest.fixture
def deck_copy(tmp_path):
    """Factory: deck_copy('six_link_static', group, {...}) -> path of an edited copy."""
    def make(stem, group=None, assignments=None, **kw):
        src = INPUTS / f"{stem}.nml"
        dst = tmp_path / f"{stem}_{len(list(tmp_path.iterdir()))}.nml"
        if group is None:
            dst.write_text(src.read_text())
            return dst
        return edit_deck(src, dst, group, assignments, **kw)
    return make


def pytest_configure(config):
    config.addinivalue_line(
        "markers", "whole_job: runs a whole refined job or a multi-start design study, minutes under the debug "
        "build (-Og, -fcheck=all); .ci/tests runs it on the release build only, since the debug pass looks for "
        "uninitialised values and bad indices, which the smaller tests of the same Fortran routines reach")


def pytest_report_header(config):
    """Whether the core under test has the probes most tests use (meson option ``probes``;
    .ci/setup builds with it, the product wheel without)."""
    from pydriver.core_probes import HAS_PROBES
    return f"rotorcable probes: {'built' if HAS_PROBES else 'NOT built (bash .ci/setup builds them)'}"


@pytest.fixture(scope="session")
def slurm():
    """A private single-node Slurm (``tests/slurm_cluster.py``), started for the first test
    that asks for it and stopped at the end of the session.

    Not skipped when Slurm is missing: the tests that need it fail, saying that
    ``bash .ci/setup`` installs it (CI must run them).
    """
    from slurm_cluster import SlurmUnavailable, local_slurm
    with contextlib.ExitStack() as stack:
        try:
            cluster = stack.enter_context(local_slurm())
        except SlurmUnavailable as exc:
            pytest.fail(f"cannot start the tests' Slurm: {exc}", pytrace=False)
        yield cluster
