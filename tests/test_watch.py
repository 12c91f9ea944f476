"""Watch the cable (issue 22, item 6): the ParaView export and the report's animation show the
time series' own cable.

The flight deck is the main job's (uh60_part2_forward_flight_cable) at its deck n = 11
without refinement, for speed; the report's size at n = 44 is extrapolated here from the
embedded data's size per joint point and measured in README.md ("Watch it").
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

import meshio
import numpy as np
import pytest

import pydriver
from conftest import INPUTS
from pydriver.animation import UNIT_M, read_embedded
from pydriver.frames import frame_rows, joint_points
from pydriver.model import Model

FLIGHT = INPUTS / "uh60_part2_forward_flight_cable.nml"
MB = 1.0e6


def _flight_model():
    return Model.from_deck(FLIGHT).with_changes({"refinement.levels": 1})


@pytest.fixture(scope="module")
def flight(tmp_path_factory):
    out = tmp_path_factory.mktemp("watch") / "run"
    res = pydriver.run_deck(_flight_model(), out=out, report=True, vtk=True)
    return res, out


def _pvd(out):
    """(time [s], file name) of every entry of cable.pvd."""
    root = ET.parse(out / "cable.pvd").getroot()
    return [(float(d.get("timestep")), d.get("file")) for d in root.iter("DataSet")]


def test_flight_writes_one_file_per_sample_of_the_revolution(flight):
    """360 samples per revolution: 360 frames (the 361st sample is the first again), each
    file listed in the pvd, in result.files and in the run's marker."""
    res, out = flight
    entries = _pvd(out)
    n_rows = len(res.timeseries["t"])
    assert n_rows == 361 and len(entries) == 360
    assert [f for _, f in entries] == [f"cable_{k:04d}.vtu" for k in range(360)]
    assert {f for _, f in entries} | {"cable.pvd"} <= set(res.files)
    assert all((out / f).is_file() for _, f in entries)
    assert [t for t, _ in entries] == [float(t) for t in res.timeseries["t"][:360]]


@pytest.mark.parametrize("frame", [0, 90, 359])
def test_vtk_frame_reads_back_with_meshio_at_its_time(flight, frame):
    """The file of the frame at time t holds the joint points of the time-series row at t.
    Points are stored as float64 in binary: equal to the bit (tolerance 0), and to the core's
    own joint points to 1e-14 m (the CM recursion of pydriver.frames: one rounding per body)."""
    res, out = flight
    ts = res.timeseries
    n = res.summary["n_bodies"]
    t, name = _pvd(out)[frame]
    row = int(np.flatnonzero(ts["t"] == t)[0])                 # the time picks the row, exactly
    mesh = meshio.read(out / name)
    assert mesh.points.dtype == np.float64 and mesh.points.shape == (n + 1, 3)
    np.testing.assert_array_equal(mesh.points, joint_points(ts, n, [row])[0])
    np.testing.assert_allclose(mesh.points, res.extra["shape_joints"][:, :, row].T, rtol=0, atol=1e-14)
    assert [c.type for c in mesh.cells] == ["line"] and len(mesh.cells[0].data) == n
    strain = [ts[f"strain{j + 1}"][row] for j in range(n)]
    np.testing.assert_array_equal(mesh.point_data["strain"], strain + strain[-1:])   # tip repeats joint n
    bending = [ts[f"bending{j + 1}_Nm"][row] for j in range(n)]
    np.testing.assert_array_equal(mesh.point_data["bending_Nm"], bending + bending[-1:])
    damage = list(res.extra["tables"]["fatigue.csv"]["damage_per_hour"])
    np.testing.assert_array_equal(mesh.point_data["damage_per_hour"], damage + damage[-1:])


