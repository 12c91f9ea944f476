"""The component registry: every load and support of a model declares here, once, the parameters its
Fortran constructor reads by name (name, unit, shape, default, and the deck keys that feed it),
and when a deck has it.  :mod:`pydriver.assembly` packs each present component from its
declaration, :mod:`pydriver.core` sends the values as the component's parameter block, and the
factory (``src_fortran/loads/factory.f90``) hands the block to the constructor, which asks for
each value by name (``src_fortran/parameter_block.f90``).  No layout is written by position.

The deck keys themselves, with their ranges and defaults, stay in :mod:`pydriver.schema`, the
one deck schema; a parameter fed straight by a key takes that key's value (and default), one fed
by several keys, or by what assembly derived from them (the joint constants), says how.

A new load: its Fortran file, its lines in ``loads/factory.f90`` and ``src_fortran/meson.build``,
its :class:`Component` in :data:`LOADS`, and its keys in the schema (docs/architecture.md).  The
integrator's settings are declared the same way (:data:`SOLVER`) and travel as a block too.  A new
support the same with ``supports/factory.f90`` and :data:`SUPPORTS`; every support also gets
the prescribed motion of its deck group under ``motion.`` (:func:`support_motion_parameters`;
the names are declared in :mod:`pydriver.motions`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from pydriver.deckfile import Deck
from pydriver.motions import DEG, rot_y, rot_z, support_motion
from pydriver.schema import lookup

#: Sizes of the shapes a parameter may have, given the number of bodies n (None: any size, the
#: Fortran constructor checks it against what it knows, e.g. the number of coordinates).
SHAPES = {"scalar": lambda n: 1, "vec3": lambda n: 3, "matrix3": lambda n: 9, "body": lambda n: n,
          "coords": lambda n: None,
          "free_joints x 3": lambda n: None, "list": lambda n: None}


@dataclass(frozen=True)
class Parameter:
    """One named value of a component's parameter block."""

    name: str                     #: what the Fortran constructor asks for
    unit: str                     #: unit of the value in the block (SI, radians)
    shape: str                    #: a key of SHAPES
    keys: tuple = ()              #: the deck keys ('group.key') that feed it
    #: the value from the deck and what assembly built (``built``, below); None: the one key's value
    derive: Callable | None = None
    integer: bool = False         #: an integer array (a body index) rather than reals
    word: bool = False            #: a word (a choice: the linear solver), sent as its character codes
    doc: str = ""

    @property
    def default(self):
        """The default of a parameter fed straight by one key: that key's schema default."""
        if self.derive is None and len(self.keys) == 1:
            group, name = self.keys[0].split(".")
            return lookup(group, name).default
        return None

    def value(self, deck: Deck, built: dict) -> np.ndarray | str:
        """The parameter's value for this deck, as a numpy array of its size (a word: a str)."""
        raw = self.derive(deck, built) if self.derive is not None else deck[self.keys[0]]
        if raw is None:
            # A key without a default that the deck leaves out: required once its component is present.
            deck.fail(*self.keys[0].split("."), "is required here (no default)")
        if self.word:
            return str(raw)
        a = np.asarray(raw, dtype=np.int32 if self.integer else float).reshape(-1)
        size = SHAPES[self.shape](deck.n_bodies)
        if size is not None and a.size != size:
            raise ValueError(f"parameter {self.name}: {a.size} values for shape {self.shape} ({size})")
        return a


@dataclass(frozen=True)
class Component:
    """A load (or support) kind of the core's factory with its parameters."""

    kind: str                     #: the factory's name for it
    parameters: tuple             #: its Parameter declarations
    present: Callable             #: (deck, built) -> whether the deck has it
    context: str = ""             #: prefixed to the core's messages about it ('&springs')
    group: str = ""               #: a support's deck group (its motion, its 'active' key)
    doc: str = ""

    def pack(self, deck: Deck, built: dict) -> dict:
        """``{name: value}`` of every parameter, for :meth:`pydriver.core.CoreModel.add_load`."""
        return {p.name: p.value(deck, built) for p in self.parameters}

    @property
    def deck_keys(self) -> dict:
        """``{name: 'group.key'}`` of the parameters fed by one deck key: a value the core
        refuses by its parameter name is reported as that key."""
        return {p.name: p.keys[0] for p in self.parameters if len(p.keys) == 1}


def _nonzero(key: str) -> Callable:
    return lambda deck, built: bool(np.any(np.asarray(deck[key], float) != 0.0))


def _built(name: str) -> Callable:
    return lambda deck, built: built[name]


