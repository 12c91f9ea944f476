"""Comparison of equilibrium tables with the thesis's appendix tables, as orientations.

The thesis's joint angles are not unique: R_z(gamma + 180) R_y(beta) = R_z(gamma) R_y(-beta)
R_z(180), the extra half turn being absorbed by the next joint's gamma (Table A.5 prints
pairs such as gamma = 180.01, beta = -10.97).  canonical_angles() removes these half turns,
so tables are compared by their bending angles and CM coordinates, not by raw numbers.
"""

from __future__ import annotations

import json

import numpy as np

from conftest import DATA


def thesis_table(name: str) -> np.ndarray:
    """Rows (body, gamma_deg, beta_deg, x, y, z) of thesis table `name` (e.g. 'A.3')."""
    return np.array(json.loads((DATA / "thesis_appendix_A.json").read_text())[name]["rows"], float)


def wrap(a):
    return (np.asarray(a) + 180.0) % 360.0 - 180.0


def canonical_angles(gamma_deg, beta_deg):
    """Joint angles with |gamma| <= 90 deg, half turns carried into the next joint."""
    g_out, b_out = [], []
    carry = 0.0
    for g, b in zip(gamma_deg, beta_deg):
        g = float(wrap(g + carry))
        carry = 0.0
        if abs(g) > 90.0:
            g = float(wrap(g - 180.0))
            b = -b
            carry = 180.0
        g_out.append(g)
        b_out.append(b)
    return np.array(g_out), np.array(b_out)


def bending_vectors(gamma_deg, beta_deg):
    """Bend of every joint as a rotation vector in the (canonical) parent frame [deg].

    beta about the y axis turned by gamma: beta * (-sin gamma, cos gamma).  Well defined
    where beta -> 0 (the bending direction gamma is then meaningless).
    """
    g, b = canonical_angles(gamma_deg, beta_deg)
    gr = np.radians(g)
    return np.column_stack([-b * np.sin(gr), b * np.cos(gr)])
