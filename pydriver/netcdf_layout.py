"""The HDF5 time series (``timeseries.h5``) in netCDF4 conventions, so that
``xarray.open_dataset(path, engine="h5netcdf")`` opens it (issue 22).

Dimensions ``time`` (unlimited: the run streams into it), ``body``, ``joint``, ``component``
(x, y, z) and ``bending_axis`` (x, y of the joint).  The columns of the CSV form become
variables over them: the centres of mass ``cm(time, body, component)``, the reactions
``F_A(time, component)`` ..., the joint loads ``axial(time, joint)`` ..., the bending moment and
curvature components ``moment(time, joint, bending_axis)``; every other column (energies, rotor
angle, joint coordinates and rates) is a variable over ``time`` under its CSV name.  Each
variable carries ``units`` and ``long_name`` attributes (from ``pydriver/output_columns.py``);
the root attribute ``columns`` lists the CSV names in their order, and :func:`read_columns`
gives them back as the flat columns ``load_results`` has always returned.

Written with h5netcdf (PyPI), the netCDF4-on-HDF5 writer xarray reads.
"""

from __future__ import annotations

import json
import re

import numpy as np

from pydriver.output_columns import column_meaning, unit_of

LAYOUT = "rotorcable-netcdf4-1"
_COMPONENTS = ("x", "y", "z")
_AXES = ("x", "y")

#: (variable, dimensions after time, CSV name pattern) of the grouped columns; {j} is the body or
#: joint number, {c} the component, {a} the bending axis.
GROUPS = [
    ("cm", ("body", "component"), "{c}{j}"),
    ("gamma", ("body",), "gamma{j}_deg"),
    ("beta", ("body",), "beta{j}_deg"),
    ("tip", ("component",), "tip_{c}"),
    ("F_A", ("component",), "FA_{c}"),
    ("M_A", ("component",), "MA_{c}"),
    ("F_B", ("component",), "FB_{c}"),
    ("M_B", ("component",), "MB_{c}"),
    ("F_A_on_support", ("component",), "FA_on_support_{c}"),
    ("M_A_on_support", ("component",), "MA_on_support_{c}"),
    ("F_B_on_support", ("component",), "FB_on_support_{c}"),
    ("M_B_on_support", ("component",), "MB_on_support_{c}"),
    ("axial", ("joint",), "axial{j}_N"),
    ("shear", ("joint",), "shear{j}_N"),
    ("bending", ("joint",), "bending{j}_Nm"),
    ("torsion", ("joint",), "torsion{j}_Nm"),
    ("curvature", ("joint",), "curvature{j}_1pm"),
    ("strain", ("joint",), "strain{j}"),
    ("moment", ("joint", "bending_axis"), "moment_{a}{j}_Nm"),
    ("kappa", ("joint", "bending_axis"), "kappa_{a}{j}_1pm"),
]


def _placement(columns: list[str], n: int) -> tuple[dict, list[str]]:
    """{variable: (dims, {column: index tuple})} of the grouped columns present, and the rest."""
    where = {}
    taken = set()
    for var, dims, pattern in GROUPS:
        cells = {}
        for idx in np.ndindex(*[{"body": n, "joint": n, "component": 3, "bending_axis": 2}[d] for d in dims]):
            sub = dict(zip(dims, idx))
            name = pattern.format(j=sub.get("body", sub.get("joint", 0)) + 1,
                                  c=_COMPONENTS[sub.get("component", 0)], a=_AXES[sub.get("bending_axis", 0)])
            cells[name] = idx
        if all(name in columns for name in cells):
            where[var] = (dims, cells)
            taken.update(cells)
    rest = [c for c in columns if c not in taken and c != "t"]
    return where, rest


