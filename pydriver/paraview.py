"""ParaView export (``rotorcable run DECK --vtk``): the cable as series of line meshes.

Files, in the run directory:

* ``cable.pvd``: the collection ParaView opens (File > Open ``cable.pvd``), one entry per
  frame with its time [s];
* ``cable_0000.vtu`` ... : the cable at one frame: the n + 1 joint points P_1 (clamp A) ...
  P_{n+1} (the tip, clamp B if held) joined by n line cells (body j from P_j to P_{j+1}), with
  point data ``strain`` (jacket strain [-]), ``bending_Nm`` (bending moment [Nm]), ``joint``
  (1 ... n + 1) and, with &fatigue, ``damage_per_hour`` (Miner damage per flight hour
  [1/h]).  The tip is no joint of the chain and carries no joint load of its own: it repeats
  joint n's values, so the last body shows one colour.  Point data ``radius_m`` is the jacket's
  radius (ParaView: Extract Surface, Tube, "Vary radius: by absolute scalar" draws the cable to
  scale).  Cell data per body (issue 37): ``axis``, the body's axis e3 (along it), and ``normal``,
  its axis e1, which turns with the cable's twist (a Glyph of ``normal`` at the cell centres shows
  the twist), from the kinematics at the frame's coordinates (where the record at hand holds them:
  an in-memory or CSV time series, a static or modal equilibrium).  Points are stored as float64
  (binary, zlib), exactly the numbers of the time series' joint points.
* ``mode<k>.pvd`` and ``mode<k>_00.vtu`` ... ``mode<k>_23.vtu`` (modal and Campbell runs): mode
  k as an animation of one period in :data:`MODE_FRAMES` frames: the equilibrium's joint points
  P* plus a Re(d_k e^{i theta}), theta = 0, 15, ... 345 deg, where d_k is the joint points'
  first-order displacement along the mode (the linearised motion the mode is, as ParaView's
  Warp By Vector shows a displacement: clamp B holds exactly, a body's length changes at second
  order); ``timestep`` theta / 360 deg (ParaView's Play loops it).  The amplitude a puts the
  largest joint-point displacement at :data:`MODE_AMPLITUDE` of the cable's length (a visible
  shape; a mode's own amplitude is arbitrary).  Point data ``displacement_m`` (each joint
  point's displacement from the equilibrium [m], a vector), ``joint`` and ``radius_m``, and cell
  data ``axis`` and ``normal`` at q* + a Re(phi e^(i theta)); a comment in the collection gives
  the mode's frequency and the scale.  A pure twist mode moves no joint point: its frames show it
  by the bodies' normals, turned by up to :data:`TWIST_AMPLITUDE`.

Which frames: a flight run's every sample of its last revolution (less the closing sample,
which is the first again): 360 files at ``samples_per_rev = 360``; a dynamic run's every
sample up to :data:`MAX_FRAMES`, beyond that every k-th sample evenly with the last one
(the 1 s decay sampled at 0.2 ms: 835 files of its 5001 samples).  Each file of an n = 44
cable is ~4.5 kB (the main job's 360: 1.6 MB).  A static run (and a design run on static or
modal evaluations): its equilibrium, one frame at t = 0.  A modal run: its equilibrium and its
first :data:`MAX_MODES` modes (undamped shapes, by frequency).  A Campbell run: its tracked
modes (damped, complex shapes: Coriolis coupling turns them into whirls) about the equilibrium
at one speed of its grid, the one nearest the operating speed (a single &campbell operating_rpm,
else the top of the operating range), named in the collection's comment.  A design run on
flight evaluations: the optimum's revolution.

Why meshio and why ``.vtu``, not ``.vtp``: the issue asks for a well-kept library (meshio or
pyevtk) and a test that reads the files back with meshio.  meshio 5.3 neither writes nor reads
VTK PolyData (``.vtp``; nschloe/meshio#1181 is an open draft since 2021), and it has no
polyline cell; pyevtk writes ``.vtp`` but meshio could not read it back.  An unstructured grid
of line cells is what meshio writes and reads, and ParaView draws and colours it like a
polyline (for tubes: Extract Surface, then Tube).  The ``.pvd`` collection is a five-line XML
file that meshio does not write (it has XDMF time series instead), so it is written here.
"""

from __future__ import annotations

from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np

from pydriver.analyses.registry import sections_of
from pydriver.frames import Frames, cable_frames

#: At most this many frames (files) of a dynamic run.
MAX_FRAMES = 1000
#: Frames of one period of a mode (15 deg apart: smooth at ParaView's frame rate).
MODE_FRAMES = 24
#: The largest joint-point displacement of a mode's frames, as a fraction of the cable's length.
MODE_AMPLITUDE = 0.1
#: Modes written of a modal run (the lowest; report.html lists as many).
MAX_MODES = 12
#: The largest coordinate change [rad] of a pure twist mode's frames (it moves no joint point).
TWIST_AMPLITUDE = 0.5