def _drag_stream(deck: Deck, built: dict) -> np.ndarray:
    # Forward flight at V is a free stream of -V along the deck's x axis.
    return np.asarray(deck["drag.stream_velocity"], float) - np.array([deck["drag.forward_speed"], 0.0, 0.0])


#: What assembly hands the derivations (``built``): ``stiffness``, ``damping``, ``rest`` per
#: coordinate and ``rotation_vector`` (pydriver.assembly.joint_constants and
#: rotation_vector_springs).  The loads in the order they are added to the model.
LOADS: tuple[Component, ...] = (
    Component(
        "rotation_springs", context="&cable",
        doc="springs and dampers on each joint's rotation vector (physical cable parameters, xyz joints)",
        present=_built("rotation_vector"),
        parameters=(
            Parameter("stiffness", "Nm/rad", "free_joints x 3", ("cable.ei", "cable.gj"), _built("stiffness"),
                      doc="K_x, K_y, K_z per free joint: EI/l, EI/l, GJ/l"),
            Parameter("damping", "Nms/rad", "free_joints x 3", ("cable.damping_time",), _built("damping"),
                      doc="damping_time times the stiffness"))),
    Component(
        "joint_springs", context="&springs",
        doc="linear springs and dampers on every joint coordinate",
        present=lambda deck, built: not built["rotation_vector"] and bool(
            np.any(built["stiffness"] != 0.0) or np.any(built["damping"] != 0.0)),
        parameters=(
            Parameter("stiffness", "Nm/rad", "coords", ("springs.c_gamma", "springs.c_beta", "springs.c_twist",
                                                        "cable.ei", "cable.gj"), _built("stiffness")),
            Parameter("damping", "Nms/rad", "coords", ("springs.d_gamma", "springs.d_beta", "springs.d_twist",
                                                       "cable.damping_time"), _built("damping")),
            Parameter("rest", "rad", "coords", ("springs.rest_gamma_deg", "springs.rest_beta_deg"), _built("rest")))),
    Component(
        "gravity", present=_nonzero("loads.gravity"), doc="uniform gravity",
        parameters=(Parameter("g", "m/s^2", "vec3", ("loads.gravity",)),)),
    Component(
        "pulse", present=lambda deck, built: deck["loads.pulse_body"] > 0, doc="rectangular force pulse on one body",
        parameters=(
            Parameter("body", "-", "scalar", ("loads.pulse_body",), integer=True),
            Parameter("force", "N", "vec3", ("loads.pulse_force",)),
            Parameter("t_start", "s", "scalar", ("loads.pulse_start",)),
            Parameter("t_end", "s", "scalar", ("loads.pulse_end",)))),
    Component(
        "tip_force", present=_nonzero("loads.tip_force"), doc="constant force at the free tip",
        parameters=(Parameter("force", "N", "vec3", ("loads.tip_force",)),)),
    Component(
        "drag", present=lambda deck, built: "drag" in deck.groups, doc="cross-flow aerodynamic drag",
        parameters=(
            Parameter("air_density", "kg/m^3", "scalar", ("drag.air_density",)),
            Parameter("stream", "m/s", "vec3", ("drag.stream_velocity", "drag.forward_speed"), _drag_stream,
                      doc="free stream in the inertial frame: stream_velocity - (forward_speed, 0, 0)"),
            Parameter("cd", "-", "body", ("drag.cd",)))),
    Component(
        "anchor", present=lambda deck, built: "anchor" in deck.groups,
        doc="linear spring from a joint point to a point fixed in the model frame",
        parameters=(
            Parameter("joint", "-", "scalar", ("anchor.joint",), integer=True),
            Parameter("point", "m", "vec3", ("anchor.point",)),
            Parameter("stiffness", "N/m", "scalar", ("anchor.stiffness",)))),
)


def _clamp_position(deck: Deck, built: dict) -> np.ndarray:
    # from_start: where the start shape's tip is (``built['start_shape']``, CoreModel.shape).
    return built["start_shape"]["joints"][-1] if deck["clamp_b.from_start"] else deck["clamp_b.position"]


def _clamp_rotation(deck: Deck, built: dict) -> np.ndarray:
    if deck["clamp_b.from_start"]:
        r = built["start_shape"]["last_rotation"]
    else:
        r = rot_z(deck["clamp_b.gamma_deg"] * DEG) @ rot_y(deck["clamp_b.beta_deg"] * DEG)
    return np.asarray(r, float).ravel(order="F")       # column by column, as Fortran reads it