class NetcdfTimeseries:
    """Streams time-series chunks into ``timeseries.h5`` in the netCDF4 layout."""

    def __init__(self, path, columns: list[str], n_bodies: int):
        import h5netcdf
        import h5py
        self.columns = columns
        self.where, self.rest = _placement(columns, n_bodies)
        # No chunk cache: rows are appended once, in order (h5py's cache only grows memory).
        self.f = h5netcdf.File(path, "w", rdcc_nbytes=0)
        f = self.f
        f.dimensions = {"time": None, "body": n_bodies, "joint": n_bodies, "component": 3, "bending_axis": 2}
        f.attrs["columns"] = json.dumps(columns)
        f.attrs["layout"] = LAYOUT
        f.attrs["Conventions"] = "CF-1.8"
        t = f.create_variable("time", ("time",), "f8", chunks=(16384,))
        t.attrs.update(units="s", long_name="time")
        f.create_variable("body", ("body",), data=np.arange(1, n_bodies + 1)).attrs["long_name"] = \
            "body number, from clamp A"
        f.create_variable("joint", ("joint",), data=np.arange(1, n_bodies + 1)).attrs["long_name"] = \
            "joint number, from clamp A (a joint starts the body of the same number)"
        f.create_variable("component", ("component",), data=np.array(_COMPONENTS, dtype=object),
                          dtype=h5py.string_dtype()).attrs["long_name"] = "vector component along the axis x, y or z"
        f.create_variable("bending_axis", ("bending_axis",), data=np.array(_AXES, dtype=object),
                          dtype=h5py.string_dtype()).attrs["long_name"] = \
            "the joint's local cross-section axis, x or y, a bending component is about"
        self.vars = {}
        for var, (dims, cells) in self.where.items():
            shape = [f.dimensions[d].size for d in dims]
            v = f.create_variable(var, ("time", *dims), "f8", chunks=(max(1, 16384 // int(np.prod(shape))), *shape))
            first = next(iter(cells))
            along = tuple(_PLACEHOLDER_OF[d] for d in dims)
            v.attrs.update(units=unit_of("timeseries.h5", first), long_name=_meaning(first, along))
            self.vars[var] = v
        for c in self.rest:
            v = f.create_variable(c, ("time",), "f8", chunks=(16384,))
            v.attrs.update(units=unit_of("timeseries.h5", c), long_name=_meaning(c))
            self.vars[c] = v
        self.rows = 0

    def write(self, chunk: dict):
        n = len(chunk["t"])
        a, b = self.rows, self.rows + n
        self.f.resize_dimension("time", b)
        self.f.variables["time"][a:b] = chunk["t"]
        for var, (dims, cells) in self.where.items():
            block = np.empty((n, *[self.f.dimensions[d].size for d in dims]))
            for name, idx in cells.items():
                block[(slice(None), *idx)] = chunk[name]
            self.vars[var][a:b] = block
        for c in self.rest:
            self.vars[c][a:b] = chunk[c]
        self.rows = b

    def close(self):
        self.f.close()


#: The placeholder of pydriver/output_columns.py a dimension stands for (its long_name says "each joint").
_PLACEHOLDER_OF = {"body": "j", "joint": "j", "component": "c", "bending_axis": "a"}


def _meaning(name: str, along: tuple = ()) -> str:
    """The long_name of a variable: its column's meaning, filled in (``(s = A, B)`` and ``joint
    j`` are the table's placeholders, not a variable's words)."""
    return re.sub(r"\s+", " ", column_meaning("timeseries.h5", name, along))


def is_netcdf_layout(h5) -> bool:
    """True for a file written by :class:`NetcdfTimeseries` (else the older one dataset per column)."""
    return h5.attrs.get("layout") == LAYOUT


def read_columns(h5) -> dict:
    """The flat CSV columns of a netCDF-layout file (an open ``h5py.File``)."""
    columns = json.loads(h5.attrs["columns"])
    n = h5["body"].shape[0]
    where, rest = _placement(columns, n)
    out = {"t": h5["time"][:]}
    for var, (_, cells) in where.items():
        data = h5[var][:]
        for name, idx in cells.items():
            out[name] = data[(slice(None), *idx)]
    for c in rest:
        out[c] = h5[c][:]
    return {c: out[c] for c in columns}


def column_rows(h5, names: list[str], rows) -> dict:
    """Some CSV columns at some rows of an open ``timeseries.h5`` (either layout), read from
    disk without loading the whole file (a run too large for memory)."""
    if not is_netcdf_layout(h5):
        return {c: h5[c][rows] for c in names}
    columns = json.loads(h5.attrs["columns"])
    where, _ = _placement(columns, h5["body"].shape[0])
    out = {}
    for c in names:
        if c == "t":
            out[c] = h5["time"][rows]
            continue
        var = next((v for v, (_, cells) in where.items() if c in cells), None)
        out[c] = h5[c][rows] if var is None else h5[var][(rows, *where[var][1][c])]
    return out


def row_count(h5) -> int:
    """The number of time samples of an open ``timeseries.h5`` (either layout)."""
    return h5["time"].shape[0] if is_netcdf_layout(h5) else h5["t"].shape[0]