def _point_data(frames, k: int, radius=None) -> dict:
    def with_tip(values):
        return np.append(values, values[-1])          # the tip repeats joint n (module doc)

    data = {"strain": with_tip(frames.strain[k]), "bending_Nm": with_tip(frames.bending[k]),
            "joint": np.arange(1, frames.points.shape[1] + 1, dtype=np.int32)}
    if frames.damage is not None:
        data["damage_per_hour"] = with_tip(frames.damage)
    if radius is not None:
        data["radius_m"] = radius
    return data


def _tube_radius(model, n: int) -> np.ndarray:
    """The jacket radius at each of the n + 1 points [m] (the joints' diameter, the tip the last
    body's): ParaView's Tube filter draws the cable to scale with "Vary radius: by scalar"."""
    from pydriver.analyses.common import joint_geometry
    d = joint_geometry(model)["diameter"]
    tip = 2.0 * float(model.description["bodies"].radii[-1])
    return 0.5 * np.append(d, tip)[: n + 1]


def _body_axes(model, q, t: float = 0.0) -> dict:
    """Cell data of one frame: each body's axes in the model frame, ``axis`` (e3, along the body)
    and ``normal`` (e1, which turns with the twist: a Glyph of it shows the cable's twist)."""
    rot = model.core.shape(q, t)["rotations"]
    return {"axis": [np.ascontiguousarray(rot[:, :, 2])], "normal": [np.ascontiguousarray(rot[:, :, 0])]}


def _series(run_dir, result, stem: str, points, point_data, timesteps, comment: str = "",
            cell_data=None) -> list[str]:
    """``<stem>.pvd`` and ``<stem>_NNNN.vtu`` (NN for a mode's 24 frames) of the frames
    ``points[k]`` (n + 1, 3) with ``point_data(k)`` and, where given, ``cell_data(k)`` (per body);
    listed in ``result.files``."""
    import meshio
    n = points[0].shape[0] - 1
    cells = [("line", np.column_stack([np.arange(n), np.arange(1, n + 1)]).astype(np.int64))]
    digits = 4 if stem == "cable" else 2
    names, entries = [], []
    for k, (p, t) in enumerate(zip(points, timesteps)):
        name = f"{stem}_{k:0{digits}d}.vtu"
        meshio.write_points_cells(run_dir.path(name), np.asarray(p, float), cells, point_data=point_data(k),
                                  cell_data=cell_data(k) if cell_data is not None else None, file_format="vtu")
        names.append(name)
        entries.append(f'    <DataSet timestep="{float(t)!r}" group="" part="0" file={quoteattr(name)}/>')
    note = f"<!-- {comment.replace('--', '-')} -->\n" if comment else ""
    pvd = ('<?xml version="1.0"?>\n' + note + '<VTKFile type="Collection" version="0.1" byte_order="LittleEndian">\n'
           "  <Collection>\n" + "\n".join(entries) + "\n  </Collection>\n</VTKFile>\n")
    run_dir.path(f"{stem}.pvd").write_text(pvd, encoding="utf-8")
    names.insert(0, f"{stem}.pvd")
    for name in names:
        result.files[name] = Path(run_dir.out) / name
    return names


def equilibrium_frames(result) -> Frames | None:
    """The equilibrium of a static run (or of a design run's optimum, modal runs alike) as one
    frame at t = 0: the table's joint points and the tip, its strain and bending moment."""
    t = result.table
    if t is None or "joint_x_m" not in t or "tip_m" not in result.summary:
        return None
    points = np.column_stack([t["joint_x_m"], t["joint_y_m"], t["joint_z_m"]])
    points = np.vstack([points, np.asarray(result.summary["tip_m"], float)])
    q = result.extra.get("q")
    return Frames(rows=np.zeros(1, int), t=np.zeros(1), azimuth_deg=None, points=points[None],
                  strain=np.asarray(t["strain"], float)[None], bending=np.asarray(t["bending_Nm"], float)[None],
                  damage=None, periodic=False, q=None if q is None else np.asarray(q, float)[None])


