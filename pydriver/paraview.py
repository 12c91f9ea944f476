"""ParaView export (``rotorcable run DECK --vtk``): the cable as a time series of line meshes.

Files, in the run directory:

* ``cable.pvd``: the collection ParaView opens (File > Open ``cable.pvd``), one entry per
  frame with its time [s];
* ``cable_0000.vtu`` ... : the cable at one frame: the n + 1 joint points P_1 (clamp A) ...
  P_{n+1} (the tip, clamp B if held) joined by n line cells (body j from P_j to P_{j+1}), with
  point data ``strain`` (jacket strain [-]), ``bending_Nm`` (bending moment [Nm]), ``joint``
  (1 ... n + 1) and, with &fatigue, ``damage_per_hour`` (Miner damage per flight hour
  [1/h]).  The tip is no joint of the chain and carries no joint load of its own: it repeats
  joint n's values, so the last body shows one colour.  Points are stored as float64 (binary,
  zlib), exactly the numbers of the time series' joint points.

Which frames: a flight run's every sample of its last revolution (less the closing sample,
which is the first again): 360 files at ``samples_per_rev = 360``; a dynamic run's every
sample up to :data:`MAX_FRAMES`, beyond that every k-th sample evenly with the last one
(the 1 s decay sampled at 0.2 ms: 835 files of its 5001 samples).  Each file of an n = 44
cable is ~4.5 kB (the main job's 360: 1.6 MB).

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

from pydriver.frames import cable_frames

#: At most this many frames (files) of a dynamic run.
MAX_FRAMES = 1000


def _point_data(frames, k: int) -> dict:
    def with_tip(values):
        return np.append(values, values[-1])          # the tip repeats joint n (module doc)

    data = {"strain": with_tip(frames.strain[k]), "bending_Nm": with_tip(frames.bending[k]),
            "joint": np.arange(1, frames.points.shape[1] + 1, dtype=np.int32)}
    if frames.damage is not None:
        data["damage_per_hour"] = with_tip(frames.damage)
    return data


def write_vtk(result, run_dir, timeseries_path=None) -> list[str]:
    """Write ``cable.pvd`` and ``cable_NNNN.vtu`` into the run directory (before commit) and
    list them in ``result.files``; returns the names (none for a run without a time series).

    Parameters
    ----------
    result : Result
        A flight or dynamic run.
    run_dir : RunDirectory
        Where the files go (its temporary directory until the run commits).
    timeseries_path : Path, optional
        The run's ``timeseries.h5`` or ``.csv`` when the time series was kept on disk only.
    """
    import meshio
    frames = cable_frames(result, MAX_FRAMES, timeseries_path)
    if frames is None:
        return []
    n = frames.points.shape[1] - 1
    cells = [("line", np.column_stack([np.arange(n), np.arange(1, n + 1)]).astype(np.int64))]
    names, entries = [], []
    for k in range(len(frames.rows)):
        name = f"cable_{k:04d}.vtu"
        meshio.write_points_cells(run_dir.path(name), frames.points[k], cells, point_data=_point_data(frames, k),
                                  file_format="vtu")
        names.append(name)
        entries.append(f'    <DataSet timestep="{float(frames.t[k])!r}" group="" part="0" file={quoteattr(name)}/>')
    pvd = ('<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1" byte_order="LittleEndian">\n'
           "  <Collection>\n" + "\n".join(entries) + "\n  </Collection>\n</VTKFile>\n")
    run_dir.path("cable.pvd").write_text(pvd, encoding="utf-8")
    names.insert(0, "cable.pvd")
    for name in names:
        result.files[name] = Path(run_dir.out) / name
    return names
