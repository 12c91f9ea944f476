"""Time series to HDF5 for long or large runs (issues 10 and 14): the same numbers as the CSV
file, read back by load_results, chosen automatically above the CSV size limit."""

from __future__ import annotations

import re

import numpy as np

import pydriver
from conftest import INPUTS
from pydriver import output
from pydriver.analyses import dynamics


def test_hdf5_holds_the_csv_numbers_and_load_results_reads_it(tmp_path):
    """CSV cells are repr(float) (exact round trip) and HDF5 stores doubles: bit-identical."""
    base = pydriver.Model.from_deck(INPUTS / "six_link_dynamic.nml").with_changes({"solver.t_end": 0.2})
    pydriver.run_deck(base.with_changes({"solver.output_format": "csv"}), out=tmp_path / "csv")
    pydriver.run_deck(base.with_changes({"solver.output_format": "hdf5"}), out=tmp_path / "h5")
    assert (tmp_path / "h5" / "timeseries.h5").is_file() and not (tmp_path / "h5" / "timeseries.csv").exists()
    a = pydriver.load_results(tmp_path / "csv").runs
    b = pydriver.load_results(tmp_path / "h5").runs
    ta, tb = next(iter(a.values())).timeseries, next(iter(b.values())).timeseries
    assert list(ta) == list(tb) and len(ta["t"]) == 201             # dt_out = 1 ms
    for name in ta:
        assert np.array_equal(ta[name], tb[name]), name


def test_auto_switches_to_hdf5_above_the_csv_limit(tmp_path, monkeypatch):
    monkeypatch.setattr(dynamics, "CSV_MAX_VALUES", 100)
    res = pydriver.run_deck(pydriver.Model.from_deck(INPUTS / "six_link_dynamic.nml").with_changes(
        {"solver.t_end": 0.05}), out=tmp_path / "run")
    assert res.summary["timeseries_format"] == "hdf5"
    ts = output.read_timeseries(tmp_path / "run" / "timeseries.h5")
    assert np.array_equal(ts["t"], res.timeseries["t"])


def test_xarray_opens_the_hdf5_time_series(tmp_path):
    """netCDF4 layout (issue 22): xarray opens timeseries.h5 with dimensions time, body, joint,
    component and units as attributes, and its variables hold exactly the CSV columns."""
    import xarray as xr
    base = pydriver.Model.from_deck(INPUTS / "six_link_dynamic.nml").with_changes({"solver.t_end": 0.05})
    res = pydriver.run_deck(base.with_changes({"solver.output_format": "hdf5"}), out=tmp_path / "h5")
    ts = res.timeseries
    with xr.open_dataset(tmp_path / "h5" / "timeseries.h5", engine="h5netcdf") as ds:
        assert {"time", "body", "joint", "component"} <= set(ds.dims)
        assert ds["cm"].dims == ("time", "body", "component") and ds["cm"].attrs["units"] == "m"
        assert ds["F_B"].attrs["units"] == "N" and ds["time"].attrs["units"] == "s"
        assert list(ds["component"].values) == ["x", "y", "z"]
        assert np.array_equal(ds["time"].values, ts["t"])
        assert np.array_equal(ds["cm"].sel(body=3, component="z").values, ts["z3"])
        assert np.array_equal(ds["F_B"].sel(component="z").values, ts["FB_z"])
        assert np.array_equal(ds["bending"].sel(joint=2).values, ts["bending2_Nm"])
        assert np.array_equal(ds["moment"].sel(joint=2, bending_axis="y").values, ts["moment_y2_Nm"])
        assert np.array_equal(ds["E_kin_J"].values, ts["E_kin_J"])
        # Issue 37: every long_name in words, the table's placeholders filled in by the variable.
        names = {v: ds[v].attrs.get("long_name", "") for v in ds.variables}
        for var, text in names.items():
            assert text and not re.search(r"[{}]|\(s = |\b(joint|body) j\b|a = x, y", text), (var, text)
        assert names["F_B"] == "force support B exerts on the chain"
        assert names["M_A"] == "moment support A exerts on the chain about its clamp point"
        assert names["bending"] == "bending moment magnitude at each joint"
        assert names["moment"] == "bending moment at each joint about the joint's local x and y axes"
        assert names["cm"].startswith("centre of mass of each body (")
        coords = [re.fullmatch(r"(\D+)(\d+)_coord_deg", v) for v in names]
        coords = [m for m in coords if m]
        assert coords
        for m in coords:
            assert names[m.group(0)].startswith(f"joint coordinate {m.group(1)} of joint {m.group(2)},"), m.group(0)
