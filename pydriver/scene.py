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
CM, centrifugal m w^2 (r_x, r_y, 0) with r = CM + rotor_offset when the rotor turns, and
the pulse force at the CM of ``pulse_body`` for pulse_window[0] <= t < pulse_window[1].
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pydriver import _rotorcable
from pydriver.deck import _check, deck_info

_core = _rotorcable.rotorcable_api


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
    """Read a deck and return its :class:`Scene` (start made consistent, equilibrium if asked).

    Raises
    ------
    DeckError
        Bad input.
    RunError
        The start state could not be made consistent.
    """
    path = str(path)
    info = deck_info(path)
    nb, nq = info["n_bodies"], info["n_coords"]
    out = _core.rc_scene(path, nb, nq)
    *arrays, stat, msg = out
    _check(path, stat, msg=msg)
    (lengths, radii, masses, inertia, locked, locked_angles, first_coord, stiffness, damping, rest,
     base_position, base_rotation, clamp_active, clamp_position, clamp_rotation, gravity,
     rotor_omega, rotor_offset, pulse_body, pulse_force, pulse_window, tip_force, t_end, q0,
     v0) = arrays
    return Scene(n_bodies=nb, n_coords=nq, n_constraints=info["n_constraints"],
                 lengths=lengths, radii=radii, masses=masses, inertia=inertia,
                 locked=locked.astype(bool), locked_angles=locked_angles,
                 first_coord=first_coord.astype(int), stiffness=stiffness, damping=damping,
                 rest=rest, base_position=base_position, base_rotation=base_rotation,
                 clamp_active=bool(clamp_active), clamp_position=clamp_position,
                 clamp_rotation=clamp_rotation, gravity=gravity, rotor_omega=float(rotor_omega),
                 rotor_offset=rotor_offset, pulse_body=int(pulse_body), pulse_force=pulse_force,
                 pulse_window=pulse_window, tip_force=tip_force, t_end=float(t_end), q0=q0, v0=v0)
