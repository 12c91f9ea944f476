"""The component registry (issue 23 item 1): every load declares its parameters once, in
pydriver/components.py, in the deck schema's terms; the core reads them by name from a keyed
parameter block (src_fortran/parameter_block.f90) and refuses a missing name or a wrong size
through the error channel instead of reading a flat array by position."""

from __future__ import annotations

import re

import numpy as np
import pytest

from conftest import ROOT
from pydriver.components import LOADS, SHAPES, SOLVER, SUPPORTS
from pydriver.core import CoreModel, _parameter_arrays
from pydriver.errors import DeckError, RunError
from pydriver.model import Model
from pydriver.motions import ANGLES, HINGE, ROTOR_PROFILES, angle, motion_parameters
from pydriver.schema import LINEAR_SOLVERS, lookup


def three_bodies() -> CoreModel:
    core = CoreModel("blocks", [0.1] * 3, [0.01] * 3, [0.2] * 3, "zy", [False] * 3, np.zeros((2, 3)))
    return core


def test_parameters_travel_by_name():
    names_r, sizes_r, reals, names_i, sizes_i, ints = _parameter_arrays(
        {"air_density": 1.2, "stream": [1.0, 2.0, 3.0], "body": np.int32(2), "cd": [0.5, 0.6]})
    assert names_r.split() == ["air_density", "stream", "cd"] and list(sizes_r) == [1, 3, 2]
    assert list(reals) == [1.2, 1.0, 2.0, 3.0, 0.5, 0.6]
    assert names_i.split() == ["body"] and list(sizes_i) == [1] and list(ints) == [2]
    names_r, sizes_r, reals, names_i, sizes_i, ints = _parameter_arrays({"linear_solver": "chain"})
    assert names_i.split() == ["linear_solver"] and list(sizes_i) == [5] and bytes(ints.astype("u1")) == b"chain"


def test_a_missing_parameter_is_an_error_naming_load_and_name():
    core = three_bodies()
    with pytest.raises(RunError, match=r"drag: no parameter 'cd'"):
        core.add_load("drag", {"air_density": 1.225, "stream": np.zeros(3)})


def test_a_parameter_of_the_wrong_size_is_an_error_naming_the_sizes():
    core = three_bodies()
    with pytest.raises(RunError, match=r"gravity: parameter 'g' has 2 values, expected 3"):
        core.add_load("gravity", {"g": [0.0, -9.81]})
    with pytest.raises(RunError, match=r"drag: parameter 'cd' has 2 values, expected 3"):
        core.add_load("drag", {"air_density": 1.225, "stream": np.zeros(3), "cd": [1.0, 1.0]})
    with pytest.raises(RunError, match=r"pulse: parameter 'body' has 0 values, expected 1"):
        core.add_load("pulse", {"body": np.zeros(0, np.int32), "force": np.ones(3), "t_start": 0.0, "t_end": 1.0})


def test_an_unknown_load_kind_is_an_error():
    with pytest.raises(RunError, match="unknown load kind 'magnet'"):
        three_bodies().add_load("magnet", {})


def test_an_unknown_support_kind_is_an_error():
    with pytest.raises(RunError, match="unknown support kind 'hook'"):
        three_bodies().add_support("hook", {})


def test_a_support_without_a_declared_parameter_is_an_error_naming_it():
    motion = {"motion.hinges": np.int32(0)}
    with pytest.raises(RunError, match=r"clamp: no parameter 'rotation'"):
        three_bodies().add_support("clamp", {"position": np.zeros(3), **motion})
    with pytest.raises(RunError, match=r"clamp: parameter 'rotation' has 4 values, expected 9"):
        three_bodies().add_support("clamp", {"position": np.zeros(3), "rotation": np.eye(2), **motion})


def test_the_chain_end_takes_one_support():
    core = three_bodies()
    clamp = {"position": [0.3, 0.0, 0.0], "rotation": np.eye(3).ravel(), "motion.hinges": np.int32(0)}
    core.add_support("clamp", clamp)
    with pytest.raises(RunError, match="has a support already"):
        core.add_support("clamp", clamp)