#: Support B kinds; a deck has at most one (each is present by its group's ``active`` key).
#: ``built`` holds ``start_shape``, the deck's start shape (CoreModel.shape of q0).
SUPPORTS: tuple[Component, ...] = (
    Component(
        "clamp", group="clamp_b", context="clamp B", present=lambda deck, built: bool(deck["clamp_b.active"]),
        doc="clamp B: the tip's position and the last body's orientation held (6 rows)",
        parameters=(
            Parameter("position", "m", "vec3", ("clamp_b.position", "clamp_b.from_start"), _clamp_position),
            Parameter("rotation", "-", "matrix3", ("clamp_b.gamma_deg", "clamp_b.beta_deg", "clamp_b.from_start"),
                      _clamp_rotation, doc="R_B0, column by column"))),
    Component(
        "ball", group="ball_b", context="ball B", present=lambda deck, built: bool(deck["ball_b.active"]),
        doc="ball B: the tip's position held, the last body free to turn about it (3 rows)",
        parameters=(Parameter("position", "m", "vec3", ("ball_b.position",)),)),
)


#: The settings of a time integration (IDA: ``src_fortran/dae_integrator.f90``, settings_from_block
#: reads them by these names), each the deck's &solver key of the same name.  ``built`` holds
#: ``linear_solver``, the deck's choice with 'auto' resolved (pydriver.model.Model.linear_solver).
SOLVER = Component(
    "solver", context="&solver", present=lambda deck, built: True,
    doc="tolerances, step limits, linear solver and kernels of a time integration (IDA)",
    parameters=(
        Parameter("rtol", "-", "scalar", ("solver.rtol",)),
        Parameter("atol", "-", "scalar", ("solver.atol",), doc="on q [rad] and v [rad/s]"),
        Parameter("atol_multiplier", "N, Nm", "scalar", ("solver.atol_multiplier",)),
        Parameter("h_max", "s", "scalar", ("solver.h_max",), doc="0: no limit"),
        Parameter("max_steps", "-", "scalar", ("solver.max_steps",), integer=True),
        Parameter("linear_solver", "-", "scalar", ("solver.linear_solver",), _built("linear_solver"), word=True,
                  doc="one of pydriver.schema.LINEAR_SOLVERS ('auto' resolved)"),
        Parameter("jacobian", "-", "scalar", ("solver.jacobian",), word=True),
        Parameter("jacobian_max_age", "-", "scalar", ("solver.jacobian_max_age",), integer=True),
        Parameter("vector_kernels", "-", "scalar", ("solver.vector_kernels",), word=True)))


def solver_settings(deck: Deck, linear_solver: str) -> dict:
    """``{name: value}`` of :data:`SOLVER` for this deck (Python numbers and words), the
    settings :meth:`pydriver.core.CoreModel.start` and the other integrations take; a caller may
    change a value (``dict(settings, rtol=1e-10)``) before passing them on."""
    values = SOLVER.pack(deck, {"linear_solver": linear_solver})
    return {name: v if isinstance(v, str) else v.item() for name, v in values.items()}


def support_of(deck: Deck) -> Component | None:
    """The support B the deck has (None: a free end); two at once are a DeckError."""
    present = [c for c in SUPPORTS if c.present(deck, {})]
    if len(present) > 1:
        deck.fail(present[1].group, "active", f"the chain's end has one support, and &{present[0].group} "
                  "is active too")
    return present[0] if present else None


def support_motion_parameters(support: Component, deck: Deck, rot: dict | None, position) -> dict:
    """The prescribed motion of the support's group, its block's entries under ``motion.``
    (pydriver.motions.support_motion; read by rotorcable_motion_builder)."""
    return support_motion(deck, rot, support.group, position)


def add_loads(core, deck: Deck, built: dict) -> dict:
    """Add every load of :data:`LOADS` the deck has to the model in ``core``; returns what was
    added, ``{kind: {name: value}}`` in the order added (``Model.description['loads']``)."""
    added = {}
    for component in LOADS:
        if component.present(deck, built):
            added[component.kind] = component.pack(deck, built)
            core.add_load(component.kind, added[component.kind], context=component.context,
                          deck_keys=component.deck_keys)
    return added


def component_group(component: Component) -> str:
    """The deck group a component is read from: a support's own group, a load's first key's."""
    return component.group or component.parameters[0].keys[0].split(".")[0]


def load_component(kind: str) -> Component:
    """The declaration of the load ``kind`` (KeyError for a kind not in :data:`LOADS`)."""
    return {c.kind: c for c in LOADS}[kind]