def _model_at(model, n: int):
    """The deck's model at n bodies (a refined run's result is that of its finest level)."""
    if model.n_bodies == n:
        return model
    from pydriver.analyses.refinement import refined_deck
    from pydriver.model import Model
    return Model(refined_deck(model.deck, n // model.n_bodies))


def mode_frames(model, q, shape) -> tuple[list, list, float]:
    """The joint points of one period of a mode (module doc), their displacements from the
    equilibrium, and the largest displacement per unit modal coordinate [m] (the scale).

    Parameters
    ----------
    model : Model
        The model the mode is of (its number of bodies).
    q : numpy.ndarray
        The equilibrium [rad].
    shape : numpy.ndarray
        The mode in q, real (undamped) or complex (damped), at any scale.
    """
    shape = np.asarray(shape, complex)
    shape = shape / max(float(np.max(np.abs(shape))), np.finfo(float).tiny)
    joints = lambda x: np.asarray(model.core.shape(np.asarray(x, float))["joints"], float)     # noqa: E731
    rest = joints(q)
    # The joint points' first-order displacement along the real and imaginary parts: central
    # differences of the kinematics (as modes.csv's CM displacements), step 1e-6 rad.
    h = 1.0e-6
    d_re = (joints(q + h * shape.real) - joints(q - h * shape.real)) / (2.0 * h)
    d_im = (joints(q + h * shape.imag) - joints(q - h * shape.imag)) / (2.0 * h)
    theta = 2.0 * np.pi * np.arange(MODE_FRAMES) / MODE_FRAMES
    moved = [np.cos(a) * d_re - np.sin(a) * d_im for a in theta]
    reach = max(float(np.max(np.linalg.norm(d, axis=1))) for d in moved)
    length = float(np.sum(model.description["bodies"].lengths))
    scale = MODE_AMPLITUDE * length / reach if reach > 0.0 else 0.0
    moved = [scale * d for d in moved]
    return [rest + d for d in moved], moved, reach


def mode_coordinates(q, shape, reach: float, length: float) -> list:
    """The coordinates of a mode's frames (:func:`mode_frames`' scale), for the bodies'
    orientations: q* + a Re(phi e^(i theta)); a pure twist mode, which moves no joint point, is
    shown at a twist of TWIST_AMPLITUDE rad (its turn is all there is to see)."""
    shape = np.asarray(shape, complex)
    shape = shape / max(float(np.max(np.abs(shape))), np.finfo(float).tiny)
    a = MODE_AMPLITUDE * length / reach if reach > 0.0 else TWIST_AMPLITUDE
    theta = 2.0 * np.pi * np.arange(MODE_FRAMES) / MODE_FRAMES
    return [np.asarray(q, float) + a * (np.cos(t) * shape.real - np.sin(t) * shape.imag) for t in theta]


def _write_modes(result, run_dir, model) -> list[str]:
    """mode<k>.pvd of a modal run (its undamped shapes) or a Campbell run (its tracked shapes at
    one speed)."""
    s = result.summary
    if "modes" in sections_of(s) and "mode_shapes_q" in result.extra:
        q, shapes = result.extra["q"], result.extra["mode_shapes_q"][:, :MAX_MODES]
        freqs, where = s["frequencies_hz"], "undamped, about the equilibrium"
    elif "campbell" in sections_of(s) and "mode_shapes" in result.extra:
        m = result.extra["mode_shapes"]
        q, shapes, freqs = m["q"], m["shapes"], m["f_hz"]
        where = f"damped, tracked, about the equilibrium at {m['rpm']:g} rpm (of the diagram's grid)"
    else:
        return []
    model = _model_at(model, int(s["n_bodies"]))
    length = float(np.sum(model.description["bodies"].lengths))
    radius = _tube_radius(model, model.n_bodies)
    names = []
    for k in range(shapes.shape[1]):
        points, moved, reach = mode_frames(model, q, shapes[:, k])
        turned = mode_coordinates(q, shapes[:, k], reach, length)
        joint = np.arange(1, points[0].shape[0] + 1, dtype=np.int32)
        comment = (f"mode {k + 1}, {float(freqs[k]):.6g} Hz ({where}); frames: joint points P* + a Re(d e^(i theta)), "
                   f"d their first-order displacement, timestep = theta / 360 deg, the largest displacement "
                   f"{MODE_AMPLITUDE:g} of the cable's length" + ("" if reach > 0.0 else
                                                                   f" (none: a twist mode, shown by the bodies' "
                                                                   f"normals turned {TWIST_AMPLITUDE:g} rad)"))
        names += _series(run_dir, result, f"mode{k + 1}", points,
                         lambda i, moved=moved: {"displacement_m": moved[i], "joint": joint, "radius_m": radius},
                         np.arange(MODE_FRAMES) / MODE_FRAMES, comment,
                         cell_data=lambda i, turned=turned: _body_axes(model, turned[i]))
    return names


def write_vtk(result, run_dir, timeseries_path=None, model=None) -> list[str]:
    """Write the run's ParaView files into the run directory (before commit) and list them in
    ``result.files``; returns the names.

    Parameters
    ----------
    result : Result
        The run.
    run_dir : RunDirectory
        Where the files go (its temporary directory until the run commits).
    timeseries_path : Path, optional
        The run's ``timeseries.h5`` or ``.csv`` when the time series was kept on disk only.
    model : Model, optional
        The run's model: the mode shapes of a modal or Campbell run are drawn by its kinematics
        (without it, only the cable's own frames are written).
    """
    frames = cable_frames(result, MAX_FRAMES, timeseries_path) or equilibrium_frames(result)
    names = []
    if frames is not None:
        n = frames.points.shape[1] - 1
        at_n = _model_at(model, n) if model is not None else None
        radius = _tube_radius(at_n, n) if at_n is not None else None
        cells = None
        if at_n is not None and frames.q is not None:
            cells = lambda k: _body_axes(at_n, frames.q[k], float(frames.t[k]))      # noqa: E731
        names += _series(run_dir, result, "cable", frames.points, lambda k: _point_data(frames, k, radius), frames.t,
                         cell_data=cells)
    if model is not None:
        names += _write_modes(result, run_dir, model)
    return names