def test_animation_data_match_the_time_series(flight):
    """Frames, positions (0.1 mm integers: within half a unit), strain and damage (3
    significant digits: within 0.5 % relative) and the azimuth slider (0.1 deg) as in the
    time series and the fatigue table."""
    res, out = flight
    ts = res.timeseries
    n = res.summary["n_bodies"]
    data = read_embedded((out / "report.html").read_text(encoding="utf-8"))
    assert data["n"] == n and len(data["p"]) == len(ts["t"]) - 1 == 360
    assert data["rows"] == list(range(360))
    p = np.asarray(data["p"], float).reshape(360, n + 1, 3) * data["unit_m"]
    assert data["unit_m"] == UNIT_M
    exact = res.extra["shape_joints"][:, :, :360].transpose(2, 1, 0)
    assert np.max(np.abs(p - exact)) <= 0.5 * UNIT_M + 1e-12
    strain = np.column_stack([ts[f"strain{j + 1}"][:360] for j in range(n)])
    np.testing.assert_allclose(np.asarray(data["strain"]), strain, rtol=5e-3, atol=0)
    np.testing.assert_allclose(data["strain_max"], strain.max(), rtol=5e-3)
    np.testing.assert_allclose(data["damage"], res.extra["tables"]["fatigue.csv"]["damage_per_hour"], rtol=5e-3)
    assert np.max(np.abs(np.asarray(data["axis"]["values"]) - ts["azimuth_deg"][:360])) <= 0.05 + 1e-9
    hub = np.asarray(data["hub"]) * UNIT_M
    np.testing.assert_allclose(hub, res.summary["rotor"]["centre_m"], atol=0.5 * UNIT_M)
    assert data["clamp_b"] is True


def test_report_is_self_contained_and_small(flight):
    """No outside script, stylesheet or CDN; under 5 MB at n = 11, and the animation's data
    extrapolated to n = 44 (size proportional to the joint points) keep it under 5 MB too."""
    _, out = flight
    page = (out / "report.html").read_text(encoding="utf-8")
    assert "<script src" not in page and "<link" not in page
    assert "http://" not in page and "https://" not in page
    assert "id='cable-canvas'" in page and "id='cable-slider'" in page and "id='cable-play'" in page
    size = len(page.encode())
    start = page.index('id="cable-data">')
    embedded = len(page[start:page.index("</script>", start)].encode())
    n = 11
    at_44 = size - embedded + embedded * (44 + 1) / (n + 1)
    assert size < 5 * MB and at_44 < 5 * MB, (size, at_44)


def test_frame_rows():
    """A periodic record drops its closing sample; a long dynamic run is decimated evenly to at
    most max_frames, first and last sample included."""
    np.testing.assert_array_equal(frame_rows(361, True, 720), np.arange(360))
    np.testing.assert_array_equal(frame_rows(501, False, 1000), np.arange(501))
    rows = frame_rows(5001, False, 1000)
    assert len(rows) <= 1000 and rows[0] == 0 and rows[-1] == 5000
    assert len(set(np.diff(rows[:-1]))) == 1
    rows = frame_rows(2001, False, 1000)
    assert len(rows) <= 1000 and rows[-1] == 2000


@pytest.mark.parametrize("fmt", ["hdf5", "csv"])
def test_dynamic_run_streamed_to_disk_animates_from_the_file(fmt, tmp_path, monkeypatch):
    """A dynamic run whose time series stays on disk only (too large for memory) reads its
    frames back from the file: the same animation data and VTK points as in memory."""
    model = Model.from_deck(INPUTS / "six_link_dynamic.nml").with_changes({"solver.t_end": 0.3,
                                                                          "solver.output_format": fmt})
    ref = pydriver.run_deck(model, out=tmp_path / "memory", report=True, vtk=True)
    from pydriver.analyses import dynamics
    monkeypatch.setattr(dynamics, "MEMORY_LIMIT", 0.0)
    res = pydriver.run_deck(model, out=tmp_path / "disk", report=True, vtk=True)
    assert res.timeseries is None and ("timeseries.h5" if fmt == "hdf5" else "timeseries.csv") in res.files
    a = read_embedded((tmp_path / "memory" / "report.html").read_text(encoding="utf-8"))
    b = read_embedded((tmp_path / "disk" / "report.html").read_text(encoding="utf-8"))
    assert a == b and len(a["p"]) == len(ref.timeseries["t"]) and a["axis"]["label"] == "t"
    last = f"cable_{len(a['p']) - 1:04d}.vtu"
    np.testing.assert_array_equal(meshio.read(tmp_path / "disk" / last).points,
                                  meshio.read(tmp_path / "memory" / last).points)


