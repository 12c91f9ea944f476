"""The time series carries the joint coordinates the springs act on, unwrapped, and their
rates (issue 22: only the wrapped thesis angles were written, so twist and winding could not be
recovered)."""

from __future__ import annotations

import numpy as np

import pydriver
from conftest import INPUTS
from pydriver.study import override_deck


def test_rates_are_the_derivatives_of_the_coordinates(tmp_path):
    """Independent check: central differences of the coordinate columns over the output
    interval equal the rate columns to the differences' truncation, (omega dt)^2 / 6 of the
    rate.  Checked after the pulse (t > 0.12 s; it ends at 0.1 s, and its edges are jumps of the
    acceleration that central differences smear): there the motion is the decay's first modes,
    26 and 64 Hz, so at dt = 0.1 ms (omega dt)^2 / 6 < 3e-4 (measured 7e-4 with the pulse's
    remnant higher modes).  Bound: 1e-2 of the largest rate, a factor >10 above it."""
    deck = override_deck(INPUTS / "uh60_part2_decay.nml", tmp_path / "d.nml",
                         {"solver": {"t_end": "0.2", "dt_out": "1.0e-4"}})
    ts = pydriver.run_deck(deck).timeseries
    coords = [c for c in ts if c.endswith("_coord_deg")]
    assert coords and all(c.replace("_coord_deg", "_rate_degps") in ts for c in coords)
    t = ts["t"]
    late = t[1:-1] > 0.12
    for c in coords:
        rate = ts[c.replace("_coord_deg", "_rate_degps")]
        fd = ((ts[c][2:] - ts[c][:-2]) / (t[2:] - t[:-2]))[late]
        scale = max(np.max(np.abs(rate[1:-1][late])), 1e-9)
        assert np.max(np.abs(fd - rate[1:-1][late])) < 1e-2 * scale, c


def test_xyz_joints_write_the_twist(tmp_path):
    ts = pydriver.run_deck(pydriver.Model.from_deck(INPUTS / "uh60_part2_forward_flight_cable.nml")
                           .with_changes({"refinement.levels": 1})).timeseries
    twist = [c for c in ts if c.startswith("twist") and c.endswith("_coord_deg")]
    assert len(twist) == 11                      # every joint: &cable clamps A with a spring (2 EI/l)
    assert all(np.all(np.isfinite(ts[c])) for c in twist)
    assert max(np.max(np.abs(ts[c])) for c in twist) > 0.0
