"""The core's one error channel at the f2py boundary (issue 23): routines that used to return
zeros or garbage for a bad handle, wrong sizes or a failed LAPACK call return a status that
pydriver.core raises as RunError, and the interpreter survives."""

from __future__ import annotations

import numpy as np
import pytest

import pydriver
from conftest import INPUTS
from pydriver import core as core_module


@pytest.fixture
def closed_chain():
    """The six-link chain held by both clamps (nc > 0: G has rows, so it has a null space)."""
    m = pydriver.Model.from_deck(INPUTS / "six_link_static.nml")
    assert m.nc > 0
    return m


def freed_handle(core):
    """Free the core's model and hand back its dead handle (the object forgets it, so its
    destructor frees nothing that a later model might have been given)."""
    handle = core.handle
    core_module._api.rc_model_free(handle)
    core.handle = None
    return handle


def test_shape_of_a_freed_model_raises(closed_chain):
    core = closed_chain.core
    q0 = closed_chain.q0
    assert np.all(np.isfinite(core.shape(q0)["cm"]))       # the live model answers
    core.handle = freed_handle(core)
    try:
        with pytest.raises(pydriver.RunError, match="no model with this handle"):
            core.shape(q0)
        with pytest.raises(pydriver.RunError, match="no model with this handle"):
            core.thesis_coordinates(*np.zeros((4, core.n_bodies)))
    finally:
        core.handle = None


def test_shape_with_wrong_sizes_raises(closed_chain):
    core = closed_chain.core
    with pytest.raises(pydriver.RunError, match="wrong sizes"):
        core.shape(np.zeros(core.nq + 1))


def test_modal_matrices_at_a_non_finite_state_raise(closed_chain, monkeypatch):
    """A NaN coordinate makes G non-finite: its null space (modal.f90, reduced_matrices) cannot
    be formed, which used to come back as all-zero matrices and is now an error."""
    # The core detects NaN by comparisons, which raise the invalid-operation flag: the debug
    # suite's trap (ROTORCABLE_FPE_TRAP=1, pydriver.core._FpeTrapped) would turn the detection
    # itself into SIGFPE, so this call goes to the core untrapped.
    monkeypatch.setattr(core_module, "_api", core_module._rotorcable.rotorcable_api)
    core = closed_chain.core
    q = np.array(closed_chain.q0, float)
    lam = np.zeros(core.nc)
    assert np.any(core.modal_matrices(q, lam)["M_r"] != 0.0)  # the finite state has matrices
    q[0] = np.nan
    with pytest.raises(pydriver.RunError, match="constraint Jacobian"):
        core.modal_matrices(q, lam)