def test_a_failed_export_leaves_nothing(tmp_path, monkeypatch):
    """The files go through the run directory: an export that fails half-way leaves no
    output directory and no temporary behind."""
    calls = []

    def failing(*args, **kwargs):
        calls.append(1)
        if len(calls) == 5:
            raise OSError("disk full (simulated)")
        return write(*args, **kwargs)

    write = meshio.write_points_cells
    monkeypatch.setattr(meshio, "write_points_cells", failing)
    with pytest.raises(OSError, match="simulated"):
        pydriver.run_deck(_flight_model(), out=tmp_path / "run", vtk=True)
    assert list(tmp_path.iterdir()) == []


def test_static_run_writes_its_equilibrium(tmp_path):
    """--vtk on a static run (issue 35: it wrote nothing and said nothing): cable.pvd with one
    frame at t = 0, the table's joint points and the tip, exactly (float64, tolerance 0), with
    the table's strain and bending moment; the report has no animation (nothing moves)."""
    res = pydriver.run_deck(INPUTS / "six_link_static.nml", out=tmp_path / "run", report=True, vtk=True)
    assert _pvd(tmp_path / "run") == [(0.0, "cable_0000.vtu")]
    assert {"cable.pvd", "cable_0000.vtu"} <= set(res.files)
    mesh = meshio.read(tmp_path / "run" / "cable_0000.vtu")
    t = res.table
    expected = np.vstack([np.column_stack([t["joint_x_m"], t["joint_y_m"], t["joint_z_m"]]), res.summary["tip_m"]])
    np.testing.assert_array_equal(mesh.points, expected)
    np.testing.assert_array_equal(mesh.point_data["strain"], np.append(t["strain"], t["strain"][-1]))
    np.testing.assert_array_equal(mesh.point_data["bending_Nm"], np.append(t["bending_Nm"], t["bending_Nm"][-1]))
    assert read_embedded((tmp_path / "run" / "report.html").read_text(encoding="utf-8")) is None


def _mode_frames(out, k):
    """(timesteps, meshes) of mode<k>.pvd."""
    root = ET.parse(out / f"mode{k}.pvd").getroot()
    entries = [(float(d.get("timestep")), d.get("file")) for d in root.iter("DataSet")]
    return [t for t, _ in entries], [meshio.read(out / f) for _, f in entries]


@pytest.fixture(scope="module")
def modal(tmp_path_factory):
    out = tmp_path_factory.mktemp("modes") / "run"
    return pydriver.run_deck(INPUTS / "uh60_part2_modal.nml", out=out, vtk=True), out


def test_modal_run_writes_each_mode_as_one_period(modal):
    """mode1.pvd ... mode12.pvd (the lowest 12 of 14 modes), 24 frames each at timesteps 0,
    1/24 ... 23/24 of the period, beside the equilibrium's cable.pvd."""
    res, out = modal
    assert len(res.summary["frequencies_hz"]) == 14
    pvds = sorted(n for n in res.files if n.startswith("mode") and n.endswith(".pvd"))
    assert pvds == sorted(f"mode{k}.pvd" for k in range(1, 13)) and "cable.pvd" in res.files
    for k in (1, 12):
        times, meshes = _mode_frames(out, k)
        assert times == [i / 24 for i in range(24)] and len(meshes) == 24
        assert f"{res.summary['frequencies_hz'][k - 1]:.6g} Hz" in (out / f"mode{k}.pvd").read_text()