def test_no_support_is_downcast_outside_its_own_file():
    """What the model asks of support B is a procedure of support_type (reach_target,
    motion_twist), not a `type is (clamp_support)` branch in projection or sampling."""
    for path in sorted((ROOT / "src_fortran").rglob("*.f90")):
        if path.parent.name != "supports":
            assert not re.search(r"type is \(\w+_support\)", path.read_text()), path.name


@pytest.mark.parametrize("component", LOADS + SUPPORTS + (SOLVER,), ids=lambda c: c.kind)
def test_every_declared_parameter_is_fed_by_schema_keys(component):
    """Each parameter names the deck keys that feed it; they are keys of the schema, and one fed
    straight by a single key has that key's unit and shape, so the schema (range, default, doc)
    describes the value the core gets."""
    assert component.parameters and component.doc
    for p in component.parameters:
        assert p.shape in SHAPES and p.keys, p.name
        for dotted in p.keys:
            assert lookup(*dotted.split(".")) is not None, f"{component.kind}.{p.name}: {dotted} is no deck key"
        if p.derive is None:
            assert len(p.keys) == 1
            key = lookup(*p.keys[0].split("."))
            assert (key.unit, key.shape) == (p.unit, p.shape), f"{component.kind}.{p.name}"
            assert p.default == key.default


def test_no_load_constructor_reads_a_flat_array_by_position():
    """The constructors take a parameter block; none takes (ints, reals) any more."""
    for path in sorted((ROOT / "src_fortran" / "loads").glob("*.f90")):
        text = path.read_text()
        assert not re.search(r"real\(dp\), intent\(in\) :: reals\(:\)", text), path.name
        assert not re.search(r"\breals\(\d", text), path.name


@pytest.mark.parametrize("component", LOADS + SUPPORTS, ids=lambda c: c.kind)
def test_every_declared_kind_is_known_to_its_factory(component):
    """The registry and the Fortran factories name the same kinds: an empty block reaches the
    constructor, which refuses it (a missing parameter, or the rotation springs' joints of
    this zy chain), instead of the factory's 'unknown ... kind'."""
    core = three_bodies()
    add = core.add_support if component in SUPPORTS else core.add_load
    with pytest.raises(RunError) as exc:
        add(component.kind, {})
    assert "unknown" not in str(exc.value)
    assert "no parameter" in str(exc.value) or component.kind == "rotation_springs"


@pytest.mark.parametrize("component", SUPPORTS, ids=lambda c: c.kind)
def test_every_support_group_has_an_active_key(component):
    """support_of names '&group active' when two supports are switched on."""
    assert lookup(component.group, "active") is not None and lookup(component.group, "active").type == "bool"


def test_the_solver_settings_are_declared_once():
    """The integrator settings travel as a keyed block (pydriver.components.SOLVER): a missing
    name is refused by the core naming it, and each declared name is a &solver deck key."""
    model = Model.from_deck(ROOT / "inputs" / "six_link_dynamic.nml")
    settings = model.solver_settings()
    assert list(settings) == [p.name for p in SOLVER.parameters]
    assert all(p.keys == (f"solver.{p.name}",) for p in SOLVER.parameters)
    del settings["atol"]
    with pytest.raises(RunError, match=r"solver: no parameter 'atol'"):
        model.core.start(settings, 0.0, model.q0, model.v0)


@pytest.mark.parametrize("choice", [c for c in lookup("solver", "linear_solver").choices if c != "auto"] + ["lu"])
def test_the_linear_solvers_are_written_once(choice):
    """The schema's choices (pydriver.schema.LINEAR_SOLVERS) are the words the core takes, by name:
    every one starts an integration, and any other word is a DeckError naming the key."""
    model = Model.from_deck(ROOT / "inputs" / "six_link_dynamic.nml")
    settings = dict(model.solver_settings(), linear_solver=choice)
    assert lookup("solver", "linear_solver").choices == ("auto", *LINEAR_SOLVERS)
    if choice in LINEAR_SOLVERS:
        session = model.core.start(settings, 0.0, model.q0, model.v0)
        q, _ = session.advance([1.0e-3])
        session.close()
        assert np.all(np.isfinite(q))
    else:
        with pytest.raises(DeckError, match="linear_solver") as exc:
            model.core.start(settings, 0.0, model.q0, model.v0)
        assert "'lu' is not one of this core's" in str(exc.value)


