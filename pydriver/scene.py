"""The scene of a deck as plain numbers, for independent implementations of the same model.

Benchmark peers (SciPy, Exudyn) and tests build their own model of a deck from this and
start from the same consistent state as rotorcable's integrators, so that differences
between methods are differences of method, not of input.

Conventions (docs/model.md): body j is a uniform cylinder with its frame origin at its
joint point P_j, axis along local z, CM at R_j (0, 0, L_j/2) from P_j, next joint at
R_j (0, 0, L_j).  R_j = R_{j-1} Rz(gamma_j) Ry(beta_j) with R_0 = ``base_rotation`` and
P_1 = ``base_position``.  A locked joint keeps ``locked_angles``; a free joint's
(gamma, beta) are q[first_coord-1], q[first_coord].  Joint torques are
-stiffness (q - rest) - damping qdot per coordinate.  Clamp B (if active) holds the tip
P_{n+1} at ``clamp_position`` and R_n at ``clamp_rotation``.  Loads: weight m g at each
CM; with a turning rotor the equations are written in the hub frame turning at
``rotor_omega`` about the z axis through -rotor_offset (centrifugal, Coriolis and the
couples on the bodies' rotational inertia); the pulse force at the CM of ``pulse_body`` for
pulse_window[0] <= t < pulse_window[1].
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pydriver.analyses.dynamics import start_state
from pydriver.model import Model


@dataclass
class Scene:
    """Bodies, joints, springs, supports, loads and the consistent start of a deck (SI, rad)."""

    n_bodies: int
    n_coords: int
    n_constraints: int
    lengths: np.ndarray
    radii: np.ndarray
    masses: np.ndarray
    inertia: np.ndarray          #: (n, 3) principal inertia about the CM, body axes
    locked: np.ndarray           #: (n,) bool
    locked_angles: np.ndarray    #: (n, 2) gamma, beta of locked joints
    first_coord: np.ndarray      #: (n,) 1-based index of joint j's gamma in q, 0 if locked
    stiffness: np.ndarray
    damping: np.ndarray
    rest: np.ndarray
    base_position: np.ndarray
    base_rotation: np.ndarray
    clamp_active: bool
    clamp_position: np.ndarray
    clamp_rotation: np.ndarray
    gravity: np.ndarray
    rotor_omega: float
    rotor_offset: np.ndarray
    pulse_body: int              #: 1-based, 0 = no pulse
    pulse_force: np.ndarray
    pulse_window: np.ndarray     #: start, end [s]
    tip_force: np.ndarray
    t_end: float
    q0: np.ndarray               #: consistent start coordinates
    v0: np.ndarray               #: consistent start rates


def scene(path) -> Scene:
    """Read a deck (or take a Model) and return its :class:`Scene`, the start made consistent
    (the equilibrium if the deck starts there).

    Raises
    ------
    DeckError
        Bad input.
    RunError
        The start state could not be made consistent.
    """
    m = path if isinstance(path, Model) else Model.from_deck(path)
    d = m.description
    b = d["bodies"]
    i_xx = b.masses * (b.lengths**2 + 3 * b.radii**2) / 12.0          # eq. 4.50
    inertia = np.column_stack([i_xx, i_xx, b.masses * b.radii**2 / 2.0])
    deck = m.deck
    q0, v0 = start_state(m)
    start = m.core.consistent_start(q0, v0)
    nq = m.nq
    clamp = d["clamp"]
    rot = d["rotor"]
    return Scene(n_bodies=m.n_bodies, n_coords=nq, n_constraints=m.nc, lengths=b.lengths, radii=b.radii,
                 masses=b.masses, inertia=inertia, locked=b.locked,
                 locked_angles=np.column_stack([np.radians(deck["shape.gamma_deg"]),
                                                np.radians(deck["shape.beta_deg"])]),
                 first_coord=d["first_coord"], stiffness=d["stiffness"], damping=d["damping"], rest=d["rest"],
                 base_position=np.zeros(3), base_rotation=d["base_rotation"], clamp_active=clamp is not None,
                 clamp_position=clamp[0] if clamp else np.zeros(3),
                 clamp_rotation=clamp[1] if clamp else np.zeros((3, 3)),
                 gravity=np.asarray(deck["loads.gravity"], float),
                 rotor_omega=float(rot["params"][0]) if rot else 0.0,
                 rotor_offset=np.asarray(deck["loads.rotor_offset"], float),
                 pulse_body=int(deck["loads.pulse_body"]), pulse_force=np.asarray(deck["loads.pulse_force"], float),
                 pulse_window=np.array([deck["loads.pulse_start"], deck["loads.pulse_end"]]),
                 tip_force=np.asarray(deck["loads.tip_force"], float), t_end=float(deck["solver.t_end"]),
                 q0=start["q"], v0=start["v"])