@pytest.mark.parametrize("k", [1, 2, 5])
def test_mode_frames_are_the_mode_shape(modal, k):
    """Frame theta is P* + a cos(theta) d of the undamped mode's joint displacement d: the frame
    at 180 deg is the one at 0 mirrored, at 90 deg the equilibrium (cos 90 deg = 6e-17), the
    largest displacement 10 % of the 0.59 m cable (to round-off), clamp A and clamp B still
    (below 1e-8 m: central differences with a 1e-6 rad step, measured 1e-9).  The centres of
    mass between the joint points move as modes.csv says (its columns scaled to a largest
    component of 1): central differences of the same kinematics, to 1e-5 (modes.csv steps
    1e-6 along the mass-normalised shape, whose truncation error O(h^2) was measured at up to
    2.2e-7 here; it does not depend on the CPU)."""
    res, out = modal
    _, meshes = _mode_frames(out, k)
    d = [m.point_data["displacement_m"] for m in meshes]
    rest = meshio.read(out / "cable_0000.vtu").points
    np.testing.assert_allclose(meshes[0].points, rest + d[0], rtol=0, atol=1e-15)
    np.testing.assert_allclose(d[12], -d[0], rtol=0, atol=1e-15)
    assert np.max(np.abs(d[6])) < 1e-15
    assert max(np.max(np.linalg.norm(x, axis=1)) for x in d) == pytest.approx(0.1 * 0.590, rel=1e-12)
    assert np.linalg.norm(d[0][0]) == 0.0 and np.linalg.norm(d[0][-1]) < 1e-8
    cm = 0.5 * (d[0][:-1] + d[0][1:])
    cm = cm / np.max(np.abs(cm))
    modes = res.extra["modes"]
    n = res.summary["n_bodies"]
    table = np.array([[modes[f"d{c}{j + 1}"][k - 1] for c in "xyz"] for j in range(n)])
    np.testing.assert_allclose(cm, table, rtol=0, atol=1e-5)


def test_campbell_run_writes_its_tracked_modes_at_the_operating_speed(tmp_path):
    """The Campbell deck (6 tracked modes, operating range 0 ... 500 rpm): mode1.pvd ...
    mode6.pvd about the equilibrium at the top of the range, 500 rpm, named in each file; each
    frame's largest displacement is 10 % of the cable, clamp B still (below 1e-8 m)."""
    model = Model.from_deck(INPUTS / "uh60_part2_campbell.nml").with_changes({"campbell.n_speeds": 3})
    res = pydriver.run_deck(model, out=tmp_path / "run", vtk=True)
    pvds = sorted(n for n in res.files if n.endswith(".pvd"))
    assert pvds == sorted(f"mode{k}.pvd" for k in range(1, 7))
    for k in (1, 6):
        assert "at 500 rpm" in (tmp_path / "run" / f"mode{k}.pvd").read_text()
        _, meshes = _mode_frames(tmp_path / "run", k)
        d = [m.point_data["displacement_m"] for m in meshes]
        assert max(np.max(np.linalg.norm(x, axis=1)) for x in d) == pytest.approx(0.059, rel=1e-12)
        assert max(np.linalg.norm(x[-1]) for x in d) < 1e-8


def test_the_vtk_cells_carry_each_bodys_orientation_and_the_points_the_jacket_radius(tmp_path):
    """Issue 37: the ParaView files show the cable's twist and its thickness.  Each body's cell
    data ``axis`` is the unit vector from its joint point to the next (the body's e3: the same
    kinematics, so to round-off, 1e-12), ``normal`` is a unit vector orthogonal to it (the body's e1,
    turning with the twist), and ``radius_m`` is half the deck's diameter at every point."""
    import meshio
    deck = INPUTS / "uh60_part2_forward_flight_cable.nml"
    model = pydriver.Model.from_deck(deck).with_changes({"refinement.levels": 1, "solver.floquet": False,
                                                        "solver.samples_per_rev": 36})
    pydriver.run_deck(model, out=tmp_path / "run", vtk=True)
    mesh = meshio.read(tmp_path / "run" / "cable_0005.vtu")
    p = mesh.points
    chord = (p[1:] - p[:-1]) / np.linalg.norm(p[1:] - p[:-1], axis=1)[:, None]
    axis, normal = mesh.cell_data["axis"][0], mesh.cell_data["normal"][0]
    assert np.max(np.abs(axis - chord)) < 1e-12
    assert np.max(np.abs(np.sum(axis * normal, axis=1))) < 1e-12
    assert np.max(np.abs(np.linalg.norm(normal, axis=1) - 1.0)) < 1e-12
    assert np.allclose(mesh.point_data["radius_m"], 0.0075, rtol=1e-12)     # diameter 0.015 m
