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
pulse_window[0] <= t < pulse_window[1]; the constant ``tip_force`` at a free tip.

Derived from the model as built, by name (issue 23 item 3): the loads from their component
registry blocks (``Model.description['loads']``, pydriver/components.py), support B from its
block, the rotor speed from the core (``CoreModel.parameter('rotor.omega')``).  What the scene
cannot describe is refused, never dropped: a load other than the joint springs, gravity, the
pulse and the tip force (the rotation-vector springs, drag, the anchor spring, ...), a support B
other than a fixed clamp, a moving support A, and a rotor that is not turning at a constant
speed with the hub-frame equations.  A caller whose independent model leaves a load out on
purpose says so: ``scene(deck, ignore=("drag",))``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pydriver.analyses.dynamics import start_state
from pydriver.components import LOADS, SUPPORTS, component_group, load_component
from pydriver.errors import DeckError
from pydriver.model import Model

#: The loads a Scene describes (its fields above); every other load of the registry is refused.
REPRESENTED_LOADS = ("joint_springs", "gravity", "pulse", "tip_force")

#: The support B kinds a Scene describes (held still: a moving one is refused).
REPRESENTED_SUPPORTS = ("clamp",)


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
    ignored: tuple = ()          #: loads of the deck left out at the caller's request (``ignore``)


def _refuse(m: Model, group: str, what: str, ignorable: str = "",
            why: str = "the independent implementations it feeds have no such term") -> None:
    """A DeckError naming the deck, the component's group and what the scene cannot describe."""
    hint = f"; to leave it out knowingly, pass ignore=({ignorable!r},)" if ignorable else ""
    raise DeckError(m.name, group, "", f"pydriver.scene cannot represent {what}: {why}{hint}")


def _loads(m: Model, ignore: tuple) -> dict:
    """``{kind: {name: value}}`` of the loads the scene describes; every other load of the
    model refused unless ignored."""
    built = m.description["loads"]
    known = {c.kind for c in LOADS}
    unknown = [k for k in ignore if k not in known]
    if unknown:
        raise ValueError(f"scene: ignore={tuple(ignore)!r} names no load of the registry: {unknown} "
                         f"(loads: {sorted(known)})")
    for kind in built:
        if kind not in REPRESENTED_LOADS and kind not in ignore:
            c = load_component(kind)
            _refuse(m, component_group(c), f"the load {kind!r} ({c.doc})", ignorable=kind)
    # A load the deck does not have takes its declaration's values from the deck (no gravity,
    # pulse body 0, no tip force): what the scene's fields mean by "none".
    out = {}
    for kind in REPRESENTED_LOADS:
        if kind in ignore:
            continue
        if kind in built:
            out[kind] = built[kind]
        elif kind != "joint_springs":
            out[kind] = load_component(kind).pack(m.deck, {})
    return out


def _check_supports(m: Model) -> None:
    """Support B a fixed clamp or none, support A fixed."""
    d = m.description
    kind = d["support"]
    if kind is not None:
        c = {s.kind: s for s in SUPPORTS}[kind]
        if kind not in REPRESENTED_SUPPORTS:
            _refuse(m, c.group, f"the support {kind!r} ({c.doc})")
        if int(d["support_parameters"].get("motion.hinges", 0)):
            _refuse(m, c.group, f"the moving support {kind!r} (carried by the rotor or the blade)")
    if d["base_moves"]:
        _refuse(m, "clamp_a", "the moving support A (carried by the rotor or the blade)")


def _rotor(m: Model) -> tuple[float, np.ndarray]:
    """Omega [rad/s] (by name from the core) and the rotor offset (minus the centre) [m]."""
    rot = m.description["rotor"]
    if rot is None:
        return 0.0, np.asarray(m.deck["loads.rotor_offset"], float)
    if rot["profile"] != "constant" or not rot["hub"] or not rot["body_couples"]:
        _refuse(m, "rotor", f"the rotor (profile '{rot['profile']}', "
                            f"{'hub' if rot['hub'] else 'inertial'} frame, body couples "
                            f"{'on' if rot['body_couples'] else 'off'})",
                why="a Scene turns at one constant speed, with the hub-frame equations and the body couples")
    return float(m.core.parameter("rotor.omega")[0]), np.zeros(3) - np.asarray(rot["centre"], float)


def scene(path, ignore: tuple = ()) -> Scene:
    """Read a deck (or take a Model) and return its :class:`Scene`, the start made consistent
    (the equilibrium if the deck starts there).

    Parameters
    ----------
    path : path or Model
    ignore : tuple of str
        Loads of the registry (``pydriver.components.LOADS`` kinds, e.g. ``"drag"``) the caller's
        independent model leaves out on purpose; the scene then describes the model without them
        (``Scene.ignored``), except its start state, which stays the model's own (an equilibrium
        start is that of the model with them).  Any other load the scene cannot describe is
        refused.

    Raises
    ------
    DeckError
        Bad input, or a load, support or rotor of the deck that the scene cannot describe (it
        names the deck and the component).
    RunError
        The start state could not be made consistent.
    """
    m = path if isinstance(path, Model) else Model.from_deck(path)
    ignore = tuple(ignore)
    loads = _loads(m, ignore)
    _check_supports(m)
    omega, offset = _rotor(m)
    d = m.description
    b = d["bodies"]
    i_xx = b.masses * (b.lengths**2 + 3 * b.radii**2) / 12.0          # eq. 4.50
    inertia = np.column_stack([i_xx, i_xx, b.masses * b.radii**2 / 2.0])
    deck = m.deck
    q0, v0 = start_state(m)
    start = m.core.consistent_start(q0, v0)
    nq = m.nq
    springs = loads.get("joint_springs", {"stiffness": np.zeros(nq), "damping": np.zeros(nq), "rest": np.zeros(nq)})
    clamp = d["support_parameters"] if d["support"] == "clamp" else None
    pulse, weight, tip = loads.get("pulse"), loads.get("gravity"), loads.get("tip_force")
    return Scene(n_bodies=m.n_bodies, n_coords=nq, n_constraints=m.nc, lengths=b.lengths, radii=b.radii,
                 masses=b.masses, inertia=inertia, locked=b.locked,
                 locked_angles=np.column_stack([np.radians(deck["shape.gamma_deg"]),
                                                np.radians(deck["shape.beta_deg"])]),
                 first_coord=d["first_coord"], stiffness=np.asarray(springs["stiffness"], float),
                 damping=np.asarray(springs["damping"], float), rest=np.asarray(springs["rest"], float),
                 base_position=np.zeros(3), base_rotation=d["base_rotation"], clamp_active=clamp is not None,
                 clamp_position=np.asarray(clamp["position"], float) if clamp else np.zeros(3),
                 clamp_rotation=np.asarray(clamp["rotation"], float).reshape(3, 3, order="F") if clamp
                 else np.zeros((3, 3)),
                 gravity=np.asarray(weight["g"], float) if weight else np.zeros(3),
                 rotor_omega=omega, rotor_offset=offset,
                 pulse_body=int(pulse["body"][0]) if pulse else 0,
                 pulse_force=np.asarray(pulse["force"], float) if pulse else np.zeros(3),
                 pulse_window=np.array([pulse["t_start"][0], pulse["t_end"][0]]) if pulse else np.zeros(2),
                 tip_force=np.asarray(tip["force"], float) if tip else np.zeros(3),
                 t_end=float(deck["solver.t_end"]), q0=start["q"], v0=start["v"], ignored=ignore)