def _values(names) -> dict:
    # A table or a series gets three values (a spline needs three points), a scalar one.
    return {name: [0.0, 1.0, 2.0] if name in ("t", "theta", "coefficients") else 0.5 for name in names}


@pytest.mark.parametrize("kind", sorted(ANGLES))
def test_every_declared_angle_is_read_by_name(kind):
    """A hinge's angle travels by name (pydriver.motions.ANGLES, src_fortran/motion/
    angle_function.f90): the core builds every declared kind from exactly its declared
    parameters, and asks for each of them by name."""
    values = _values(ANGLES[kind])
    full = motion_parameters([((0.0, 0.0, 1.0), (0.0, 0.0, 0.0), angle(kind, **values))])
    assert set(full) == {"motion.hinges"} | {f"motion.hinge1.{n}" for n in (*HINGE, *ANGLES[kind])}
    three_bodies().set_base(np.zeros(3), np.eye(3), full)
    for name in (*HINGE, *ANGLES[kind]):
        part = {k: v for k, v in full.items() if k != f"motion.hinge1.{name}"}
        with pytest.raises((RunError, DeckError), match=rf"no parameter 'motion.hinge1.{name}'"):
            three_bodies().set_base(np.zeros(3), np.eye(3), part)


def test_an_unknown_angle_kind_is_an_error_naming_it():
    full = motion_parameters([((0.0, 0.0, 1.0), (0.0, 0.0, 0.0), angle("constant", value=0.1))])
    full["motion.hinge1.angle"] = "spiral"
    with pytest.raises((RunError, DeckError), match="'spiral' is not an angle kind"):
        three_bodies().set_base(np.zeros(3), np.eye(3), full)
    with pytest.raises(ValueError, match="declared"):
        angle("fourier", azimuth0=0.0)


@pytest.mark.parametrize("profile", sorted(ROTOR_PROFILES))
def test_every_declared_rotor_profile_is_read_by_name(profile):
    """The rotor's speed profile travels by name (pydriver.motions.ROTOR_PROFILES,
    src_fortran/motion/rotor.f90): the core asks for each declared parameter by name."""
    values = {"constant": {"omega": 10.0}, "table": {"t": [0.0, 1.0, 2.0], "omega": [0.0, 5.0, 10.0]},
              "runup": {"omega_start": 0.0, "omega_end": 10.0, "t_start": 0.1, "duration": 1.0}}[profile]
    full = {"profile": profile, "centre": np.zeros(3), "hub": np.int32(1), "body_couples": np.int32(1), **values}
    three_bodies().set_rotor(full)
    for name in ("centre", "hub", "body_couples", *ROTOR_PROFILES[profile]):
        part = {k: v for k, v in full.items() if k != name}
        with pytest.raises((RunError, DeckError), match=rf"no parameter '{name}'"):
            three_bodies().set_rotor(part)
    with pytest.raises(DeckError, match="'spin' is not a speed profile"):
        three_bodies().set_rotor(dict(full, profile="spin"))


def test_no_motion_is_read_by_position():
    """The motion and rotor builders read names, not offsets into flat arrays."""
    for name in ("builder.f90", "rotor.f90", "angle_function.f90"):
        text = (ROOT / "src_fortran" / "motion" / name).read_text()
        assert not re.search(r"\b(reals|ints|params)\(\w+ *[+:]", text), name
    assert not re.search(r"motion_(ints|reals)", (ROOT / "pydriver" / "components.py").read_text())


def test_rotor_profiles_are_the_deck_choices():
    """The rotor profiles the core is given parameters for are exactly the deck's choices."""
    from pydriver.schema import ROTOR_PROFILE_NAMES, lookup
    assert set(ROTOR_PROFILES) == set(ROTOR_PROFILE_NAMES)
    assert tuple(lookup("rotor", "profile").choices) == ROTOR_PROFILE_NAMES
