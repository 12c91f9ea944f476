"""The cable as a sequence of frames: joint points and per-joint values of the samples shown.

One source for what the report's animation (:mod:`pydriver.animation`) and the ParaView
export (:mod:`pydriver.paraview`) draw, so that both show the same cable.

Joint points come from the time series itself, not from a second evaluation of the model:
body j is a uniform cylinder whose centre of mass lies halfway between its joint point P_j and
the next one P_{j+1} (docs/model.md, "Conventions"), so from the tip P_{n+1} (``tip_x`` ...)
back to clamp A

    P_j = 2 CM_j - P_{j+1},     j = n, ..., 1.

The recursion adds one rounding of the CM per body: for n = 44 the points agree with the
core's own joint points to 1e-15 m (measured against ``extra['shape_joints']`` of a flight run).

Which samples are frames:

* flight: every sample of the last revolution except the last one, which is the first one
  again (the motion is periodic to ``periodic_tol``): 360 frames at ``samples_per_rev = 360``;
* dynamic: every sample, or, for runs with more samples than a view needs, every k-th sample
  with the last one always included (evenly decimated; the caller says how many at most).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pydriver.analyses.registry import reported


@dataclass
class Frames:
    """The cable at the frames shown.

    Attributes
    ----------
    rows : numpy.ndarray
        Time-series row of each frame (0-based).
    t : numpy.ndarray
        Time of each frame [s].
    azimuth_deg : numpy.ndarray or None
        Blade azimuth of each frame (runs with a rotor).
    points : numpy.ndarray
        (frames, n + 1, 3) joint points P_1 (clamp A) ... P_{n+1} (the tip; clamp B if held) [m].
    strain : numpy.ndarray
        (frames, n) jacket strain at joints 1 ... n [-].
    bending : numpy.ndarray
        (frames, n) bending moment at joints 1 ... n [Nm].
    damage : numpy.ndarray or None
        (n,) Miner damage per flight hour of joints 1 ... n (runs with &fatigue) [1/h].
    periodic : bool
        The frames are one revolution that repeats (flight).
    q : numpy.ndarray or None
        (frames, nq) the coordinates [rad] of each frame, where the record at hand holds them (its
        ``*_coord_deg`` columns are q in order, record_columns.coordinate_columns): the bodies'
        orientations follow from them (the cable's twist in the ParaView export).
    """

    rows: np.ndarray
    t: np.ndarray
    azimuth_deg: np.ndarray | None
    points: np.ndarray
    strain: np.ndarray
    bending: np.ndarray
    damage: np.ndarray | None
    periodic: bool
    q: np.ndarray | None = None


def frame_rows(n_rows: int, periodic: bool, max_frames: int) -> np.ndarray:
    """The time-series rows shown: all (less the closing sample of a periodic record), or
    evenly every k-th with the last one included when there are more than ``max_frames``."""
    last = n_rows - 1 if periodic and n_rows > 1 else n_rows
    if last <= max_frames:
        return np.arange(last)
    step = math.ceil(last / max_frames)
    rows = np.arange(0, last, step)
    if not periodic and rows[-1] != last - 1:
        rows = np.append(rows[:-1] if len(rows) >= max_frames else rows, last - 1)
    return rows


def joint_points(ts: dict, n: int, rows=slice(None)) -> np.ndarray:
    """(rows, n + 1, 3) joint points from the time series' centres of mass and tip (see the
    module's doc)."""
    tip = np.column_stack([np.asarray(ts[f"tip_{c}"])[rows] for c in "xyz"])
    p = np.empty((tip.shape[0], n + 1, 3))
    p[:, n] = tip
    for j in range(n - 1, -1, -1):
        cm = np.column_stack([np.asarray(ts[f"{c}{j + 1}"])[rows] for c in "xyz"])
        p[:, j] = 2.0 * cm - p[:, j + 1]
    return p


def _columns_needed(n: int, rotor: bool) -> list[str]:
    names = ["t"] + (["azimuth_deg"] if rotor else [])
    names += [f"{c}{j + 1}" for j in range(n) for c in "xyz"] + ["tip_x", "tip_y", "tip_z"]
    names += [f"strain{j + 1}" for j in range(n)] + [f"bending{j + 1}_Nm" for j in range(n)]
    return names


def _streamed_columns(path, names: list[str], periodic: bool, max_frames: int):
    """Rows and the needed columns of a time series kept on disk only (HDF5), read at the
    frames' rows alone (a run too large for memory is never loaded whole)."""
    import h5py

    from pydriver.netcdf_layout import column_rows, row_count
    with h5py.File(path, "r") as h5:
        rows = frame_rows(row_count(h5), periodic, max_frames)
        return rows, column_rows(h5, names, rows)


def cable_frames(result, max_frames: int, timeseries_path=None) -> Frames | None:
    """The frames of a flight or dynamic run (or a design run's optimum revolution); None for
    runs without a time series.

    Parameters
    ----------
    result : Result
        A flight or dynamic run.
    max_frames : int
        At most this many frames (a periodic record of more samples, or a long dynamic run,
        is decimated evenly).
    timeseries_path : Path, optional
        The run's ``timeseries.h5`` (read at the frames' rows only) or ``timeseries.csv`` when
        the run kept its time series on disk only (``result.timeseries is None``).
    """
    s = result.summary
    # A design run on flight evaluations holds the optimum's revolution (registry.reported).
    entry = reported(s)
    if not entry.integrates:
        return None
    n = int(s["n_bodies"])
    periodic = entry.periodic
    ts = result.timeseries
    rotor = ts is not None and "azimuth_deg" in ts
    if ts is None and timeseries_path is not None and str(timeseries_path).endswith(".csv"):
        from pydriver.output import read_timeseries
        ts = read_timeseries(timeseries_path)        # a CSV holds at most 5e6 values (output.py)
        rotor = "azimuth_deg" in ts
    if ts is None:
        if timeseries_path is None:
            return None
        import h5py
        with h5py.File(timeseries_path, "r") as h5:
            rotor = "azimuth_deg" in h5
        rows, cols = _streamed_columns(timeseries_path, _columns_needed(n, rotor), periodic, max_frames)
        sel = slice(None)
    else:
        rows = frame_rows(len(ts["t"]), periodic, max_frames)
        cols, sel = ts, rows
    table = result.extra.get("tables", {}).get("fatigue.csv")
    damage = np.asarray(table["damage_per_hour"], float) if table is not None else None
    return Frames(rows=rows, t=np.asarray(cols["t"])[sel],
                  azimuth_deg=np.asarray(cols["azimuth_deg"])[sel] if rotor else None,
                  points=joint_points(cols, n, sel),
                  strain=np.column_stack([np.asarray(cols[f"strain{j + 1}"])[sel] for j in range(n)]),
                  bending=np.column_stack([np.asarray(cols[f"bending{j + 1}_Nm"])[sel] for j in range(n)]),
                  damage=damage, periodic=periodic, q=_coordinates(cols, sel))


def _coordinates(cols, sel) -> np.ndarray | None:
    """(frames, nq) coordinates [rad] from the record's ``*_coord_deg`` columns (in q's order), or
    None when the columns at hand do not hold them (a record streamed from HDF5 reads only the
    columns the frames draw)."""
    names = [c for c in cols if str(c).endswith("_coord_deg")]
    if not names:
        return None
    return np.radians(np.column_stack([np.asarray(cols[c], float)[sel] for c in names]))
